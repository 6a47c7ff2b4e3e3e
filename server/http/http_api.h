#pragma once
// The HTTP API v1 over a JobQueue (routes in http_api.cpp, described in api/openapi.yaml).
#include <atomic>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "server/http/bearer_auth.h"
#include "server/http/connection_guard.h"
#include "server/http/response_bytes.h"
#include "server/queue/job_queue.h"
#include "server/loggable.h"

namespace tessera::server {
class ConnectionStream;
struct Problem;
}

namespace httplib {
class Server;
struct Request;
struct Response;
}

namespace tessera::server {

struct HttpLimits {
    size_t max_job_body = 1 << 20;         // bytes of a job's JSON
    size_t max_upload = 256ull << 20;      // bytes of an uploaded scene
    size_t max_head_bytes = 64 << 10;      // a request's line and headers
    uint64_t max_bodies_in_flight = 1ull << 30;  // bytes all request bodies being read at once may take
    uint64_t max_encoded = 512ull << 20;  // bytes of images encoded on request and not yet sent (response_bytes.h)
    int max_json_depth = 64;               // nested arrays and objects of a job's JSON
    ConnectionLimits connections;          // bound, deadlines and spare threads (connection_guard.h)
    // Who may use it: with tokens, every /v1 route (and /metrics unless metrics_open) needs
    // one; /healthz and /readyz stay open.
    BearerAuth auth;
    bool metrics_open = false;
    // GET /v1/events: a stream ends after this long (clients reconnect with Last-Event-ID), and
    // sends a comment when nothing happened for keep_alive_s.
    double event_stream_s = 300;
    double event_keep_alive_s = 15;
};

// Whether a Content-Type header names JSON: application/json or application/*+json, in any
// case, with or without parameters.
bool is_json_media_type(const std::string& header);
// The methods a path answers to ("GET, HEAD, POST"), or "" for a path no route takes.
std::string allowed_methods(const std::string& path);

class HttpApi {
public:
    HttpApi(JobQueue& queue, HttpLimits limits, std::string openapi_path);
    ~HttpApi();
    // Binds (port 0 picks a free port) and returns the port; throws on failure.
    int bind(const std::string& host, int port);
    // Serves until stop(); call from the thread that should block.
    void serve();
    void stop();

private:
    void routes();
    void event_routes();
    void page_routes();
    std::string metrics_text();
    bool needs_token(const std::string& path) const;
    size_t body_limit(const httplib::Request& req) const;
    // Answers a request from its head alone when it must be refused (true): no body is read.
    bool refuse_before_body(const httplib::Request& req, httplib::Response& res);
    // Whether `path` names a job the queue does not have (its route answers 404, which a
    // precondition does not override: RFC 9110 13.2.1).
    bool names_missing_job(const std::string& path);
    // Each request's body budget, taken from the shared bound before a byte is read, and given
    // back when the request is answered.
    void begin_body(httplib::Request& req, ConnectionStream& strm);
    // Answers with the problem and ends the connection after it (what is left of the request
    // is not read as another).
    void answer_and_close(httplib::Response& res, const Problem& p);
    void end_request();
    // Why no job can be accepted now (shutting down, the store or Redis unreachable), or "".
    std::string unready_reason();
    // /healthz and /readyz answered on a connection past the --max-connections bound: the
    // whole HTTP response, or "" for any other path.
    std::string probe_answer(const std::string& path);

    JobQueue& queue_;
    HttpLimits limits_;
    std::string openapi_path_;
    // Before server_: the guard outlives the connection threads that report to it.
    std::unique_ptr<ConnectionGuard> guard_;
    std::unique_ptr<httplib::Server> server_;
    std::atomic<uint64_t> bodies_in_flight_{0};
    EncodedResponses encoded_{limits_.max_encoded};
    // Answers with `encode`'s bytes, or throws 503 busy past limits_.max_encoded; `live` as
    // EncodedResponses::send.
    void send_encoded(const httplib::Request& req, httplib::Response& res, uint64_t estimate, const std::string& content_type,
                      const std::function<std::vector<unsigned char>()>& encode, const std::string& live = "");
    std::mutex probe_mutex_;  // readiness as the refusing thread last asked it
    std::chrono::steady_clock::time_point probe_at_;
    std::string probe_reason_;
    std::mutex status_mutex_;
    std::map<int, uint64_t> responses_by_status_;
};

}  // namespace tessera::server
