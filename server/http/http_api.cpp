#include "server/http/http_api.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <regex>
#include <type_traits>
#include <utility>
#include <vector>
#include <sstream>

#include <httplib.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "api/job_schema.h"
#include "api/json_text.h"
#include "api/result_files.h"
#include "engine/io/image_io.h"
#include "engine/render/aov.h"
#include "server/http/connection_stream.h"
#include "server/http/problem.h"
#include "server/http/response_bytes.h"

namespace tessera::server {
using nlohmann::json;
using api::json_text;

namespace {

thread_local std::chrono::steady_clock::time_point request_start;

void send_json(httplib::Response& res, int status, const json& body) {
    res.status = status;
    res.set_content(json_text(body), "application/json");
}

void send_problem(httplib::Response& res, const Problem& p) {
    json body = {{"type", "/problems/" + p.slug}, {"title", p.title}, {"status", p.status}, {"detail", p.what()}};
    if (p.field) body["field"] = *p.field;
    if (!p.location.empty()) body["location"] = p.location;
    if (!p.error_id.empty()) body["error_id"] = p.error_id;
    if (p.retry_after > 0) res.set_header("Retry-After", std::to_string(p.retry_after));
    res.status = p.status;
    res.set_content(json_text(body), "application/problem+json");
}

std::string read_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

// ?exposure=EV on image.png: stops of exposure applied to the linear values before the sRGB
// curve (0 when absent).
float exposure_param(const httplib::Request& req, const std::string& file) {
    if (!req.has_param("exposure")) return 0.f;
    if (file != "image.png")
        throw Problem(400, "invalid-parameter", "Invalid query parameter", "exposure applies to image.png only").with_field("exposure");
    const std::string v = req.get_param_value("exposure");
    char* end = nullptr;
    const double ev = v.empty() || v.size() > 24 ? NAN : std::strtod(v.c_str(), &end);
    if (!std::isfinite(ev) || end != v.c_str() + v.size() || ev < -16 || ev > 16)
        throw Problem(400, "invalid-parameter", "Invalid query parameter", "exposure must be a number of stops in [-16, 16]").with_field("exposure");
    return float(ev);
}

size_t size_param(const httplib::Request& req, const char* name, size_t fallback, size_t lo, size_t hi) {
    if (!req.has_param(name)) return fallback;
    const std::string v = req.get_param_value(name);
    if (v.empty() || v.size() > 18 || v.find_first_not_of("0123456789") != std::string::npos)
        throw Problem(400, "invalid-parameter", "Invalid query parameter", std::string(name) + " must be a whole number").with_field(name);
    const size_t n = std::stoul(v);
    if (n < lo || n > hi)
        throw Problem(400, "invalid-parameter", "Invalid query parameter",
                      std::string(name) + " must lie in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]").with_field(name);
    return n;
}

}  // namespace

// RFC 9110: the media type is case-insensitive and may carry parameters (charset); JSON is
// application/json or a structured +json type. Anything else, or none, is refused.
bool is_json_media_type(const std::string& header) {
    std::string t = header.substr(0, header.find(';'));
    while (!t.empty() && (t.back() == ' ' || t.back() == '\t')) t.pop_back();
    size_t start = t.find_first_not_of(" \t");
    t = start == std::string::npos ? std::string() : t.substr(start);
    for (char& c : t) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (t == "application/json") return true;
    return t.rfind("application/", 0) == 0 && t.size() > 17 && t.compare(t.size() - 5, 5, "+json") == 0;
}

// The result files the routes take (regex alternatives), a still's or a frame's and a job's:
// api::ResultFiles::routed's names, the list the status's links are checked against.
std::string files_re(bool frame) {
    std::string re;
    for (const std::string& f : api::ResultFiles::routed(frame)) {
        if (!re.empty()) re += '|';
        for (char c : f) {
            if (c == '.') re += '\\';
            re += c;
        }
    }
    return re;
}
const std::string& render_files_re() {
    static const std::string re = files_re(true);
    return re;
}
const std::string& job_files_re() {
    static const std::string re = files_re(false);
    return re;
}

const char* content_type(const std::string& file) {
    auto ends = [&](const char* s) { return file.size() >= std::strlen(s) && file.compare(file.size() - std::strlen(s), std::string::npos, s) == 0; };
    return ends(".exr") ? "image/x-exr" : ends(".json") ? "application/json" : ends(".csv") ? "text/csv"
         : ends(".svg") ? "image/svg+xml" : ends(".mp4") ? "video/mp4" : "image/png";
}

namespace {

// A job's result file and a frame's: the routes whose answers carry an ETag.
const std::regex& job_file_route() {
    static const std::regex re("/v1/jobs/[^/]+/(" + job_files_re() + ")");
    return re;
}
const std::regex& frame_file_route() {
    static const std::regex re("/v1/jobs/[^/]+/frames/-?[0-9]{1,8}/(" + render_files_re() + ")");
    return re;
}

// Whether `path` is a result file's, whose answers decide If-Match themselves.
bool takes_etags(const std::string& path) {
    return std::regex_match(path, job_file_route()) || std::regex_match(path, frame_file_route());
}

// An If-Match of "*" alone, on every line: any current answer matches it.
bool only_any(const httplib::Request& req) {
    const size_t n = req.get_header_value_count("If-Match");
    for (size_t i = 0; i < n; ++i) {
        const std::string v = req.get_header_value("If-Match", i);
        const size_t a = v.find_first_not_of(" \t"), b = v.find_last_not_of(" \t");
        if (a == std::string::npos || v.substr(a, b - a + 1) != "*") return false;
    }
    return true;
}

}  // namespace

std::string allowed_methods(const std::string& path) {
    // As routes() registers them; httplib answers HEAD with a GET route.
    static const std::vector<std::pair<std::regex, std::string>> table = {
        {std::regex(R"(/healthz|/readyz|/metrics|/v1/openapi\.yaml|/v1/job-schema|/v1/events|/v1/nodes|/|/ui/[^/]+)"), "GET, HEAD"},
        {std::regex(R"(/v1/jobs|/v1/scenes)"), "GET, HEAD, POST"},
        {std::regex(R"(/v1/comparisons)"), "POST"},
        {std::regex(R"(/v1/jobs/[^/:]+:(pause|resume))"), "POST"},
        {std::regex(R"(/v1/jobs/[^/]+)"), "GET, HEAD, DELETE"},
        {std::regex(R"(/v1/jobs/[^/]+/results)"), "DELETE"},
        {std::regex(R"(/v1/jobs/[^/]+/log)"), "GET, HEAD"},
        {job_file_route(), "GET, HEAD"},
        {frame_file_route(), "GET, HEAD"},
    };
    for (const auto& [re, allow] : table)
        if (std::regex_match(path, re)) return allow;
    return "";
}

namespace {

std::string scene_format(const CatalogEntry& e) {
    if (e.source == "builtin") return "builtin";
    const std::string ext = std::filesystem::path(e.path).extension().string();
    return ext == ".dae" ? "dae" : ext == ".glb" ? "glb" : "gltf";
}

json parse_body(const httplib::Request& req, int max_depth) {
    if (!is_json_media_type(req.get_header_value("Content-Type")))
        throw Problem(415, "unsupported-media-type", "Unsupported media type",
                      "send the job with Content-Type: application/json (curl: -H 'Content-Type: application/json')");
    std::optional<json> body;
    try {
        body = api::parse_json(req.body, max_depth);
    } catch (const api::JsonTooDeep& e) {
        throw Problem(400, "json-too-deep", "JSON nested too deeply", std::string(e.what()) + " (tessera serve --max-json-depth)").with_field("");
    } catch (const api::JsonDuplicateKey& e) {
        throw Problem(400, "duplicate-key", "A key given twice", e.what()).with_field("");
    }
    if (!body) throw Problem(400, "malformed-json", "Malformed JSON", "the request body is not valid JSON").with_field("");
    return std::move(*body);
}

}  // namespace

namespace {

// The stream of the connection this thread serves: the error handler asks it which budget a
// failed read broke.
thread_local ConnectionStream* t_stream = nullptr;

// httplib's server with its connection loop replaced: the connection keeps one stream for all
// its requests (pipelined requests are answered in order, httplib 0.11 drops them), every
// request's head and body are read against budgets, and the guard watches each phase.
class GuardedServer final : public httplib::Server {
public:
    using BodyBudget = std::function<void(httplib::Request&, ConnectionStream&)>;
    GuardedServer(ConnectionGuard& guard, uint64_t max_head_bytes, BodyBudget body_budget, std::function<void()> request_done)
        : guard_(guard), max_head_bytes_(max_head_bytes), body_budget_(std::move(body_budget)), request_done_(std::move(request_done)) {}

private:
    bool process_and_close_socket(int sock) override {
        return guard_.run(sock, [](void* self, int fd) { return static_cast<GuardedServer*>(self)->serve_connection(fd); }, this);
    }

