// The connection guard on its own, over real loopback sockets: the bound and its 503, probes
// answered past it, the header deadline, close_idle and the open-connection count. The test
// plays httplib's part: a serve function of its own reads requests and calls the guard's hooks
// from the connection's thread, where httplib calls them.
#include "server/http/connection_guard.h"

#include <gtest/gtest.h>
#include <httplib.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "tests/server/raw_socket.h"

namespace tessera::server {
namespace {

using Clock = std::chrono::steady_clock;

// Long enough for a loaded 2-core machine; a failing guard costs the test this much, no more.
constexpr int kWaitMs = 10000;
// A serve function that the guard never cuts still ends, so that a failing test does not hang.
constexpr int kServeSafetyMs = 20000;

const std::string kRequest = "GET /a HTTP/1.1\r\nHost: x\r\n\r\n";
const std::string kServedBody = "served";

class Listener {
public:
    Listener() {
        fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
        sockaddr_in a{};
        a.sin_family = AF_INET;
        a.sin_port = 0;
        a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        socklen_t len = sizeof a;
        if (fd_ < 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(fd_, 64) != 0 ||
            ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len) != 0)
            return;
        port_ = ntohs(a.sin_port);
    }
    ~Listener() {
        if (fd_ >= 0) ::close(fd_);
    }
    Listener(const Listener&) = delete;
    Listener& operator=(const Listener&) = delete;

    // A new loopback connection: the client's end, and the accepted end that the guard serves
    // (-1 for both when it could not be made).
    std::pair<int, int> connect() {
        if (port_ == 0) return {-1, -1};
        const int client = connect_loopback(port_);
        if (client < 0) return {-1, -1};
        const int served = ::accept(fd_, nullptr, nullptr);
        if (served < 0) {
            ::close(client);
            return {-1, -1};
        }
        return {client, served};
    }

private:
    int fd_ = -1;
    int port_ = 0;
};

// The "server" handed to ConnectionGuard::run: what httplib's serving does with the guard's
// hooks, and counters the tests wait on.
struct Backend {
    explicit Backend(ConnectionGuard& g) : guard(g) {}
    ConnectionGuard& guard;
    std::atomic<int> entered{0};    // connections that reached serve
    std::atomic<int> responses{0};  // responses written and reported with response_sent
    std::atomic<int> holding{0};    // requests for /hold waiting to be released

    std::mutex mutex;
    std::condition_variable cv;
    bool released = false;

    void hold() {
        ++holding;
        std::unique_lock<std::mutex> lock(mutex);
        cv.wait_for(lock, std::chrono::milliseconds(kServeSafetyMs), [&] { return released; });
        --holding;
    }
    void release() {
        {
            std::lock_guard<std::mutex> lock(mutex);
            released = true;
        }
        cv.notify_all();
    }
};

// Reads up to the end of a request head into `head`; false when the connection ends (or is
// cut) first.
bool read_head(int fd, std::string& buffered, std::string& head) {
    for (;;) {
        const size_t end = buffered.find("\r\n\r\n");
        if (end != std::string::npos) {
            head = buffered.substr(0, end + 4);
            buffered.erase(0, end + 4);
            return true;
        }
        pollfd p{fd, POLLIN, 0};
        if (::poll(&p, 1, kServeSafetyMs) <= 0) return false;
        char chunk[1024];
        const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
        if (n <= 0) return false;
        buffered.append(chunk, size_t(n));
    }
}

// httplib's part: requests on a keep-alive connection until the client closes or the guard
// cuts it, with the hooks in the order httplib calls them, and the socket closed at the end.
bool serve(void* server, int fd) {
    Backend& b = *static_cast<Backend*>(server);
    ++b.entered;
    std::string buffered, head;
    bool ok = true;
    while (read_head(fd, buffered, head)) {
        b.guard.request_head_read();
        if (head.rfind("GET /hold ", 0) == 0) b.hold();
        b.guard.response_started(kServedBody.size());
        const std::string reply = "HTTP/1.1 200 OK\r\nContent-Length: " + std::to_string(kServedBody.size()) + "\r\n\r\n" + kServedBody;
        if (!send_all(fd, reply)) {
            ok = false;
            break;
        }
        b.guard.response_sent();
        ++b.responses;
    }
    ::shutdown(fd, SHUT_RDWR);
    ::close(fd);
    return ok;
}

// Connections run through ConnectionGuard::run directly, each in a thread of its own (as the
// task queue's threads would). Joined on destruction, after releasing held requests.
class Runner {
public:
    explicit Runner(ConnectionGuard& guard, Backend& backend) : guard_(guard), backend_(backend) {}
    ~Runner() {
        backend_.release();
        for (std::thread& t : threads_) t.join();
    }
    Runner(const Runner&) = delete;
    Runner& operator=(const Runner&) = delete;

