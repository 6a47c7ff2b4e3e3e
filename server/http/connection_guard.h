#pragma once
// The HTTP server's connections: a thread for each open connection up to a bound (beyond it a
// 503 and a close), and deadlines for each phase of a request, enforced by a watchdog that
// shuts a connection's socket down when its phase runs out of time.
//
// cpp-httplib 0.11 serves a connection in one thread from accept to close and has only a
// per-recv timeout: a client that sends a header line every second holds its thread forever,
// and a fixed pool of such threads is taken by a handful of slow clients. The guard bounds the
// whole phase instead (nginx's client_header_timeout, Apache's mod_reqtimeout).
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <unordered_set>

namespace httplib { class TaskQueue; }

namespace tessera::server {

struct ConnectionLimits {
    int max_connections = 512;     // open connections; one more gets a 503 and is closed
    double header_timeout_s = 10;  // a request's line and headers, from the connection's start or the end of the keep-alive wait
    double body_timeout_s = 30;    // a body read with its handling, or a response written: this plus size / min_rate
    double min_rate = 64 * 1024;   // bytes per second a client must keep up on long bodies and responses
    double keep_alive_s = 5;       // idle time between requests before httplib closes the connection
    int spare_threads = 16;        // idle connection threads kept for the next connections
};

class ConnectionGuard {
public:
    explicit ConnectionGuard(ConnectionLimits limits);
    ~ConnectionGuard();
    ConnectionGuard(const ConnectionGuard&) = delete;
    ConnectionGuard& operator=(const ConnectionGuard&) = delete;

    // The task queue httplib runs connections on: a thread per connection, up to the bound.
    httplib::TaskQueue* new_task_queue();

    // Runs one accepted connection: `serve` is httplib's own processing of the socket, which
    // closes it. A connection past the bound is answered 503 and closed here instead.
    bool run(int fd, bool (*serve)(void* server, int fd), void* server);

    // httplib's hooks, called in the connection's own thread.
    // The head is read: the body (and its handling) has the body timeout, extended as the body
    // arrives by what it brought at the minimum rate (body_progress), so a client that trickles
    // is cut after the timeout however large a length it declared.
    void request_head_read();
    void body_progress(uint64_t bytes_read);
    void response_started(uint64_t body_bytes);
    // A stream (Server-Sent Events) that writes at least every `interval_s`: the client must take
    // each write within the body timeout after the next one is due; called when it starts and
    // after every write.
    void response_streaming(double interval_s);
    void response_sent();
    // The connection ends after this response: its request's body was not read.
    void close_after_response();
    bool closing() const;
    // Probes still get their answer on a connection past the bound: given a GET path, the whole
    // HTTP response for it, or "" (then the 503).
    void set_probe(std::function<std::string(const std::string& path)> probe) { probe_ = std::move(probe); }

    // On stop: close the connections that wait for a request, so that stop does not wait out
    // their keep-alive; requests in progress finish.
    void close_idle();

    int open() const { return open_.load(); }
    uint64_t refused() const { return refused_.load(); }
    uint64_t timed_out() const { return timed_out_.load(); }
    const ConnectionLimits& limits() const { return limits_; }

    struct Connection;  // one open connection's deadline (connection_guard.cpp)

private:
    friend class ConnectionThreads;
    void watch();
    void set_deadline(double seconds, int phase);
    void refuse(int fd);

    ConnectionLimits limits_;
    std::mutex mutex_;
    std::unordered_set<Connection*> connections_;
    std::atomic<int> open_{0};
    std::atomic<int> queued_{0};  // accepted, waiting for or running in a thread
    std::atomic<uint64_t> refused_{0};
    std::atomic<uint64_t> timed_out_{0};
    std::atomic<bool> stopping_{false};
    std::thread watchdog_;
    std::function<std::string(const std::string&)> probe_;
};

}  // namespace tessera::server
