#pragma once
// What a response holds while a slow client reads it. A result file is streamed from disk in
// small reads, not copied into the response: 100 clients that asked for a 12.7 MB passes.exr
// and read nothing took the server from 139 to 1,172 MiB (docs/reliability.md). An image encoded
// on request (a running job's pass, another exposure) is held once per answer, and all of them
// together are bounded: past the bound the server answers 503 with Retry-After rather than
// encode another. These answers fit the one range they serve to their size themselves (an open or
// overlong end cut at theirs; 416 with a problem past it), whether held or streamed.
//
// Both carry a validator: a file its ETag (its size, modification time and inode; weak for a
// text answer httplib may compress) and, once it has been in place a second, Last-Modified (a
// date within its second could be another file's); an encoded image a weak ETag of its bytes. Preconditions are evaluated as RFC 9110 orders them: If-Match and If-Unmodified-Since
// that fail are 412, If-None-Match (or, without it, If-Modified-Since) that matches is 304, and
// a range is served under If-Range only while the strong validator it names is the answer's.
// An image that changes while its job runs (a running job's latest pass) serves no range, so
// that a resumed download never joins two passes.
#include <atomic>
#include <cstdint>
#include <ctime>
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

// An HTTP date (IMF-fixdate) of a time.
std::string http_date(time_t t);
// What every answer carries: its Date, and `Accept-Ranges: none` unless a result file said it
// takes ranges (httplib would say `bytes` on a HEAD of any route).
void stamp(httplib::Response& res);
// Forgets what this thread held for its last answer, once it is sent: a request httplib refuses
// before routing starts from nothing.
void end_answer();

// Streams the file at `path` (which exists: the caller resolved it) in 64 KiB reads; a small
// file (a report, a curve) is answered from memory, so httplib may compress it.
void send_file(const httplib::Request& req, httplib::Response& res, const std::string& path, const std::string& content_type);

class EncodedResponses {
public:
    explicit EncodedResponses(uint64_t budget_bytes) : state_(std::make_shared<State>(budget_bytes)) {}

    // Encodes with `encode` and answers with its bytes, unless responses encoded before and
    // still being sent hold `estimate` bytes too many of the budget (one is always allowed):
    // then it returns false and has sent nothing.
    // `live` names what a URL that answers other bytes later shows now (a running job's pass):
    // its weak tag, and no range. Otherwise the tag is the bytes' (weak: an encoder may write
    // the time into them) and a range is served.
    bool send(const httplib::Request& req, httplib::Response& res, uint64_t estimate,
              const std::function<std::vector<unsigned char>()>& encode, const std::string& content_type,
              const std::string& live = "");
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