    void start(int served_fd) {
        threads_.emplace_back([this, served_fd] { guard_.run(served_fd, &serve, &backend_); });
    }

private:
    ConnectionGuard& guard_;
    Backend& backend_;
    std::vector<std::thread> threads_;
};

// What the peer sends until it closes or resets the connection (`closed`), or until
// `timeout_ms` pass in all.
std::string read_to_close(int fd, int timeout_ms, bool& closed) {
    closed = false;
    std::string out;
    const auto until = Clock::now() + std::chrono::milliseconds(timeout_ms);
    char chunk[4096];
    for (;;) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(until - Clock::now()).count();
        if (left <= 0) return out;
        pollfd p{fd, POLLIN, 0};
        const int r = ::poll(&p, 1, int(left));
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) return out;
        const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            closed = true;
            return out;
        }
        out.append(chunk, size_t(n));
    }
}

// Reads until `needle` has arrived; false when the connection ends or `timeout_ms` pass first.
bool read_until(int fd, const std::string& needle, int timeout_ms = kWaitMs) {
    std::string got;
    const auto until = Clock::now() + std::chrono::milliseconds(timeout_ms);
    char chunk[4096];
    while (got.find(needle) == std::string::npos) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(until - Clock::now()).count();
        if (left <= 0) return false;
        pollfd p{fd, POLLIN, 0};
        const int r = ::poll(&p, 1, int(left));
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) return false;
        const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return false;
        got.append(chunk, size_t(n));
    }
    return true;
}

// One request on an open connection, answered by the backend.
bool exchange(int client) { return send_all(client, kRequest) && read_until(client, kServedBody); }

// Limits whose deadlines stay out of a test that is not about them.
ConnectionLimits relaxed_limits() {
    ConnectionLimits limits;
    limits.header_timeout_s = 60;
    limits.body_timeout_s = 60;
    limits.keep_alive_s = 60;
    return limits;
}

// The bound is kept by the guard's task queue (it counts the connections it has taken), so
// these connections go through it as httplib's accept loop hands them over.
TEST(ConnectionGuard, PastTheBoundAConnectionIsAnswered503AndClosed) {
    ConnectionLimits limits = relaxed_limits();
    limits.max_connections = 2;
    ConnectionGuard guard(limits);
    Backend backend(guard);
    Listener listener;
    std::unique_ptr<httplib::TaskQueue> queue(guard.new_task_queue());
    auto hand_over = [&](int served_fd) { queue->enqueue([&guard, &backend, served_fd] { guard.run(served_fd, &serve, &backend); }); };

    std::vector<Fd> clients;
    clients.reserve(3);
    for (int i = 0; i < 2; ++i) {
        auto [client, served] = listener.connect();
        ASSERT_GE(client, 0);
        clients.emplace_back(client);
        hand_over(served);
    }
    ASSERT_TRUE(eventually([&] { return guard.open() == 2; })) << guard.open();

    auto [client, served] = listener.connect();
    ASSERT_GE(client, 0);
    Fd extra(client);
    hand_over(served);
    bool closed = false;
    const std::string answer = read_to_close(extra.fd, kWaitMs, closed);
    EXPECT_EQ(status_of(answer), 503) << answer;
    EXPECT_NE(answer.find("503"), std::string::npos) << answer;
    EXPECT_NE(answer.find("Connection: close"), std::string::npos) << answer;
    EXPECT_TRUE(closed) << "the refused connection stayed open";
    EXPECT_TRUE(eventually([&] { return guard.refused() == 1; })) << guard.refused();
    EXPECT_EQ(guard.open(), 2);

    for (Fd& c : clients) EXPECT_TRUE(exchange(c.fd)) << "a connection within the bound was not served";
    EXPECT_EQ(guard.refused(), 1u);
    // The refused connection never reached httplib's serving.
    EXPECT_EQ(backend.entered.load(), 2);

    // Their places are free again once they end: a slot that leaks would refuse everyone.
    for (Fd& c : clients) c.reset();
    EXPECT_TRUE(eventually([&] { return guard.open() == 0; })) << guard.open();
    bool served_again = false;
    const auto until = Clock::now() + std::chrono::milliseconds(kWaitMs);
    while (!served_again && Clock::now() < until) {
        auto [again, again_served] = listener.connect();
        ASSERT_GE(again, 0);
        Fd next(again);
        hand_over(again_served);
        served_again = exchange(next.fd);
    }
    EXPECT_TRUE(served_again) << "no connection served after the bound's connections ended";
}

