#include "server/http/connection_guard.h"

#include "server/http/response_bytes.h"
#include "server/http/connection_stream.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <condition_variable>
#include <deque>
#include <functional>
#include <system_error>

#include <httplib.h>
#include <spdlog/spdlog.h>

namespace tessera::server {

namespace {

using Clock = std::chrono::steady_clock;

enum Phase : int { kHead, kBody, kResponse };
const char* const kPhaseName[] = {"request headers", "request body", "response"};

int64_t now_ns() { return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count(); }

// Set by the thread that answers connections past the bound; t_refuse_fast while many wait
// for it (then they are answered without the moment of reading that avoids a reset).
thread_local bool t_refusing = false;
thread_local bool t_refuse_fast = false;

std::string peer_of(int fd) {
    std::string ip;
    int port = 0;
    socket_address(fd, true, ip, port);
    return (ip.empty() ? "?" : ip) + ":" + std::to_string(port);
}

}  // namespace

struct ConnectionGuard::Connection {
    // A duplicate of httplib's descriptor: shutdown() acts on the socket, and the duplicate
    // keeps naming this socket even after httplib closes its own and the number is reused.
    int fd = -1;
    std::string peer;
    std::atomic<int64_t> deadline_ns{0};
    std::atomic<int> phase{kHead};
    int64_t body_start_ns = 0;  // when its request's head was read
    bool cut = false;
    bool close_after = false;  // only its own thread touches this
};

namespace {
thread_local ConnectionGuard::Connection* t_connection = nullptr;
}

// A thread per connection, kept for the next one while few are idle. httplib's ThreadPool has
// a fixed size, so its threads are all taken by as many keep-alive or slow clients. The
// threads are detached and share the pool's state: the last of them may still be leaving
// (unlocking its mutex) when shutdown() has returned and httplib deletes the queue.
class ConnectionThreads final : public httplib::TaskQueue {
public:
    explicit ConnectionThreads(ConnectionGuard& guard) : pool_(std::make_shared<Pool>(guard)) {}
    ~ConnectionThreads() override { shutdown(); }

    void enqueue(std::function<void()> fn) override {
        Pool& p = *pool_;
        std::unique_lock<std::mutex> lock(p.mutex);
        if (p.guard.queued_.load() >= p.guard.limits_.max_connections) {
            p.refusals.push_back(std::move(fn));
            if (!p.refuser_running) {
                p.refuser_running = true;
                ++p.live;
                if (!start_thread([pool = pool_] { refuse_loop(*pool); })) {
                    p.refuser_running = false;
                    --p.live;
                    std::function<void()> first = std::move(p.refusals.front());
                    p.refusals.pop_front();
                    lock.unlock();
                    refuse_here(first);
                    return;
                }
            }
            p.refuse_cv.notify_one();
            return;
        }
        ++p.guard.queued_;
        p.tasks.push_back(std::move(fn));
        // Each idle thread takes one task: a new thread when tasks outnumber them.
        if (int(p.tasks.size()) <= p.idle) {
            p.cv.notify_one();
        } else {
            ++p.live;
            if (!start_thread([pool = pool_] { work_loop(*pool); })) {
                // No thread to be had (a process or memory limit): this connection is refused
                // at once, and the server goes on with the threads it has.
                --p.live;
                --p.guard.queued_;
                std::function<void()> task = std::move(p.tasks.back());
                p.tasks.pop_back();
                lock.unlock();
                refuse_here(task);
            }
        }
    }

    void shutdown() override {
        Pool& p = *pool_;
        std::unique_lock<std::mutex> lock(p.mutex);
        p.stop = true;
        p.cv.notify_all();
        p.refuse_cv.notify_all();
        p.done.wait(lock, [&] { return p.live == 0; });
    }

private:
    template <typename F>
    static bool start_thread(F&& f) {
        try {
            std::thread(std::forward<F>(f)).detach();
            return true;
        } catch (const std::system_error& e) {
            spdlog::error("cannot start a connection thread: {}", e.what());
            return false;
        }
    }

    // Runs a connection's task as a refusal in this (the accepting) thread: a 503 and a close,
    // without the moment of reading.
    static void refuse_here(std::function<void()>& task) {
        t_refusing = true;
        t_refuse_fast = true;
        task();
        t_refusing = false;
        t_refuse_fast = false;
    }