    bool serve_connection(int fd) {
        ConnectionStream strm(fd, double(read_timeout_sec_) + read_timeout_usec_ * 1e-6,
                              double(write_timeout_sec_) + write_timeout_usec_ * 1e-6);
        strm.on_body_progress([this](uint64_t bytes) { guard_.body_progress(bytes); });
        t_stream = &strm;
        bool ok = false;
        for (size_t n = 0; n < keep_alive_max_count_ && svr_sock_ != INVALID_SOCKET; ++n) {
            if (!strm.wait_for_request(double(keep_alive_timeout_sec_))) break;
            strm.begin_request(max_head_bytes_);
            bool closed = false;
            try {
                ok = process_request(strm, n + 1 == keep_alive_max_count_, closed,
                                     [&](httplib::Request& req) { body_budget_(req, strm); });
            } catch (const std::exception& e) {
                // A hook outside the route handlers threw after its answer began: the connection
                // ends, the process goes on.
                spdlog::error("connection: {}", loggable(e.what(), 400));
                ok = false;
            } catch (...) {
                ok = false;
            }
            request_done_();
            if (!ok || closed || guard_.closing()) break;
        }
        if (guard_.closing()) {
            // The answer is out; what the client still sends of a body that was not read is
            // dropped until it closes, so that it reads the answer rather than a reset.
            ::shutdown(fd, SHUT_WR);
            strm.drain(1.0);
        }
        t_stream = nullptr;
        ::shutdown(fd, SHUT_RDWR);
        ::close(fd);
        return ok;
    }