TEST(ConnectionGuard, ProbesAreAnsweredPastTheBound) {
    ConnectionLimits limits = relaxed_limits();
    limits.max_connections = 1;
    // The paths the guard asked the probe for (from its refusing thread).
    std::mutex asked_mutex;
    std::vector<std::string> asked;
    ConnectionGuard guard(limits);
    guard.set_probe([&](const std::string& path) -> std::string {
        {
            std::lock_guard<std::mutex> lock(asked_mutex);
            asked.push_back(path);
        }
        const std::string body = path == "/healthz" ? "alive" : path == "/readyz" ? "ready" : "";
        if (body.empty()) return "";
        return "HTTP/1.1 200 OK\r\nContent-Length: " + std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n" + body;
    });
    Backend backend(guard);
    Listener listener;
    std::unique_ptr<httplib::TaskQueue> queue(guard.new_task_queue());
    auto hand_over = [&](int served_fd) { queue->enqueue([&guard, &backend, served_fd] { guard.run(served_fd, &serve, &backend); }); };

    auto [held, held_served] = listener.connect();
    ASSERT_GE(held, 0);
    Fd holder(held);
    hand_over(held_served);
    ASSERT_TRUE(eventually([&] { return guard.open() == 1; })) << guard.open();

    // The request line is sent before the connection is handed over: the guard reads it from
    // what has arrived when it refuses.
    auto past_the_bound = [&](const std::string& request) {
        auto [client, served] = listener.connect();
        if (client < 0) return std::string("(no connection)");
        Fd c(client);
        send_all(c.fd, request);
        hand_over(served);
        bool closed = false;
        std::string answer = read_to_close(c.fd, kWaitMs, closed);
        if (!closed) answer += "(not closed)";
        return answer;
    };

    const std::string health = past_the_bound("GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n");
    EXPECT_EQ(status_of(health), 200) << health;
    EXPECT_NE(health.find("alive"), std::string::npos) << health;
    const std::string ready = past_the_bound("GET /readyz HTTP/1.1\r\nHost: x\r\n\r\n");
    EXPECT_EQ(status_of(ready), 200) << ready;
    EXPECT_NE(ready.find("ready"), std::string::npos) << ready;
    // A probe answered is not a refusal.
    EXPECT_EQ(guard.refused(), 0u);

    // Other paths, and a longer path that starts like a probe's, are refused as ever.
    const std::string other = past_the_bound("GET /v1/jobs HTTP/1.1\r\nHost: x\r\n\r\n");
    EXPECT_EQ(status_of(other), 503) << other;
    const std::string lookalike = past_the_bound("GET /healthzz HTTP/1.1\r\nHost: x\r\n\r\n");
    EXPECT_EQ(status_of(lookalike), 503) << lookalike;
    EXPECT_TRUE(eventually([&] { return guard.refused() == 2; })) << guard.refused();
    {
        std::lock_guard<std::mutex> lock(asked_mutex);
        EXPECT_EQ(asked, (std::vector<std::string>{"/healthz", "/readyz"}));
    }

    EXPECT_TRUE(exchange(holder.fd)) << "the connection within the bound was not served";
    EXPECT_EQ(backend.entered.load(), 1);
}

