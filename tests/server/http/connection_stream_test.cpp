// ConnectionStream held to what the HTTP server builds on, over real loopback sockets: a
// request's head and body are read no further than their budgets, and a read past one names
// the phase it broke (a timeout or a closed client names none); bytes read ahead stay for the
// next request, so pipelined requests arrive whole; a body without framing is empty at once;
// body progress counts each body's bytes; wait_for_request sees buffered and waiting bytes and
// tells a closed or silent client; a cut (the guard's shutdown from its own thread) ends a
// blocked read, and writes then fail without SIGPIPE, as they do to a client that went away or
// stopped reading; drain drops what a client still sends until it closes, its time is up, or
// (a client that never stops) enough was read; the addresses are the socket's.
#include "server/http/connection_stream.h"

#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "tests/server/raw_socket.h"

namespace tessera::server {
namespace {

using Clock = std::chrono::steady_clock;
using Overrun = ConnectionStream::Overrun;

// Long enough for a loaded 2-core machine; a failing stream costs the test this much, no more.
constexpr int kWaitMs = 10000;
// Read and write timeouts where the test expects none to pass.
constexpr double kLongTimeoutS = 10.0;

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// A listening socket on 127.0.0.1 (or ::1) at a port of the kernel's choosing.
class Listener {
public:
    explicit Listener(int family = AF_INET) : family_(family) {
        fd_ = ::socket(family, SOCK_STREAM, 0);
        if (fd_ < 0) return;
        sockaddr_storage a{};
        socklen_t len = 0;
        if (family == AF_INET) {
            auto* v4 = reinterpret_cast<sockaddr_in*>(&a);
            v4->sin_family = AF_INET;
            v4->sin_addr.s_addr = htonl(INADDR_LOOPBACK);
            len = sizeof(sockaddr_in);
        } else {
            auto* v6 = reinterpret_cast<sockaddr_in6*>(&a);
            v6->sin6_family = AF_INET6;
            v6->sin6_addr = in6addr_loopback;
            len = sizeof(sockaddr_in6);
        }
        if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), len) != 0 || ::listen(fd_, 16) != 0 ||
            ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len) != 0)
            return;
        port_ = family == AF_INET ? ntohs(reinterpret_cast<sockaddr_in*>(&a)->sin_port)
                                  : ntohs(reinterpret_cast<sockaddr_in6*>(&a)->sin6_port);
    }
    ~Listener() {
        if (fd_ >= 0) ::close(fd_);
    }
    Listener(const Listener&) = delete;
    Listener& operator=(const Listener&) = delete;

    int port() const { return port_; }

    // A new connection: the client's end and the accepted end (-1 for both when it failed).
    std::pair<int, int> connect() const {
        if (port_ == 0) return {-1, -1};
        int client = -1;
        if (family_ == AF_INET) {
            client = connect_loopback(port_);
        } else {
            client = ::socket(AF_INET6, SOCK_STREAM, 0);
            sockaddr_in6 a{};
            a.sin6_family = AF_INET6;
            a.sin6_addr = in6addr_loopback;
            a.sin6_port = htons(uint16_t(port_));
            if (client >= 0 && ::connect(client, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
                ::close(client);
                client = -1;
            }
        }
        if (client < 0) return {-1, -1};
        const int served = ::accept(fd_, nullptr, nullptr);
        if (served < 0) {
            ::close(client);
            return {-1, -1};
        }
        return {client, served};
    }

private:
    int family_;
    int fd_ = -1;
    int port_ = 0;
};

int local_port(int fd) {
    sockaddr_storage a{};
    socklen_t len = sizeof a;
    if (::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0) return -1;
    if (a.ss_family == AF_INET) return ntohs(reinterpret_cast<sockaddr_in*>(&a)->sin_port);
    if (a.ss_family == AF_INET6) return ntohs(reinterpret_cast<sockaddr_in6*>(&a)->sin6_port);
    return -1;
}

// Bytes waiting in the socket's receive queue, not yet taken by the stream.
size_t queued(int fd) {
    int n = 0;
    return ::ioctl(fd, FIONREAD, &n) == 0 && n > 0 ? size_t(n) : 0;
}