    ConnectionGuard& guard_;
    uint64_t max_head_bytes_;
    BodyBudget body_budget_;
    std::function<void()> request_done_;
};

// The bytes of request body this thread's request holds of HttpApi's shared bound, and
// whether that bound refused it.
thread_local uint64_t t_body_held = 0;
thread_local bool t_body_refused = false;

// An error id that a 500's body and its log line share.
std::string new_error_id() {
    static std::atomic<uint64_t> counter{0};
    static const uint64_t start = uint64_t(std::chrono::system_clock::now().time_since_epoch().count());
    return fmt::format("{:016x}", (start * 0x9E3779B97F4A7C15ull) ^ (++counter * 0xBF58476D1CE4E5B9ull));
}

Problem internal_problem(std::string_view what) {
    const std::string id = new_error_id();
    spdlog::error("internal error {}: {}", id, loggable(what, 400));
    return Problem(500, "internal", "Internal server error", "an internal error; the server's log has it as error " + id)
        .with_error_id(id);
}

// Runs one of httplib's hooks so that nothing it throws leaves it: an exception is logged with
// an error id and handed, as a 500 problem, to `failed`, which answers with it where the hook
// answers (and gives the hook's result).
template <typename F, typename G>
auto contained(const char* hook, F&& f, G&& failed) noexcept -> decltype(f()) {
    try {
        return f();
    } catch (const std::exception& e) {
        return failed(internal_problem(std::string(hook) + ": " + e.what()));
    } catch (...) {
        return failed(internal_problem(std::string(hook) + ": unknown exception"));
    }
}

template <typename F>
void contained(const char* hook, F&& f) noexcept {
    contained(hook, std::forward<F>(f), [](const Problem&) {});
}

}  // namespace

// Health and readiness stay open for probes; everything under /v1 needs a token, and the
// metrics unless they are declared open.
bool HttpApi::needs_token(const std::string& path) const {
    return path.rfind("/v1/", 0) == 0 || path == "/v1" || (path == "/metrics" && !limits_.metrics_open);
}

namespace {

uint64_t content_length(const httplib::Request& req) {
    const std::string v = req.get_header_value("Content-Length");
    if (v.empty() || v.size() > 19 || v.find_first_not_of("0123456789") != std::string::npos) return 0;
    return std::stoull(v);
}

bool is_form_type(std::string type) {
    for (char& c : type) c = char(std::tolower(static_cast<unsigned char>(c)));
    return type.rfind("application/x-www-form-urlencoded", 0) == 0;
}

bool is_identity(std::string coding) {
    for (char& c : coding) c = char(std::tolower(static_cast<unsigned char>(c)));
    return coding == "identity" || coding.empty();
}

bool is_chunked(const httplib::Request& req) {
    std::string te = req.get_header_value("Transfer-Encoding");
    for (char& c : te) c = char(std::tolower(static_cast<unsigned char>(c)));
    return te == "chunked";
}

}  // namespace

HttpApi::HttpApi(JobQueue& queue, HttpLimits limits, std::string openapi_path)
    : queue_(queue), limits_(limits), openapi_path_(std::move(openapi_path)),
      guard_(std::make_unique<ConnectionGuard>(limits_.connections)),
      server_(std::make_unique<GuardedServer>(
          *guard_, limits_.max_head_bytes, [this](httplib::Request& req, ConnectionStream& strm) { begin_body(req, strm); },
          [this] { end_request(); })) {
    server_->new_task_queue = [this] { return guard_->new_task_queue(); };
    guard_->set_probe([this](const std::string& path) { return probe_answer(path); });
    server_->set_payload_max_length(std::max(limits_.max_upload, limits_.max_job_body));
    // Small JSON responses must not wait for Nagle's algorithm and the client's delayed ACK
    // (measured: 43 ms per status poll without this, 0.1 ms of work).
    server_->set_tcp_nodelay(true);
    // httplib closes a connection after 5 requests by default: pollers would reconnect all the
    // time. Idle connections still close after the keep-alive timeout.
    server_->set_keep_alive_max_count(10000);
    server_->set_keep_alive_timeout(std::max<time_t>(1, time_t(limits_.connections.keep_alive_s)));
    server_->set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
        return contained("pre-routing", [&] {
            request_start = std::chrono::steady_clock::now();
            guard_->request_head_read();
            return refuse_before_body(req, res) ? httplib::Server::HandlerResponse::Handled : httplib::Server::HandlerResponse::Unhandled;
        }, [&](const Problem& p) {
            answer_and_close(res, p);
            return httplib::Server::HandlerResponse::Handled;
        });
    });
    // curl sends a large body only after "100 Continue": the same refusals, before it sends it.
    server_->set_expect_100_continue_handler([this](const httplib::Request& req, httplib::Response& res) {
        return contained("expect-100", [&] { return refuse_before_body(req, res) ? res.status : 100; },
                         [&](const Problem& p) {
                             answer_and_close(res, p);
                             return res.status;
                         });
    });
    server_->set_post_routing_handler([this](const httplib::Request&, httplib::Response& res) {
        contained("post-routing", [&] {
            stamp(res);
            if (res.get_header_value("Content-Type") == "text/event-stream") guard_->response_streaming(limits_.event_keep_alive_s);
            // A streamed answer holds no body: its length is the provider's.
            else guard_->response_started(res.body.empty() ? res.content_length_ : res.body.size());
        });
    });
    server_->set_logger([this](const httplib::Request& req, const httplib::Response& res) {
        contained("logger", [&] {
            // A request httplib refused before routing (a broken request line, a cut connection)
            // has no start time.
            const bool timed = request_start != std::chrono::steady_clock::time_point{};
            const double ms = timed ? std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - request_start).count() : 0;
            spdlog::info("{} {} {} {}", loggable(req.method, 16), loggable(req.path, 512), res.status, timed ? fmt::format("{:.2f} ms", ms) : "-");
            request_start = {};
            end_answer();
            guard_->response_sent();
            std::lock_guard<std::mutex> lock(status_mutex_);
            ++responses_by_status_[res.status];
        });
    });
    // Errors httplib raises itself (unknown route, body too large, a broken head, a read past a
    // budget) get a problem body too.
    server_->set_error_handler([this](const httplib::Request& req, httplib::Response& res) {
        // A problem's body is never cut by a Range (one httplib could not read fills in part).
        const_cast<httplib::Request&>(req).ranges.clear();
        contained("error handler", [&] {
            stamp(res);
            if (!res.body.empty()) return;
            const auto overrun = t_stream ? t_stream->overrun() : ConnectionStream::Overrun::none;
            if (overrun != ConnectionStream::Overrun::none) {
                // The rest of what the client sends is not read: the connection ends.
                res.set_header("Connection", "close");
                guard_->close_after_response();
                if (overrun == ConnectionStream::Overrun::head) {
                    send_problem(res, Problem(431, "header-fields-too-large", "Request header fields too large",
                                              "a request's line and headers may take at most " + std::to_string(limits_.max_head_bytes) +
                                                  " bytes (tessera serve --max-header-bytes)"));
                } else {
                    send_problem(res, Problem(413, "payload-too-large", "Payload too large",
                                              "a request body for " + loggable(req.path, 200) + " may be at most " + std::to_string(body_limit(req)) +
                                                  " bytes" + (is_chunked(req) ? " (chunked framing included, an eighth more)" : "")));
                }
                return;
            }
            if (res.status == 404) {
                // A route that exists under other methods: 405 with the ones it takes (RFC 9110).
                const std::string allow = allowed_methods(req.path);
                const std::string method = req.method == "HEAD" ? "GET" : req.method;
                if (!allow.empty() && (", " + allow + ",").find(", " + method + ",") == std::string::npos) {
                    res.set_header("Allow", allow);
                    send_problem(res, Problem(405, "method-not-allowed", "Method not allowed",
                                              loggable(req.path, 200) + " takes " + allow + ", not " + loggable(req.method, 16)));
                    return;
                }
            }
            if (res.status == 404) {
                send_problem(res, Problem(404, "not-found", "Not found", "no route for " + loggable(req.method, 16) + " " + loggable(req.path, 200)));
                return;
            }
            // httplib refused the request before it was read whole (a broken request line or
            // header, a bad Range, a broken multipart body): what is left of it must not be
            // parsed as the next request.
            if (res.status == 416) {
                // httplib 0.11 refuses a Range it cannot read (a unit other than bytes, a range
                // backwards) on any route, before routing: nothing was done.
                answer_and_close(res, Problem(416, "invalid-range", "Unreadable Range header",
                                              "the Range header is not bytes=first-last (or bytes=-suffix): the request was refused "
                                              "before it was routed, and nothing was done (a POST queued no job); send it without "
                                              "the Range"));
                return;
            }
            const char* title = res.status == 413 ? "Payload too large" : res.status == 414 ? "URI too long" : "Request error";
            answer_and_close(res, Problem(res.status, "request-error", title, "the request was refused with status " + std::to_string(res.status)));
        }, [&](const Problem& p) { answer_and_close(res, p); });
    });
    server_->set_exception_handler([this](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
        contained("exception handler", [&] {
            try {
                std::rethrow_exception(ep);
            } catch (const Problem& p) {
                send_problem(res, p);
            } catch (const QueueError& e) {
                // Sent as made: a scene's file is named by its place in the catalog where the text
                // is made (CatalogEntry::shown), the client's own words are quoted as sent (cut,
                // they would tell a client which folders are the server's), and what only the
                // server may read (a store's file, its Redis) is its cause, logged here.
                if (!e.cause.empty()) spdlog::warn("{}: {}", e.code, loggable(e.cause, 400));
                send_problem(res, problem(e));
            } catch (const StoreError& e) {
                spdlog::error("job store: {}", loggable(e.what(), 400));
                send_problem(res, store_problem(e));
            } catch (const std::bad_alloc&) {
                send_problem(res, internal_problem("out of memory"));
            } catch (const std::exception& e) {
                send_problem(res, internal_problem(e.what()));
            } catch (...) {
                send_problem(res, internal_problem("unknown exception"));
            }
        }, [&](const Problem& p) { answer_and_close(res, p); });
    });
    routes();
}