// The guard's reason to exist: httplib's per-read timeout does not stop a client that keeps
// sending a byte now and then, the head's deadline does.
TEST(ConnectionGuard, HeaderDeadlineCutsAHeadNotFinishedInTime) {
    ConnectionLimits limits = relaxed_limits();
    // Short for the test, yet long enough that a loaded machine reads the prompt client's head
    // (already sent when its connection starts) well within it.
    limits.header_timeout_s = 1.0;
    ConnectionGuard guard(limits);
    Backend backend(guard);
    Listener listener;
    Runner runner(guard, backend);

    auto [p, p_served] = listener.connect();
    auto [s, s_served] = listener.connect();
    auto [t, t_served] = listener.connect();
    ASSERT_GE(p, 0);
    ASSERT_GE(s, 0);
    ASSERT_GE(t, 0);
    Fd prompt(p), stalled(s), trickling(t);

    std::atomic<bool> stop_trickle{false};
    std::thread trickler;
    struct JoinTrickler {
        std::atomic<bool>& stop;
        std::thread& thread;
        ~JoinTrickler() {
            stop = true;
            if (thread.joinable()) thread.join();
        }
    } join_trickler{stop_trickle, trickler};

    ASSERT_TRUE(send_all(prompt.fd, kRequest));
    ASSERT_TRUE(send_all(stalled.fd, "GET /a HTTP/1.1\r\nHost: x\r\n"));
    ASSERT_TRUE(send_all(trickling.fd, "GET /a HTTP/1.1\r\nHost: x\r\nX-Slow: "));
    const int trickle_fd = trickling.fd;
    trickler = std::thread([&stop_trickle, trickle_fd] {
        const auto until = Clock::now() + std::chrono::milliseconds(kServeSafetyMs);
        while (!stop_trickle && Clock::now() < until && send_all(trickle_fd, "a"))
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
    });

    const auto start = Clock::now();
    runner.start(p_served);
    runner.start(s_served);
    runner.start(t_served);

    EXPECT_TRUE(read_until(prompt.fd, kServedBody)) << "the prompt client was not answered";

    bool closed = false;
    const std::string stalled_got = read_to_close(stalled.fd, kServeSafetyMs, closed);
    EXPECT_TRUE(closed) << "the stalled head was not cut";
    EXPECT_EQ(stalled_got, "");
    // Its deadline started after `start`: a cut before the header timeout is a wrong deadline.
    EXPECT_GE(std::chrono::duration<double>(Clock::now() - start).count(), limits.header_timeout_s * 0.95);
    const std::string trickling_got = read_to_close(trickling.fd, kServeSafetyMs, closed);
    EXPECT_TRUE(closed) << "the trickling head was not cut";
    EXPECT_EQ(trickling_got, "");

    EXPECT_TRUE(eventually([&] { return guard.timed_out() == 2; })) << guard.timed_out();
    // The prompt connection had its response, so it waits for its next request under the
    // keep-alive deadline, not its first head's: still open, and served again.
    EXPECT_TRUE(exchange(prompt.fd)) << "the prompt connection was cut";
    EXPECT_EQ(guard.timed_out(), 2u);

    prompt.reset();
    EXPECT_TRUE(eventually([&] { return guard.open() == 0; })) << guard.open();
}