    struct Pool {
        explicit Pool(ConnectionGuard& g) : guard(g) {}
        ConnectionGuard& guard;  // outlives the connections: HttpApi destroys it after the server
        std::mutex mutex;
        std::condition_variable cv, refuse_cv, done;
        std::deque<std::function<void()>> tasks, refusals;
        int idle = 0;
        int live = 0;
        bool stop = false;
        bool refuser_running = false;
    };

    static void work_loop(Pool& p) {
        std::unique_lock<std::mutex> lock(p.mutex);
        for (;;) {
            ++p.idle;
            p.cv.wait_for(lock, std::chrono::seconds(30), [&] { return p.stop || !p.tasks.empty(); });
            --p.idle;
            if (p.tasks.empty()) {
                if (p.stop || p.idle >= p.guard.limits_.spare_threads) break;
                continue;
            }
            std::function<void()> fn = std::move(p.tasks.front());
            p.tasks.pop_front();
            lock.unlock();
            fn();
            fn = nullptr;
            --p.guard.queued_;
            lock.lock();
            if (p.idle >= p.guard.limits_.spare_threads && p.tasks.empty()) break;
        }
        if (--p.live == 0) p.done.notify_all();
    }

    static void refuse_loop(Pool& p) {
        t_refusing = true;
        std::unique_lock<std::mutex> lock(p.mutex);
        for (;;) {
            p.refuse_cv.wait_for(lock, std::chrono::seconds(5), [&] { return p.stop || !p.refusals.empty(); });
            if (p.refusals.empty()) break;
            std::function<void()> fn = std::move(p.refusals.front());
            p.refusals.pop_front();
            t_refuse_fast = p.refusals.size() >= 8;
            lock.unlock();
            fn();
            fn = nullptr;
            lock.lock();
        }
        p.refuser_running = false;
        if (--p.live == 0) p.done.notify_all();
    }

    std::shared_ptr<Pool> pool_;
};

ConnectionGuard::ConnectionGuard(ConnectionLimits limits) : limits_(limits) {
    watchdog_ = std::thread([this] { watch(); });
}

ConnectionGuard::~ConnectionGuard() {
    stopping_ = true;
    if (watchdog_.joinable()) watchdog_.join();
}

httplib::TaskQueue* ConnectionGuard::new_task_queue() { return new ConnectionThreads(*this); }

bool ConnectionGuard::run(int fd, bool (*serve)(void*, int), void* server) {
    if (t_refusing) {
        refuse(fd);
        return false;
    }
    auto conn = std::make_unique<Connection>();
    conn->fd = ::fcntl(fd, F_DUPFD_CLOEXEC, 0);
    if (conn->fd < 0) {
        // Out of descriptors: a connection the watchdog could not cut is not served.
        refuse(fd);
        return false;
    }
    conn->peer = peer_of(fd);
    Connection* c = conn.get();
    c->deadline_ns = now_ns() + int64_t(limits_.header_timeout_s * 1e9);
    {
        std::lock_guard<std::mutex> lock(mutex_);
        connections_.insert(c);
    }
    ++open_;
    t_connection = c;
    // Left the same way whether serve returns or throws (out of memory building its stream):
    // the watchdog and close_idle walk connections_, so the record leaves it before it is freed.
    struct Leave {
        ConnectionGuard& guard;
        Connection* c;
        ~Leave() {
            t_connection = nullptr;
            --guard.open_;
            {
                std::lock_guard<std::mutex> lock(guard.mutex_);
                guard.connections_.erase(c);
            }
            if (c->fd >= 0) ::close(c->fd);
        }
    } leave{*this, c};
    return serve(server, fd);
}

void ConnectionGuard::set_deadline(double seconds, int phase) {
    Connection* c = t_connection;
    if (!c) return;
    c->phase = phase;
    c->deadline_ns = now_ns() + int64_t(seconds * 1e9);
}

void ConnectionGuard::request_head_read() {
    set_deadline(limits_.body_timeout_s, kBody);
    if (t_connection) t_connection->body_start_ns = now_ns();
}

void ConnectionGuard::body_progress(uint64_t bytes_read) {
    Connection* c = t_connection;
    if (!c || c->phase != kBody) return;
    c->deadline_ns = c->body_start_ns + int64_t((limits_.body_timeout_s + double(bytes_read) / limits_.min_rate) * 1e9);
}

void ConnectionGuard::response_started(uint64_t body_bytes) {
    set_deadline(limits_.body_timeout_s + double(body_bytes) / limits_.min_rate, kResponse);
}

void ConnectionGuard::response_streaming(double interval_s) { set_deadline(interval_s + limits_.body_timeout_s, kResponse); }

void ConnectionGuard::close_after_response() {
    if (t_connection) t_connection->close_after = true;
}

bool ConnectionGuard::closing() const { return t_connection && t_connection->close_after; }

void ConnectionGuard::response_sent() {
    // What is left of a refused body is drained for a moment after the answer; otherwise
    // httplib waits up to the keep-alive time for the next request's first byte, and its
    // headers then have the header timeout.
    if (t_connection && t_connection->close_after) set_deadline(2.0, kHead);
    else set_deadline(limits_.keep_alive_s + limits_.header_timeout_s, kHead);
}

void ConnectionGuard::close_idle() {
    std::lock_guard<std::mutex> lock(mutex_);
    for (Connection* c : connections_)
        if (c->phase == kHead && !c->cut) {
            c->cut = true;
            ::shutdown(c->fd, SHUT_RDWR);
        }
}

void ConnectionGuard::watch() {
    while (!stopping_) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        const int64_t now = now_ns();
        std::lock_guard<std::mutex> lock(mutex_);
        for (Connection* c : connections_) {
            if (c->cut || now < c->deadline_ns.load()) continue;
            c->cut = true;
            ::shutdown(c->fd, SHUT_RDWR);
            ++timed_out_;
            // The peer is an address we formatted: nothing the client sent reaches the log.
            spdlog::warn("closed the connection from {}: its {} took longer than allowed", c->peer, kPhaseName[c->phase.load()]);
        }
    }
}