HttpApi::~HttpApi() { stop(); }

namespace {

// Debian's libcpp-httplib is compiled with a listen backlog of 5 (CPPHTTPLIB_LISTEN_BACKLOG),
// so a burst of clients overflows the accept queue and connections are dropped. Linux lets a
// second listen() on the listening socket raise the backlog; the library offers no other hook.
void raise_listen_backlog(int port) {
    for (int fd = 3; fd < 4096; ++fd) {
        int listening = 0;
        socklen_t len = sizeof listening;
        if (getsockopt(fd, SOL_SOCKET, SO_ACCEPTCONN, &listening, &len) != 0 || !listening) continue;
        sockaddr_storage addr{};
        socklen_t alen = sizeof addr;
        if (getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &alen) != 0) continue;
        const int p = addr.ss_family == AF_INET ? ntohs(reinterpret_cast<sockaddr_in*>(&addr)->sin_port)
                    : addr.ss_family == AF_INET6 ? ntohs(reinterpret_cast<sockaddr_in6*>(&addr)->sin6_port) : -1;
        if (p == port) ::listen(fd, SOMAXCONN);
    }
}

}  // namespace

int HttpApi::bind(const std::string& host, int port) {
    const int bound = port == 0 ? server_->bind_to_any_port(host) : (server_->bind_to_port(host, port) ? port : -1);
    if (bound <= 0) throw std::runtime_error("cannot listen on " + host + ":" + std::to_string(port));
    raise_listen_backlog(bound);
    return bound;
}

void HttpApi::serve() { server_->listen_after_bind(); }

void HttpApi::send_encoded(const httplib::Request& req, httplib::Response& res, uint64_t estimate, const std::string& content_type,
                           const std::function<std::vector<unsigned char>()>& encode, const std::string& live) {
    if (!encoded_.send(req, res, estimate, encode, content_type, live))
        throw Problem(503, "busy", "Too many images encoded at once",
                      "images encoded on request and not yet sent hold " + std::to_string(encoded_.held()) +
                          " bytes; with this one they would pass the bound of " + std::to_string(encoded_.budget()) +
                          " bytes (--max-encoded-mb); retry when clients have read them")
            .with_retry_after(1);
}
void HttpApi::stop() {
    if (!server_) return;
    // Event streams wait for events in connection threads: they end now, not at their timeout.
    queue_.events().close();
    server_->stop();
    // Connections waiting for their next request would hold stop() for their keep-alive time.
    guard_->close_idle();
}
std::string HttpApi::unready_reason() { return queue_.unready_reason(); }

// The same answers as the routes', written whole: the refusing thread has no httplib request.
std::string HttpApi::probe_answer(const std::string& path) {
    int status = 200;
    std::string body;
    if (path == "/healthz") {
        body = R"({"status":"ok"})";
    } else if (path == "/readyz") {
        // Asked at most once a second here: the refusing thread serves every connection past the
        // bound, and a farm's readiness is a Redis round trip.
        std::string why;
        {
            std::lock_guard<std::mutex> lock(probe_mutex_);
            const auto now = std::chrono::steady_clock::now();
            if (now - probe_at_ > std::chrono::seconds(1)) {
                probe_reason_ = unready_reason();
                probe_at_ = now;
            }
            why = probe_reason_;
        }
        status = why.empty() ? 200 : 503;
        body = why.empty() ? R"({"status":"ready"})"
                           : json_text({{"type", "/problems/not-ready"}, {"title", "Not ready"}, {"status", 503}, {"detail", why}});
    } else {
        return "";
    }
    return fmt::format("HTTP/1.1 {} {}\r\nContent-Type: {}\r\nDate: {}\r\nConnection: close\r\nContent-Length: {}\r\n\r\n{}", status,
                       status == 200 ? "OK" : "Service Unavailable", status == 200 ? "application/json" : "application/problem+json",
                       http_date(std::time(nullptr)), body.size(), body);
}