// Waits until all `n` bytes a test sent are in the served socket, so that the stream's first
// read takes them at once (the read-ahead the tests rely on).
bool arrived(int fd, size_t n) {
    return eventually([&] { return queued(fd) >= n; });
}

// Reads up to `n` bytes, stopping at the first read that gives none.
std::string read_up_to(ConnectionStream& s, size_t n) {
    std::string out;
    char buf[4096];
    while (out.size() < n) {
        const ssize_t r = s.read(buf, std::min(sizeof buf, n - out.size()));
        if (r <= 0) break;
        out.append(buf, size_t(r));
    }
    return out;
}

// A request's head read as httplib's line reader reads it: a byte at a time, to the blank line.
std::string read_head(ConnectionStream& s) {
    std::string out;
    char c;
    while (out.size() < 4 || out.compare(out.size() - 4, 4, "\r\n\r\n") != 0) {
        if (s.read(&c, 1) != 1) break;
        out += c;
    }
    return out;
}

class ConnectionStreamTest : public ::testing::Test {
protected:
    void SetUp() override {
        const auto [client, served] = listener_.connect();
        ASSERT_GE(client, 0);
        ASSERT_GE(served, 0);
        client_.fd = client;
        served_.fd = served;
        // The client's small writes go out at once, not after a delayed ACK.
        const int one = 1;
        ::setsockopt(client_.fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    }

    Listener listener_;
    Fd client_;
    Fd served_;
};

const std::string kGetA = "GET /a HTTP/1.1\r\nHost: x\r\n\r\n";
const std::string kGetB = "GET /b HTTP/1.1\r\nHost: x\r\n\r\n";

TEST_F(ConnectionStreamTest, HeadIsReadNoFurtherThanItsBudget) {
    ASSERT_TRUE(send_all(client_.fd, kGetA + kGetB));
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    s.begin_request(10);
    // Asked for more than the budget at every read: given the budget's bytes and no more.
    std::string got;
    char buf[64];
    while (got.size() < 10) {
        const ssize_t n = s.read(buf, sizeof buf);
        ASSERT_GT(n, 0);
        got.append(buf, size_t(n));
    }
    EXPECT_EQ(got, kGetA.substr(0, 10));
    EXPECT_EQ(s.overrun(), Overrun::none) << "reading exactly the budget is no overrun";
    EXPECT_EQ(s.read(buf, sizeof buf), -1);
    EXPECT_EQ(s.overrun(), Overrun::head);
}

TEST_F(ConnectionStreamTest, BodyIsReadNoFurtherThanItsBudget) {
    const std::string head = "POST /a HTTP/1.1\r\nContent-Length: 5\r\n\r\n";
    ASSERT_TRUE(send_all(client_.fd, head + "hello, and more than was announced"));
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    s.begin_request(1024);
    ASSERT_EQ(read_head(s), head);
    s.begin_body(5, true);
    std::string got;
    char buf[64];
    while (got.size() < 5) {
        const ssize_t n = s.read(buf, sizeof buf);
        ASSERT_GT(n, 0);
        got.append(buf, size_t(n));
    }
    EXPECT_EQ(got, "hello");
    EXPECT_EQ(s.overrun(), Overrun::none);
    EXPECT_EQ(s.read(buf, sizeof buf), -1);
    EXPECT_EQ(s.overrun(), Overrun::body);
}

TEST_F(ConnectionStreamTest, ARefusedBodyBreaksItsBudgetAtItsFirstByte) {
    // The server refuses a body by giving it no budget: the first read of it is the 413's cue.
    const std::string head = "POST /a HTTP/1.1\r\nContent-Length: 5\r\n\r\n";
    ASSERT_TRUE(send_all(client_.fd, head + "hello"));
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    s.begin_request(1024);
    ASSERT_EQ(read_head(s), head);
    s.begin_body(0, true);
    char buf[64];
    EXPECT_EQ(s.read(buf, sizeof buf), -1);
    EXPECT_EQ(s.overrun(), Overrun::body);
}

TEST_F(ConnectionStreamTest, TheNextRequestStartsWithoutAnOverrun) {
    ASSERT_TRUE(send_all(client_.fd, kGetA));
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    s.begin_request(4);
    EXPECT_EQ(read_up_to(s, 100), kGetA.substr(0, 4));
    ASSERT_EQ(s.overrun(), Overrun::head);
    s.begin_request(1024);
    EXPECT_EQ(s.overrun(), Overrun::none);
    // The bytes read ahead past the old budget are the new request's.
    EXPECT_EQ(read_head(s), kGetA.substr(4));
}

TEST_F(ConnectionStreamTest, PipelinedRequestsArriveWhole) {
    const std::string first_head = "POST /a HTTP/1.1\r\nContent-Length: 5\r\n\r\n";
    const std::string first = first_head + "hello";
    ASSERT_TRUE(send_all(client_.fd, first + kGetB));
    ASSERT_TRUE(arrived(served_.fd, first.size() + kGetB.size()));
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    ASSERT_TRUE(s.wait_for_request(kLongTimeoutS));
    s.begin_request(1024);
    EXPECT_EQ(read_head(s), first_head);
    s.begin_body(5, true);
    EXPECT_EQ(read_up_to(s, 5), "hello");
    // The second request is in the stream's buffer alone now: the socket has nothing, so
    // only the bytes read ahead can say a request is waiting.
    EXPECT_EQ(queued(served_.fd), 0u);
    EXPECT_TRUE(s.wait_for_request(0));
    s.begin_request(1024);
    EXPECT_EQ(read_head(s), kGetB);
    EXPECT_EQ(s.overrun(), Overrun::none);
    EXPECT_FALSE(s.wait_for_request(0.2));
}

TEST_F(ConnectionStreamTest, AnUnframedBodyIsEmptyAndLeavesTheNextRequest) {
    // A GET with neither Content-Length nor Transfer-Encoding: the bytes after its head are
    // the next request, not its body (RFC 9112 6.3).
    ASSERT_TRUE(send_all(client_.fd, kGetA + kGetB));
    ASSERT_TRUE(arrived(served_.fd, kGetA.size() + kGetB.size()));
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    std::vector<uint64_t> progress;
    s.on_body_progress([&](uint64_t n) { progress.push_back(n); });
    s.begin_request(1024);
    ASSERT_EQ(read_head(s), kGetA);
    s.begin_body(1 << 20, false);
    char buf[64];
    EXPECT_EQ(s.read(buf, sizeof buf), 0);
    EXPECT_EQ(s.read(buf, sizeof buf), 0);
    EXPECT_EQ(s.overrun(), Overrun::none);
    EXPECT_TRUE(progress.empty());
    EXPECT_TRUE(s.wait_for_request(0));
    s.begin_request(1024);
    EXPECT_EQ(read_head(s), kGetB);
}

TEST_F(ConnectionStreamTest, AnUnframedBodyDoesNotWaitForTheClient) {
    // The client sends its head and waits for the answer: waiting for its body instead would
    // end in the read timeout (-1), not the empty body (0).
    ASSERT_TRUE(send_all(client_.fd, kGetA));
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    s.begin_request(1024);
    ASSERT_EQ(read_head(s), kGetA);
    s.begin_body(1 << 20, false);
    char buf[64];
    EXPECT_EQ(s.read(buf, sizeof buf), 0);
    EXPECT_EQ(s.overrun(), Overrun::none);
}

TEST_F(ConnectionStreamTest, BodyProgressCountsEachBodysBytes) {
    const std::string head1 = "POST /a HTTP/1.1\r\nContent-Length: 10\r\n\r\n";
    const std::string head2 = "POST /b HTTP/1.1\r\nContent-Length: 2\r\n\r\n";
    const std::string all = head1 + "0123456789" + head2 + "ab";
    ASSERT_TRUE(send_all(client_.fd, all));
    ASSERT_TRUE(arrived(served_.fd, all.size()));
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    std::vector<uint64_t> progress;
    s.on_body_progress([&](uint64_t n) { progress.push_back(n); });

    s.begin_request(1024);
    ASSERT_EQ(read_head(s), head1);
    EXPECT_TRUE(progress.empty()) << "a head's bytes counted as body";
    s.begin_body(10, true);
    char buf[3];
    std::string body;
    for (int i = 0; i < 4; ++i) {
        const ssize_t n = s.read(buf, sizeof buf);
        ASSERT_GT(n, 0);
        body.append(buf, size_t(n));
    }
    EXPECT_EQ(body, "0123456789");
    EXPECT_EQ(progress, (std::vector<uint64_t>{3, 6, 9, 10}));

    progress.clear();
    s.begin_request(1024);
    ASSERT_EQ(read_head(s), head2);
    EXPECT_TRUE(progress.empty());
    s.begin_body(2, true);
    EXPECT_EQ(read_up_to(s, 2), "ab");
    ASSERT_FALSE(progress.empty());
    EXPECT_EQ(progress.back(), 2u) << "the second body's count went on from the first's";
}

TEST_F(ConnectionStreamTest, ASilentClientTimesOutWithoutAnOverrun) {
    // A timeout is the guard's business, not a 431 or a 413.
    ConnectionStream s(served_.fd, 0.3, kLongTimeoutS);
    char buf[64];
    s.begin_request(1024);
    auto start = Clock::now();
    EXPECT_EQ(s.read(buf, sizeof buf), -1);
    EXPECT_GE(seconds_since(start), 0.25) << "gave up before the read timeout";
    EXPECT_EQ(s.overrun(), Overrun::none);

    s.begin_body(100, true);
    start = Clock::now();
    EXPECT_EQ(s.read(buf, sizeof buf), -1);
    EXPECT_GE(seconds_since(start), 0.25);
    EXPECT_EQ(s.overrun(), Overrun::none);
}

TEST_F(ConnectionStreamTest, AClosedClientEndsReadsWithoutAnOverrun) {
    ASSERT_TRUE(send_all(client_.fd, "GET"));
    client_.reset();
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    s.begin_request(1024);
    EXPECT_EQ(read_up_to(s, 3), "GET");
    char buf[64];
    EXPECT_EQ(s.read(buf, sizeof buf), 0);
    EXPECT_EQ(s.overrun(), Overrun::none);
}

TEST_F(ConnectionStreamTest, WaitForRequestLeavesTheWaitingBytes) {
    ASSERT_TRUE(send_all(client_.fd, kGetA));
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    ASSERT_TRUE(s.wait_for_request(kLongTimeoutS));
    ASSERT_TRUE(s.wait_for_request(kLongTimeoutS)) << "looking took the byte";
    s.begin_request(1024);
    EXPECT_EQ(read_head(s), kGetA);
}

TEST_F(ConnectionStreamTest, WaitForRequestGivesUpOnASilentClient) {
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    const auto start = Clock::now();
    EXPECT_FALSE(s.wait_for_request(0.3));
    EXPECT_GE(seconds_since(start), 0.25);
}

TEST_F(ConnectionStreamTest, WaitForRequestSeesAClosedClientAtOnce) {
    client_.reset();
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    const auto start = Clock::now();
    EXPECT_FALSE(s.wait_for_request(30.0));
    EXPECT_LT(seconds_since(start), 10.0) << "waited out the keep-alive time for a closed client";
}

TEST_F(ConnectionStreamTest, WaitForRequestTakesARequestSentBeforeTheClientsClose) {
    // curl -d @- and raw_exchange send the request and shut their side: the request is served.
    ASSERT_TRUE(send_all(client_.fd, kGetA));
    ::shutdown(client_.fd, SHUT_WR);
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    ASSERT_TRUE(s.wait_for_request(kLongTimeoutS));
    s.begin_request(1024);
    EXPECT_EQ(read_head(s), kGetA);
    const auto start = Clock::now();
    EXPECT_FALSE(s.wait_for_request(30.0));
    EXPECT_LT(seconds_since(start), 10.0);
}

TEST_F(ConnectionStreamTest, BytesReadAheadAreReadable) {
    ASSERT_TRUE(send_all(client_.fd, "abcdef"));
    ASSERT_TRUE(arrived(served_.fd, 6));
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    s.begin_request(100);
    ASSERT_EQ(read_up_to(s, 2), "ab");
    EXPECT_EQ(queued(served_.fd), 0u);
    // The socket is empty, the stream is not: polling the socket would say no after 10 s.
    EXPECT_TRUE(s.is_readable());
    EXPECT_EQ(read_up_to(s, 4), "cdef");
}

TEST_F(ConnectionStreamTest, NothingToReadIsNotReadable) {
    ConnectionStream s(served_.fd, 0.3, kLongTimeoutS);
    EXPECT_FALSE(s.is_readable());
}

TEST_F(ConnectionStreamTest, WritesReachTheClient) {
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    EXPECT_TRUE(s.is_writable());
    const std::string answer = "HTTP/1.1 204 No Content\r\n\r\n";
    ASSERT_EQ(s.write(answer.data(), answer.size()), ssize_t(answer.size()));
    ::shutdown(served_.fd, SHUT_WR);
    EXPECT_EQ(read_until_close(client_.fd, kWaitMs), answer);
}

TEST_F(ConnectionStreamTest, WritesToAClientThatWentAwayFailWithoutASignal) {
    // MSG_NOSIGNAL or the like: a SIGPIPE would end this test's process, as it would the server.
    client_.reset();
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    const std::string answer = "HTTP/1.1 200 OK\r\n\r\n";
    // TCP learns of the close from the reset that the first write draws.
    EXPECT_TRUE(eventually([&] { return s.write(answer.data(), answer.size()) == -1; }));
    EXPECT_FALSE(s.is_writable());
}

TEST_F(ConnectionStreamTest, WritesGiveUpOnAClientThatStopsReading) {
    // httplib sets a send timeout on the sockets it accepts, so one send cannot block for
    // good; the stream's write timeout is what the test holds.
    const timeval send_timeout{2, 0};
    ::setsockopt(served_.fd, SOL_SOCKET, SO_SNDTIMEO, &send_timeout, sizeof send_timeout);
    ConnectionStream s(served_.fd, kLongTimeoutS, 0.2);
    const std::string chunk(64 << 10, 'x');
    constexpr size_t kCap = size_t(512) << 20;  // far more than loopback's buffers hold
    size_t written = 0;
    ssize_t n = 0;
    while (written < kCap) {
        n = s.write(chunk.data(), chunk.size());
        if (n <= 0) break;
        written += size_t(n);
    }
    EXPECT_EQ(n, -1) << written << " bytes written to a client that reads none";
    EXPECT_LT(written, kCap);
    EXPECT_FALSE(s.is_writable());
}

TEST_F(ConnectionStreamTest, ACutEndsABlockedReadAndTheWrites) {
    // The guard cuts a connection past its deadline with shutdown() from its own thread.
    ConnectionStream s(served_.fd, 30.0, 30.0);
    s.begin_request(1024);
    std::atomic<bool> returned{false};
    std::atomic<ssize_t> result{1};
    std::thread reader([&] {
        char buf[64];
        result = s.read(buf, sizeof buf);
        returned = true;
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the reader is inside its wait
    ::shutdown(served_.fd, SHUT_RDWR);
    EXPECT_TRUE(eventually([&] { return returned.load(); })) << "the read went on after the cut";
    reader.join();  // at the latest when the 30 s read timeout passes
    EXPECT_LE(result.load(), 0);
    EXPECT_EQ(s.overrun(), Overrun::none);

    const auto start = Clock::now();
    EXPECT_FALSE(s.wait_for_request(30.0));
    EXPECT_LT(seconds_since(start), 10.0);
    EXPECT_FALSE(s.is_writable());
    const char c = 'x';
    EXPECT_EQ(s.write(&c, 1), -1);
}

TEST_F(ConnectionStreamTest, DrainDropsWhatAnOpenClientSendsUntilItsTimeIsUp) {
    const std::string early(32 << 10, 'a'), late(16 << 10, 'b');
    ASSERT_TRUE(send_all(client_.fd, early));
    ASSERT_TRUE(arrived(served_.fd, early.size()));
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    // A body sent slowly: some of it comes while the drain runs.
    std::atomic<int64_t> late_sent_ns{INT64_MAX};
    std::thread sender([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        if (send_all(client_.fd, late)) late_sent_ns = Clock::now().time_since_epoch().count();
    });
    ::shutdown(served_.fd, SHUT_WR);  // as the server does: its answer is out
    const auto start = Clock::now();
    s.drain(2.0);
    const auto end = Clock::now();
    sender.join();
    EXPECT_GE(std::chrono::duration<double>(end - start).count(), 1.9) << "left an open client before the time was up";
    if (late_sent_ns.load() < (end - std::chrono::milliseconds(500)).time_since_epoch().count())
        EXPECT_EQ(queued(served_.fd), 0u) << "bytes sent during the drain were left unread";
    else
        EXPECT_LE(queued(served_.fd), late.size()) << "the bytes waiting when the drain began were left unread";
}

TEST_F(ConnectionStreamTest, DrainEndsWhenTheClientCloses) {
    ASSERT_TRUE(send_all(client_.fd, std::string(32 << 10, 'a')));
    client_.reset();
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    ::shutdown(served_.fd, SHUT_WR);
    const auto start = Clock::now();
    s.drain(30.0);
    EXPECT_LT(seconds_since(start), 10.0) << "drained a closed client for its whole time";
}

TEST_F(ConnectionStreamTest, DrainDoesNotReadAnEndlessClientForItsWholeTime) {
    // connection_stream.cpp bounds the drain in bytes too: a client sending at loopback speed
    // cannot hold the connection's thread for the drain's time.
    std::atomic<uint64_t> sent{0};
    std::thread flood([&] {
        const std::string chunk(64 << 10, 'z');
        for (;;) {
            const ssize_t n = ::send(client_.fd, chunk.data(), chunk.size(), MSG_NOSIGNAL);
            if (n <= 0) return;
            sent += uint64_t(n);
        }
    });
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    const auto start = Clock::now();
    s.drain(60.0);
    const double took = seconds_since(start);
    ::shutdown(client_.fd, SHUT_WR);  // ends the flood's send, blocked or not
    flood.join();
    EXPECT_LT(took, 30.0) << "drained for " << took << " s while " << sent.load() << " bytes were sent";
}

TEST_F(ConnectionStreamTest, AddressesAreTheSockets) {
    ConnectionStream s(served_.fd, kLongTimeoutS, kLongTimeoutS);
    EXPECT_EQ(s.socket(), served_.fd);
    std::string ip = "junk";
    int port = -7;
    s.get_remote_ip_and_port(ip, port);
    EXPECT_EQ(ip, "127.0.0.1");
    EXPECT_EQ(port, local_port(client_.fd));
    ip = "junk";
    port = -7;
    s.get_local_ip_and_port(ip, port);
    EXPECT_EQ(ip, "127.0.0.1");
    EXPECT_EQ(port, listener_.port());
    socket_address(client_.fd, true, ip, port);
    EXPECT_EQ(ip, "127.0.0.1");
    EXPECT_EQ(port, listener_.port());
}

TEST(ConnectionStreamAddress, Ipv6Loopback) {
    Listener listener(AF_INET6);
    const auto [client, served] = listener.connect();
    Fd c(client), s(served);
    if (client < 0) GTEST_SKIP() << "no IPv6 loopback here";
    std::string ip;
    int port = 0;
    socket_address(s.fd, true, ip, port);
    EXPECT_EQ(ip, "::1");
    EXPECT_EQ(port, local_port(c.fd));
    socket_address(s.fd, false, ip, port);
    EXPECT_EQ(ip, "::1");
    EXPECT_EQ(port, listener.port());
}

TEST(ConnectionStreamAddress, NoneForAUnixSocketOrAClosedOne) {
    int pair[2];
    ASSERT_EQ(::socketpair(AF_UNIX, SOCK_STREAM, 0, pair), 0);
    Fd a(pair[0]), b(pair[1]);
    for (bool peer : {true, false}) {
        std::string ip = "junk";
        int port = 7;
        socket_address(a.fd, peer, ip, port);
        EXPECT_EQ(ip, "");
        EXPECT_EQ(port, 0);
    }
    ConnectionStream unix_stream(a.fd, kLongTimeoutS, kLongTimeoutS);
    std::string ip = "junk";
    int port = 7;
    unix_stream.get_remote_ip_and_port(ip, port);
    EXPECT_EQ(ip, "");
    EXPECT_EQ(port, 0);

    // A descriptor that names no socket (a logged peer of a closed connection): "" and 0, not
    // what the strings held before.
    ip = "junk";
    port = 7;
    socket_address(-1, true, ip, port);
    EXPECT_EQ(ip, "");
    EXPECT_EQ(port, 0);
}

}  // namespace
}  // namespace tessera::server
