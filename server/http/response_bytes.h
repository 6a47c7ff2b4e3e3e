#pragma once
// What a response holds while a slow client reads it. A result file is streamed from disk in
// small reads, not copied into the response: 100 clients that asked for a 12.7 MB passes.exr
// and read nothing took the server from 139 to 1,172 MiB (docs/reliability.md). An image encoded
// on request (a running job's pass, another exposure) is held once per answer, and all of them
// together are bounded: past the bound the server answers 503 with Retry-After rather than
// encode another. httplib checks a Range only against a body it holds, so these answers fit the
// one range they serve (begin_body keeps at most one) to their size themselves: 416 past it.
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

// Streams the file at `path` (which exists: the caller resolved it) in 64 KiB reads; a small
// file (a report, a curve) is answered from memory, so httplib may compress it.
void send_file(const httplib::Request& req, httplib::Response& res, const std::string& path, const std::string& content_type);

class EncodedResponses {
public:
    explicit EncodedResponses(uint64_t budget_bytes) : state_(std::make_shared<State>(budget_bytes)) {}

    // Encodes with `encode` and answers with its bytes, unless responses encoded before and
    // still being sent hold `estimate` bytes too many of the budget (one is always allowed):
    // then it returns false and has sent nothing.
    bool send(const httplib::Request& req, httplib::Response& res, uint64_t estimate,
              const std::function<std::vector<unsigned char>()>& encode, const std::string& content_type);
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