// What the body may take, set before anything of it is read. Chunked framing costs bytes of its
// own: an eighth more than the route's bound (and a little) before the decoded size is checked
// against the bound itself. The bytes are taken from the bound on all bodies in flight first.
void HttpApi::begin_body(httplib::Request& req, ConnectionStream& strm) {
    // A Range is for result files alone (response_bytes.h); httplib would also copy a body once
    // per range asked for (`Range: bytes=0-,0-,...`). One range is served; several, the whole body.
    hold_range(req);
    // No route takes a form: httplib would parse a body sent as one (curl --data-binary's
    // default type) and refuse it past 8 KiB. Uploads are bytes, jobs are JSON.
    if (is_form_type(req.get_header_value("Content-Type"))) req.headers.erase("Content-Type");
    const bool chunked = req.has_header("Transfer-Encoding");
    const bool framed = chunked || req.has_header("Content-Length");
    const uint64_t limit = body_limit(req);
    const uint64_t allowance = limit + limit / 8 + 4096;
    const uint64_t budget = chunked ? allowance : content_length(req);
    t_body_held = 0;
    t_body_refused = false;
    if (framed && budget > 0 && budget <= allowance) {
        uint64_t now = bodies_in_flight_.load();
        do {
            // One body alone is always read (its route bounds it); with others, the sum is.
            if (now > 0 && now + budget > limits_.max_bodies_in_flight) {
                t_body_refused = true;
                break;
            }
        } while (!bodies_in_flight_.compare_exchange_weak(now, now + budget));
        if (!t_body_refused) t_body_held = budget;
    }
    strm.begin_body(t_body_refused ? 0 : budget, framed);
    // Room for the whole budget at once: a body grown by doubling would hold up to twice its
    // bound. Large reservations are mappings of their own, resident only as written.
    if (t_body_held > 0) req.body.reserve(size_t(t_body_held));
}

void HttpApi::end_request() {
    end_answer();  // also where the logger was skipped (a content provider that threw)
    bodies_in_flight_ -= t_body_held;
    t_body_held = 0;
    t_body_refused = false;
}

void HttpApi::answer_and_close(httplib::Response& res, const Problem& p) {
    send_problem(res, p);
    res.set_header("Connection", "close");
    guard_->close_after_response();
}

size_t HttpApi::body_limit(const httplib::Request& req) const {
    if (req.method != "POST") return 0;
    if (req.path == "/v1/jobs" || req.path == "/v1/comparisons") return limits_.max_job_body;
    if (req.path == "/v1/scenes") return limits_.max_upload;
    return 0;
}

// Refusals decided from the head alone, so that no body is read for them: no token (401), a
// Content-Length that is no number (httplib would read "-5" as a huge unsigned length), a body
// where the route takes none or over the route's bound (413; httplib would read it whole before
// answering). The unread body must not be parsed as the next request, so the connection ends.
bool HttpApi::refuse_before_body(const httplib::Request& req, httplib::Response& res) {
    const std::string cl = req.get_header_value("Content-Length");
    const bool has_te = req.has_header("Transfer-Encoding");
    const bool has_body = has_te || (req.has_header("Content-Length") && cl != "0");
    const std::string allow = allowed_methods(req.path);
    // HEAD is answered wherever GET is (httplib runs the GET route).
    const std::string method = req.method == "HEAD" ? "GET" : req.method;
    const bool method_known = (", " + allow + ",").find(", " + method + ",") != std::string::npos;
    std::optional<Problem> refusal;
    std::string authenticate;
    if (limits_.auth.enabled() && needs_token(req.path) && !limits_.auth.allows(req.get_header_value("Authorization"))) {
        const bool presented = req.has_header("Authorization");
        refusal = Problem(401, "unauthorized", "Unauthorized",
                          presented ? "the bearer token is not one this server accepts"
                                    : "this server needs a bearer token: send Authorization: Bearer <token>");
        authenticate = presented ? R"(Bearer realm="tessera", error="invalid_token")" : R"(Bearer realm="tessera")";
    } else if (!cl.empty() && (cl.size() > 19 || cl.find_first_not_of("0123456789") != std::string::npos)) {
        refusal = Problem(400, "invalid-content-length", "Invalid Content-Length",
                          "Content-Length must be a non-negative whole number, not \"" + loggable(cl, 40) + "\"").with_field("");
    } else if (req.get_header_value_count("Content-Length") > 1) {
        refusal = Problem(400, "invalid-content-length", "Invalid Content-Length", "a request has at most one Content-Length").with_field("");
    } else if (has_body && req.has_header("Content-Encoding") && !is_identity(req.get_header_value("Content-Encoding"))) {
        // httplib would inflate a gzip, deflate or brotli body into memory without a bound: a
        // megabyte of gzip is a gigabyte of body. No route takes one.
        refusal = Problem(415, "unsupported-content-encoding", "Unsupported Content-Encoding",
                          "request bodies are taken as they are (Content-Encoding: identity), not \"" +
                              loggable(req.get_header_value("Content-Encoding"), 40) + "\"");
    } else if (has_te && (!is_chunked(req) || req.has_header("Content-Length") || req.get_header_value_count("Transfer-Encoding") > 1)) {
        // RFC 9112 6.1: a server that cannot frame a body must refuse it; both framings at once
        // is how requests are smuggled past a proxy.
        refusal = Problem(400, "invalid-transfer-encoding", "Invalid Transfer-Encoding",
                          "a request body is framed by Content-Length or by Transfer-Encoding: chunked alone, not by \"" +
                              loggable(req.get_header_value("Transfer-Encoding"), 40) + "\"" +
                              (req.has_header("Content-Length") ? " with a Content-Length" : "")).with_field("");
    } else if (allow.empty()) {
        refusal = Problem(404, "not-found", "Not found", "no route for " + loggable(req.method, 16) + " " + loggable(req.path, 200));
    } else if (!method_known) {
        // Before any body is read, with or without one (a PUT without a body is as wrong).
        res.set_header("Allow", allow);
        refusal = Problem(405, "method-not-allowed", "Method not allowed",
                          loggable(req.path, 200) + " takes " + allow + ", not " + loggable(req.method, 16));
    } else if (req.has_header("If-Match") && !takes_etags(req.path) && !only_any(req) && !names_missing_job(req.path)) {
        // RFC 9110 13.1.1: evaluated before the method. These answers have no ETag, so a tag
        // never matches: a DELETE or a pause under a tag the client expects does nothing.
        refusal = Problem(412, "precondition-failed", "Precondition failed",
                          "If-Match names a tag, and " + loggable(req.path, 200) +
                              " has none (only result files carry an ETag); the request was not carried out");
    } else if (t_body_refused) {
        refusal = Problem(503, "busy", "Too many request bodies at once",
                          "the server is reading request bodies of up to " + std::to_string(bodies_in_flight_.load()) +
                              " bytes; with this one they would pass the bound of " + std::to_string(limits_.max_bodies_in_flight) +
                              " (tessera serve --max-bodies-mb); retry shortly")
                      .with_retry_after(2);
    } else if (has_body && body_limit(req) == 0) {
        refusal = Problem(413, "payload-too-large", "Payload too large", loggable(req.method, 16) + " " + loggable(req.path, 200) + " takes no request body");
    } else if (content_length(req) > body_limit(req)) {
        refusal = Problem(413, "payload-too-large", "Payload too large",
                          "a request body for " + loggable(req.path, 200) + " may be at most " + std::to_string(body_limit(req)) + " bytes");
    }
    if (!refusal) return false;
    send_problem(res, *refusal);
    if (!authenticate.empty()) res.set_header("WWW-Authenticate", authenticate);
    if (has_body) {
        res.set_header("Connection", "close");
        guard_->close_after_response();
    }
    return true;
}

