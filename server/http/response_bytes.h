#pragma once
// What a response holds while a slow client reads it. A result file is streamed from disk in
// small reads, not copied into the response: 100 clients that asked for a 12.7 MB passes.exr
// and read nothing took the server from 139 to 1,172 MiB (docs/reliability.md). An image encoded
// on request (a running job's pass, another exposure) is held once per answer, and all of them
// together are bounded: past the bound the server answers 503 with Retry-After rather than
// encode another. These answers fit the one range they serve to their size themselves (an open or
// overlong end cut at theirs; 416 with a problem past it), whether held or streamed.
//
// Both carry a validator: a file its ETag (its size, modification time and inode) and
// Last-Modified, an encoded image the ETag of its bytes. If-None-Match (or, without it,
// If-Modified-Since) that matches is answered 304, and a range is served under If-Range only
// while the validator it names is still the answer's. An image that changes while its job runs
// (a running job's latest pass) serves a range under a matching If-Range alone, so that a
// resumed download never joins two passes.
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace httplib {
struct Request;
struct Response;
}

namespace tessera::server {

// Takes the request's Range aside before it is routed. httplib applies a Range to any answer it
// sends: a job's status came back cut to a few bytes under a 200, and a POST that queued a job
// answered 416 with no body, so a client would submit it again. Only a result file served by
// send_file or EncodedResponses puts it back, fitted to its size. Several ranges give the whole
// body; If-Range is kept for the answer to compare with its validator.
void hold_range(httplib::Request& req);

// Streams the file at `path` (which exists: the caller resolved it) in 64 KiB reads; a small
// file (a report, a curve) is answered from memory, so httplib may compress it.
void send_file(const httplib::Request& req, httplib::Response& res, const std::string& path, const std::string& content_type);

class EncodedResponses {
public:
    explicit EncodedResponses(uint64_t budget_bytes) : state_(std::make_shared<State>(budget_bytes)) {}

    // Encodes with `encode` and answers with its bytes, unless responses encoded before and
    // still being sent hold `estimate` bytes too many of the budget (one is always allowed):
    // then it returns false and has sent nothing.
    // `changing`: the same URL answers other bytes later (a running job's pass), so a range
    // is served only under an If-Range naming these bytes.
    bool send(const httplib::Request& req, httplib::Response& res, uint64_t estimate,
              const std::function<std::vector<unsigned char>()>& encode, const std::string& content_type,
              bool changing = false);
    uint64_t held() const { return state_->held.load(); }
    uint64_t budget() const { return state_->budget; }

private:
    struct State {
        explicit State(uint64_t b) : budget(b) {}
        const uint64_t budget;
        std::atomic<uint64_t> held{0};
    };
    std::shared_ptr<State> state_;  // outlives the HttpApi while a response still holds bytes
};

}  // namespace tessera::server
