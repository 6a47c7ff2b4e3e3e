// GET /v1/events: job events as Server-Sent Events (the WHATWG HTML standard's
// text/event-stream), so that pages and scripts follow jobs without polling.
#include <chrono>
#include <memory>
#include <string>

#include <httplib.h>

#include "server/http/http_api.h"
#include "server/http/problem.h"

namespace tessera::server {
namespace {

// One event in the stream's framing. The data is one line of JSON (no newline inside).
void frame(std::string& out, const JobEvent& e) {
    out += "id: " + std::to_string(e.id) + "\nevent: " + e.type + "\ndata: " + e.data + "\n\n";
}

}  // namespace

void HttpApi::event_routes() {
    server_->Get("/v1/events", [this](const httplib::Request& req, httplib::Response& res) {
        std::string job;
        if (req.has_param("job")) {
            job = req.get_param_value("job");
            queue_.status(job);  // 404 for a job that does not exist
        }
        JobEvents& events = queue_.events();
        // A reconnecting client names the last event it saw; an id that is no number, or one
        // this process never gave out, gets a reset (re-read the jobs) rather than an error.
        uint64_t after = events.last_id();
        if (req.has_header("Last-Event-ID")) {
            const std::string v = req.get_header_value("Last-Event-ID");
            after = !v.empty() && v.size() <= 19 && v.find_first_not_of("0123456789") == std::string::npos ? std::stoull(v) : 0;
        }
        struct Stream {
            explicit Stream(JobEvents& e) : subscription(e) {}
            JobEvents::Subscription subscription;
            uint64_t after = 0;
            bool started = false;
            std::chrono::steady_clock::time_point end;
        };
        auto stream = std::make_shared<Stream>(events);
        stream->after = after;
        stream->end = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                             std::chrono::duration<double>(limits_.event_stream_s));
        const auto keep_alive = std::chrono::milliseconds(int64_t(limits_.event_keep_alive_s * 1000));
        res.set_header("Cache-Control", "no-store");
        // Proxies such as nginx would otherwise hold events back in their buffers.
        res.set_header("X-Accel-Buffering", "no");
        res.set_chunked_content_provider("text/event-stream", [this, stream, job, keep_alive, &events](size_t, httplib::DataSink& sink) {
            std::string out;
            std::chrono::milliseconds wait = keep_alive;
            if (!stream->started) {
                // The first bytes at once: the client knows the stream is open, and how soon to
                // come back when it ends.
                stream->started = true;
                out = "retry: 2000\n: tessera job events\n\n";
                wait = std::chrono::milliseconds(0);
            }
            const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(stream->end - std::chrono::steady_clock::now());
            wait = std::max(std::chrono::milliseconds(0), std::min(wait, left));
            const JobEvents::Batch batch = events.wait_after(stream->after, job, wait);
            if (batch.lost) out += "id: " + std::to_string(batch.last) + "\nevent: reset\ndata: {}\n\n";
            for (const JobEvent& e : batch.events) frame(out, e);
            stream->after = batch.last;
            if (out.empty()) out = ":\n\n";  // keep-alive: proxies and clients see the stream is alive
            if (!sink.write(out.data(), out.size())) return false;
            guard_->response_streaming(limits_.event_keep_alive_s);
            if (batch.closed || std::chrono::steady_clock::now() >= stream->end) sink.done();
            return true;
        });
    });
}

}  // namespace tessera::server