bool HttpApi::names_missing_job(const std::string& path) {
    static const std::regex job_path(R"(/v1/jobs/([^/:]+)(:[a-z]+|/.*)?)");
    std::smatch m;
    if (!std::regex_match(path, m, job_path)) return false;
    try {
        queue_.status(m[1]);
        return false;
    } catch (const QueueError& e) {
        return e.kind == QueueErrorKind::not_found;
    } catch (const std::exception&) {
        return false;  // the route meets it too, and answers for it
    }
}

void HttpApi::routes() {
    auto& s = *server_;
    page_routes();
    event_routes();
    s.Get("/healthz", [](const httplib::Request&, httplib::Response& res) { send_json(res, 200, {{"status", "ok"}}); });
    s.Get("/readyz", [this](const httplib::Request&, httplib::Response& res) {
        if (const std::string why = unready_reason(); !why.empty())
            throw Problem(503, "not-ready", "Not ready", why).with_retry_after(5);
        send_json(res, 200, {{"status", "ready"}});
    });
    s.Get("/metrics", [this](const httplib::Request&, httplib::Response& res) {
        res.set_content(metrics_text(), "text/plain; version=0.0.4");
    });
    s.Get("/v1/openapi.yaml", [this](const httplib::Request&, httplib::Response& res) {
        const std::string text = read_file(openapi_path_);
        if (text.empty()) throw Problem(404, "not-found", "Not found", "the OpenAPI description is not installed");
        res.set_content(text, "application/yaml");
    });

    // Both accept a JSON body and answer 202 with the queued job's status and its Location.
    auto accept_job = [this](api::JobStatus (JobQueue::*submit)(const json&)) {
        return [this, submit](const httplib::Request& req, httplib::Response& res) {
            if (req.body.size() > limits_.max_job_body)
                throw Problem(413, "payload-too-large", "Payload too large",
                              "a request body may be at most " + std::to_string(limits_.max_job_body) + " bytes");
            const json status = api::to_json((queue_.*submit)(parse_body(req, limits_.max_json_depth)));
            res.set_header("Location", status["links"]["self"].get<std::string>());
            send_json(res, 202, status);
        };
    };
    s.Post("/v1/jobs", accept_job(&JobQueue::submit));
    s.Post("/v1/comparisons", accept_job(&JobQueue::submit_comparison));
    s.Get("/v1/jobs", [this](const httplib::Request& req, httplib::Response& res) {
        const size_t limit = size_param(req, "limit", 50, 1, 1000);
        const size_t offset = size_param(req, "offset", 0, 0, 1'000'000'000);
        send_json(res, 200, to_json(queue_.list(req.has_param("state") ? req.get_param_value("state") : "", offset, limit)));
    });
    s.Get(R"(/v1/jobs/([^/]+))", [this](const httplib::Request& req, httplib::Response& res) {
        send_json(res, 200, api::to_json(queue_.status(req.matches[1])));
    });
    s.Delete(R"(/v1/jobs/([^/]+))", [this](const httplib::Request& req, httplib::Response& res) {
        send_json(res, 200, api::to_json(queue_.cancel(req.matches[1])));
    });
    s.Post(R"(/v1/jobs/([^/:]+):pause)", [this](const httplib::Request& req, httplib::Response& res) {
        send_json(res, 200, api::to_json(queue_.pause(req.matches[1])));
    });
    s.Post(R"(/v1/jobs/([^/:]+):resume)", [this](const httplib::Request& req, httplib::Response& res) {
        send_json(res, 200, api::to_json(queue_.resume(req.matches[1])));
    });
    s.Delete(R"(/v1/jobs/([^/]+)/results)", [this](const httplib::Request& req, httplib::Response& res) {
        queue_.delete_results(req.matches[1]);
        res.status = 204;
    });
    s.Get(R"(/v1/jobs/([^/]+)/log)", [this](const httplib::Request& req, httplib::Response& res) {
        const size_t from = size_param(req, "from", 0, 0, 1'000'000'000);
        const size_t limit = size_param(req, "limit", 1000, 1, 10'000);
        const LogPage page = queue_.job_log(req.matches[1], from, limit);
        res.set_header("Next-From", std::to_string(page.next));
        // Its files are named by their places in the catalog where each line was made.
        res.set_content(page.ndjson, "application/x-ndjson");
    });
    s.Get("/v1/nodes", [this](const httplib::Request&, httplib::Response& res) {
        send_json(res, 200, {{"nodes", queue_.node_report()}});
    });
    s.Get("/v1/job-schema", [this](const httplib::Request&, httplib::Response& res) {
        res.set_content(json_text(api::job_schema(queue_.config().job_limits)), "application/json");
    });
    s.Get("/v1/jobs/([^/]+)/frames/(-?[0-9]{1,8})/(" + render_files_re() + ")", [this](const httplib::Request& req, httplib::Response& res) {
        const std::string id = req.matches[1];
        const int frame = std::stoi(req.matches[2]);
        const std::string file = req.matches[3];
        send_file(req, res, queue_.frame_result_path(id, frame, file), content_type(file));
    });
    s.Get("/v1/jobs/([^/]+)/(" + job_files_re() + ")", [this](const httplib::Request& req, httplib::Response& res) {
        const std::string id = req.matches[1];
        const std::string file = req.matches[2];
        const float exposure = exposure_param(req, file);
        const char* type = content_type(file);
        // A running job's images are its latest finished pass, said so in the headers (the
        // denoised image from the kDenoiseFrom pass on, engine/render/passes.h).
        const bool denoised = file == "denoised.png" || file == "denoised.exr";
        if (api::ResultFiles::live(file)) {
            const auto live = queue_.live_pass(id);
            if (live && (!denoised || live->denoised)) {
                const Image& img = denoised ? *live->denoised : *live->image;
                const uint64_t pixels = uint64_t(img.width) * uint64_t(img.height);
                send_encoded(req, res, pixels * (file.ends_with(".exr") ? 16 : 3), type, [&] {
                    return file.ends_with(".exr") ? exr_bytes(img)
                         : file == "rate.png" ? rate_png_bytes(img, live->max_spp) : png_bytes(img, exposure);
                }, // The pass: its index, target, time and mean count tell a shot's frames and a
                   // job's restarts apart, and the image's address the same pass shown anew.
                   fmt::format("{} {} {} {} {:.17g} {:.17g} {} {}", id, file, live->pass.index, live->pass.spp, live->pass.seconds,
                               live->pass.spp_mean, static_cast<const void*>(&img), exposure));
                res.set_header("Cache-Control", "no-store");
                res.set_header("X-Tessera-Pass", std::to_string(live->pass.index));
                res.set_header("X-Tessera-Pass-Spp", std::to_string(live->pass.spp));
                const double err = denoised ? live->pass.denoised_est_rel_mse
                                 : live->pass.rel_mse >= 0 ? live->pass.rel_mse : live->pass.est_rel_mse;
                if (err >= 0) res.set_header("X-Tessera-Pass-Error", fmt::format("{:.6g}", err));
                return;
            }
        }
        const std::string path = queue_.result_path(id, file);
        if (exposure != 0.f) {
            // Another exposure of the linear image: the EXR beside the PNG, encoded anew.
            // Reserved before the EXR is read, for what the encoding holds at its peak: the file's
            // channels as floats, the image, its 8-bit pixels and the PNG (about 36 bytes a pixel).
            const std::string exr = queue_.result_path(id, "image.exr");
            const nlohmann::json settings = queue_.status(id).settings;
            const uint64_t pixels = uint64_t(settings.value("width", int64_t{0})) * uint64_t(settings.value("height", int64_t{0}));
            send_encoded(req, res, 36 * pixels, type, [&] { return png_bytes(read_image(exr), exposure); });
            return;
        }
        send_file(req, res, path, type);
    });

    s.Get("/v1/scenes", [this](const httplib::Request&, httplib::Response& res) {
        json scenes = json::array();
        for (const CatalogEntry& e : queue_.catalog().entries()) {
            json j = {{"name", e.name}, {"source", e.source}, {"format", scene_format(e)}};
            try {
                // Bound first: a range-for over .items() of a temporary would dangle.
                const json details = queue_.catalog().describe(e, queue_.config().load_limits);
                for (auto& [k, v] : details.items()) j[k] = v;
            } catch (const SceneError& err) {
                j["error"] = err.what();
            }
            scenes.push_back(j);
        }
        send_json(res, 200, {{"scenes", scenes}});
    });
    s.Post("/v1/scenes", [this](const httplib::Request& req, httplib::Response& res) {
        if (!req.has_param("name"))
            throw Problem(400, "invalid-parameter", "Missing scene name", "give the file name as ?name=FILE.gltf|.glb|.dae").with_field("name");
        if (req.body.size() > limits_.max_upload)
            throw Problem(413, "payload-too-large", "Payload too large",
                          "an upload may be at most " + std::to_string(limits_.max_upload) + " bytes");
        const CatalogEntry e = queue_.catalog().add_upload(req.get_param_value("name"), req.body, queue_.config().load_limits);
        json j = {{"id", e.name}, {"name", e.name}, {"source", e.source}, {"format", scene_format(e)}};
        const json details = queue_.catalog().describe(e, queue_.config().load_limits);
        for (auto& [k, v] : details.items()) j[k] = v;
        send_json(res, 201, j);
    });
}

std::string HttpApi::metrics_text() {
    std::ostringstream m;
    // The store's figures when it answers; without it (Redis away) the rest still do, and
    // tessera_store_up says which.
    bool store_up = true;
    try {
        const auto counts = queue_.counts_by_state();
        const size_t depth = queue_.queue_depth();
        m << "# HELP tessera_jobs Jobs by state.\n# TYPE tessera_jobs gauge\n";
        for (const auto& [state, n] : counts) m << "tessera_jobs{state=\"" << state << "\"} " << n << "\n";
        m << "# HELP tessera_queue_depth Jobs waiting to run.\n# TYPE tessera_queue_depth gauge\ntessera_queue_depth " << depth << "\n";
        m << "# HELP tessera_queue_depth_by_priority Queued jobs by priority.\n# TYPE tessera_queue_depth_by_priority gauge\n";
        for (const auto& [priority, n] : queue_.queued_by_priority())
            m << "tessera_queue_depth_by_priority{priority=\"" << priority << "\"} " << n << "\n";
        // A farm's task streams, as KEDA's redis-streams scaler reads them (docs/scaling.md).
        const auto backlog = queue_.task_backlog();
        if (!backlog.empty()) {
            m << "# HELP tessera_tasks_lag Tasks no render node has taken yet, by priority stream.\n# TYPE tessera_tasks_lag gauge\n";
            for (const auto& b : backlog)
                if (b.lag >= 0) m << "tessera_tasks_lag{priority=\"" << b.priority << "\"} " << b.lag << "\n";
            m << "# HELP tessera_tasks_pending Tasks taken by a render node and not yet done, by priority stream.\n"
              << "# TYPE tessera_tasks_pending gauge\n";
            for (const auto& b : backlog) m << "tessera_tasks_pending{priority=\"" << b.priority << "\"} " << b.pending << "\n";
        }
    } catch (const StoreError& e) {
        store_up = false;
        spdlog::warn("metrics without the job store's figures: {}", loggable(e.what(), 200));
    }
    m << "# HELP tessera_store_up Whether the job store answered (0: its figures are missing).\n# TYPE tessera_store_up gauge\n"
      << "tessera_store_up " << (store_up ? 1 : 0) << "\n";
    m << "# HELP tessera_rays_total Rays traced by finished jobs.\n# TYPE tessera_rays_total counter\ntessera_rays_total "
      << queue_.metrics().rays.load() << "\n";
    m << "# HELP tessera_render_seconds_total Render time of finished jobs.\n# TYPE tessera_render_seconds_total counter\n"
      << "tessera_render_seconds_total " << double(queue_.metrics().render_micros.load()) * 1e-6 << "\n";
    m << "# HELP tessera_jobs_submitted_total Jobs accepted since start.\n# TYPE tessera_jobs_submitted_total counter\n"
      << "tessera_jobs_submitted_total " << queue_.metrics().jobs_submitted.load() << "\n";
    m << "# HELP tessera_store_errors_total Writes the job store refused (full or unavailable).\n"
      << "# TYPE tessera_store_errors_total counter\ntessera_store_errors_total " << queue_.metrics().store_errors.load() << "\n";
    m << "# HELP tessera_scene_cache_hits_total Jobs that found their scene prepared (loaded and built) by an earlier job.\n"
      << "# TYPE tessera_scene_cache_hits_total counter\ntessera_scene_cache_hits_total " << queue_.scene_cache_counts().hits << "\n"
      << "# HELP tessera_scene_cache_misses_total Jobs that prepared their scene.\n"
      << "# TYPE tessera_scene_cache_misses_total counter\ntessera_scene_cache_misses_total " << queue_.scene_cache_counts().misses << "\n";
    // A farm's render nodes, from their last heartbeat in Redis (any API node shows them all).
    try {
        auto nodes = queue_.render_nodes();
        for (auto& [name, text] : nodes)  // a label value: no quote, backslash or newline from a node's name
            for (char& c : name) if (c == '"' || c == '\\' || c == '\n') c = '_';
        if (!nodes.empty()) {
            const std::pair<const char*, const char*> series[] = {
                {"tiles", "Tiles a render node stored."}, {"duplicates", "Tasks a render node found done or taken (late duplicates)."},
                {"reclaimed", "Tasks a render node took over from silent nodes."}, {"rays", "Rays a render node traced."},
                {"render_seconds", "Seconds a render node spent in tiles."}, {"redis_errors", "Redis errors a render node retried."},
                {"failed_tasks", "Tasks that failed on a render node, every job's (kept in Redis across its restarts)."},
                {"blocklisted_jobs", "Jobs that blocklisted a render node: it failed blocklist_after of their tasks."},
                {"passed_on", "Tasks a render node handed to others (blocklisted for their job, or failed them before)."}};
            for (const auto& [key, help] : series) {
                m << "# HELP tessera_node_" << key << "_total " << help << "\n# TYPE tessera_node_" << key << "_total counter\n";
                for (const auto& [name, text] : nodes) {
                    const json j = json::parse(text, nullptr, false);
                    if (j.is_object() && j.contains(key)) m << "tessera_node_" << key << "_total{node=\"" << name << "\"} " << json_text(j[key]) << "\n";
                }
            }
            // Busy: a node's threads with a task in hand at its last heartbeat; the farm's, over
            // the threads of the nodes seen in the last 30 s.
            m << "# HELP tessera_node_busy_fraction A render node's threads with a task in hand, at its last heartbeat.\n"
              << "# TYPE tessera_node_busy_fraction gauge\n";
            double busy_threads = 0, threads = 0;
            const double now = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
            for (const auto& [name, text] : nodes) {
                const json j = json::parse(text, nullptr, false);
                if (!j.is_object() || !j.contains("busy") || !j["busy"].is_number()) continue;
                m << "tessera_node_busy_fraction{node=\"" << name << "\"} " << json_text(j["busy"]) << "\n";
                if (j.value("last_seen", 0.0) > now - 30 && j.value("threads", 0) > 0) {
                    busy_threads += j["busy"].get<double>() * j["threads"].get<double>();
                    threads += j["threads"].get<double>();
                }
            }
            m << "# HELP tessera_nodes_busy_fraction The farm's render threads with a task in hand (nodes seen in the last 30 s).\n"
              << "# TYPE tessera_nodes_busy_fraction gauge\ntessera_nodes_busy_fraction " << (threads > 0 ? busy_threads / threads : 0.0) << "\n";
            m << "# HELP tessera_node_last_seen_seconds Unix time of a render node's last heartbeat.\n"
              << "# TYPE tessera_node_last_seen_seconds gauge\n";
            for (const auto& [name, text] : nodes) {
                const json j = json::parse(text, nullptr, false);
                if (j.is_object() && j.contains("last_seen")) m << "tessera_node_last_seen_seconds{node=\"" << name << "\"} " << json_text(j["last_seen"]) << "\n";
            }
        }
    } catch (const std::exception&) {
        // Redis unreachable: the rest of the metrics still answer.
    }
    m << "# HELP tessera_http_requests_total HTTP responses by status.\n# TYPE tessera_http_requests_total counter\n";
    std::lock_guard<std::mutex> lock(status_mutex_);
    for (const auto& [status, n] : responses_by_status_) m << "tessera_http_requests_total{status=\"" << status << "\"} " << n << "\n";
    m << "# HELP tessera_http_connections Open HTTP connections.\n# TYPE tessera_http_connections gauge\n"
      << "tessera_http_connections " << guard_->open() << "\n"
      << "# HELP tessera_http_connections_refused_total Connections answered 503 past the --max-connections bound.\n"
      << "# TYPE tessera_http_connections_refused_total counter\n"
      << "tessera_http_connections_refused_total " << guard_->refused() << "\n"
      << "# HELP tessera_http_connections_timed_out_total Connections closed when a request's headers, body or response ran past its deadline.\n"
      << "# TYPE tessera_http_connections_timed_out_total counter\n"
      << "tessera_http_connections_timed_out_total " << guard_->timed_out() << "\n";
    return m.str();
}

}  // namespace tessera::server