void ConnectionGuard::refuse(int fd) {
    ++refused_;
    const std::string body = "{\"type\":\"/problems/too-many-connections\",\"title\":\"Too many connections\",\"status\":503,"
                             "\"detail\":\"the server holds " + std::to_string(limits_.max_connections) +
                             " open connections, its bound (tessera serve --max-connections); retry shortly\"}";
    const std::string response = "HTTP/1.1 503 Service Unavailable\r\nContent-Type: application/problem+json\r\n"
                                 "Date: " + http_date(std::time(nullptr)) + "\r\n"
                                 "Retry-After: 1\r\nConnection: close\r\nContent-Length: " + std::to_string(body.size()) +
                                 "\r\n\r\n" + body;
    // A refused client must read the answer, not a reset: send it, end our side, and read what
    // the client had sent for a moment before closing (closing on unread data sends RST).
    const std::string peer = peer_of(fd);
    timeval tv{0, 200'000};
    setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
    // A liveness or readiness probe is answered even here, so that a full server is not taken
    // for a dead one: its request line, if it has arrived (briefly waited for, not at all while
    // many wait).
    std::string answer;
    if (probe_) {
        char head[256];
        pollfd p{fd, POLLIN, 0};
        if (::poll(&p, 1, t_refuse_fast ? 0 : 250) > 0) {
            const ssize_t n = ::recv(fd, head, sizeof head - 1, MSG_PEEK | MSG_DONTWAIT);
            const std::string line(head, size_t(std::max<ssize_t>(n, 0)));
            for (const char* path : {"/healthz", "/readyz"}) {
                if (line.rfind(std::string("GET ") + path + " ", 0) != 0) continue;
                try {
                    answer = probe_(path);
                } catch (const std::exception& e) {
                    spdlog::error("probe {} past the connection bound: {}", path, e.what());
                }
            }
        }
    }
    if (!answer.empty()) {
        --refused_;
        (void)!::send(fd, answer.data(), answer.size(), MSG_NOSIGNAL);
        ::shutdown(fd, SHUT_WR);
        char sink[1024];
        for (int i = 0; i < 64 && ::recv(fd, sink, sizeof sink, MSG_DONTWAIT) > 0; ++i) {}
        ::close(fd);
        return;
    }
    (void)!::send(fd, response.data(), response.size(), MSG_NOSIGNAL);
    ::shutdown(fd, SHUT_WR);
    char sink[4096];
    pollfd p{fd, POLLIN, 0};
    const auto until = Clock::now() + std::chrono::milliseconds(t_refuse_fast ? 0 : 200);
    while (Clock::now() < until && ::poll(&p, 1, 50) > 0) {
        const ssize_t n = ::recv(fd, sink, sizeof sink, MSG_DONTWAIT);
        if (n <= 0) break;
    }
    spdlog::warn("refused a connection from {}: {} connections are open", peer, limits_.max_connections);
    ::close(fd);
}

}  // namespace tessera::server