TEST(ConnectionGuard, CloseIdleClosesConnectionsWaitingForARequest) {
    ConnectionGuard guard(relaxed_limits());
    Backend backend(guard);
    Listener listener;
    Runner runner(guard, backend);

    auto [f, f_served] = listener.connect();
    auto [k, k_served] = listener.connect();
    auto [b, b_served] = listener.connect();
    ASSERT_GE(f, 0);
    ASSERT_GE(k, 0);
    ASSERT_GE(b, 0);
    // fresh: no request yet; kept_alive: answered, waits for its next; busy: in its handler.
    Fd fresh(f), kept_alive(k), busy(b);
    runner.start(f_served);
    runner.start(k_served);
    runner.start(b_served);

    ASSERT_TRUE(exchange(kept_alive.fd));
    // The client has its answer a moment before the hook says the response is sent.
    ASSERT_TRUE(eventually([&] { return backend.responses == 1; }));
    ASSERT_TRUE(send_all(busy.fd, "GET /hold HTTP/1.1\r\nHost: x\r\n\r\n"));
    ASSERT_TRUE(eventually([&] { return backend.holding == 1; }));
    ASSERT_TRUE(eventually([&] { return guard.open() == 3; })) << guard.open();

    guard.close_idle();

    bool closed = false;
    EXPECT_EQ(read_to_close(fresh.fd, kWaitMs, closed), "");
    EXPECT_TRUE(closed) << "a connection without a request stayed open";
    EXPECT_EQ(read_to_close(kept_alive.fd, kWaitMs, closed), "");
    EXPECT_TRUE(closed) << "a connection waiting for its next request stayed open";

    // A request in progress finishes: its answer still arrives whole.
    backend.release();
    EXPECT_TRUE(read_until(busy.fd, kServedBody)) << "close_idle cut a request in progress";
    // Once answered it waits for a request too, and the next close_idle closes it.
    ASSERT_TRUE(eventually([&] { return backend.responses == 2; }));
    guard.close_idle();
    EXPECT_EQ(read_to_close(busy.fd, kWaitMs, closed), "");
    EXPECT_TRUE(closed) << "an answered connection stayed open after close_idle";

    // Closing on stop is not a client's timeout.
    EXPECT_EQ(guard.timed_out(), 0u);
    EXPECT_TRUE(eventually([&] { return guard.open() == 0; })) << guard.open();
}

TEST(ConnectionGuard, OpenCountsConnectionsUntilTheyEnd) {
    ConnectionGuard guard(relaxed_limits());
    Backend backend(guard);
    Listener listener;
    Runner runner(guard, backend);
    EXPECT_EQ(guard.open(), 0);

    std::vector<Fd> clients;
    clients.reserve(3);
    for (int i = 0; i < 3; ++i) {
        auto [client, served] = listener.connect();
        ASSERT_GE(client, 0);
        clients.emplace_back(client);
        runner.start(served);
    }
    ASSERT_TRUE(eventually([&] { return guard.open() == 3; })) << guard.open();
    EXPECT_TRUE(exchange(clients[0].fd));
    EXPECT_EQ(guard.open(), 3);

    // Closed by the client, with or without a request served.
    clients[0].reset();
    EXPECT_TRUE(eventually([&] { return guard.open() == 2; })) << guard.open();
    clients[1].reset();
    clients[2].reset();
    EXPECT_TRUE(eventually([&] { return guard.open() == 0; })) << guard.open();
    EXPECT_EQ(guard.timed_out(), 0u);
    EXPECT_EQ(guard.refused(), 0u);
}

// httplib's serving can throw outside its request loop (out of memory building its stream): the
// connection leaves the guard as if it had returned, so the watchdog and close_idle, which walk
// the open connections, never touch a freed one (ASan's run catches a use after free here).
bool serve_and_throw(void*, int fd) {
    ::close(fd);
    throw std::bad_alloc();
}

TEST(ConnectionGuard, AConnectionWhoseServingThrowsLeavesTheGuard) {
    ConnectionLimits limits = relaxed_limits();
    limits.header_timeout_s = 0.2;  // the watchdog walks the connections while the test runs
    ConnectionGuard guard(limits);
    Listener listener;
    for (int i = 0; i < 3; ++i) {
        auto [client, served] = listener.connect();
        ASSERT_GE(client, 0);
        Fd c(client);
        EXPECT_THROW(guard.run(served, &serve_and_throw, nullptr), std::bad_alloc);
        EXPECT_EQ(guard.open(), 0);
    }
    guard.close_idle();
    std::this_thread::sleep_for(std::chrono::milliseconds(500));  // watchdog rounds past every deadline
    EXPECT_EQ(guard.timed_out(), 0u) << "a connection that left was cut";

    // And the guard serves on.
    Backend backend(guard);
    Runner runner(guard, backend);
    auto [client, served] = listener.connect();
    ASSERT_GE(client, 0);
    Fd c(client);
    runner.start(served);
    EXPECT_TRUE(exchange(c.fd));
}

}  // namespace
}  // namespace tessera::server
