#include "server/http/connection_stream.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>

namespace tessera::server {

namespace {

constexpr size_t kBufferBytes = 16 * 1024;

bool poll_for(int fd, short events, int timeout_ms) {
    pollfd p{fd, events, 0};
    for (;;) {
        const int n = ::poll(&p, 1, timeout_ms);
        if (n < 0 && errno == EINTR) continue;
        return n > 0 && (p.revents & (events | POLLHUP | POLLERR)) != 0;
    }
}

}  // namespace

void socket_address(int fd, bool peer, std::string& ip, int& port) {
    sockaddr_storage addr{};
    socklen_t len = sizeof addr;
    ip.clear();
    port = 0;
    if ((peer ? getpeername(fd, reinterpret_cast<sockaddr*>(&addr), &len) : getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len)) != 0)
        return;
    char host[INET6_ADDRSTRLEN] = "";
    if (addr.ss_family == AF_INET) {
        const auto* a = reinterpret_cast<const sockaddr_in*>(&addr);
        inet_ntop(AF_INET, &a->sin_addr, host, sizeof host);
        port = ntohs(a->sin_port);
    } else if (addr.ss_family == AF_INET6) {
        const auto* a = reinterpret_cast<const sockaddr_in6*>(&addr);
        inet_ntop(AF_INET6, &a->sin6_addr, host, sizeof host);
        port = ntohs(a->sin6_port);
    }
    ip = host;
}

ConnectionStream::ConnectionStream(int fd, double read_timeout_s, double write_timeout_s)
    : fd_(fd), read_timeout_ms_(int(read_timeout_s * 1000)), write_timeout_ms_(int(write_timeout_s * 1000)), buf_(kBufferBytes) {}

bool ConnectionStream::is_readable() const { return off_ < len_ || poll_for(fd_, POLLIN, read_timeout_ms_); }

bool ConnectionStream::is_writable() const {
    if (!poll_for(fd_, POLLOUT, write_timeout_ms_)) return false;
    // A peer that has gone away: httplib stops a stream's writes on this.
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, 0) > 0 && (p.revents & (POLLERR | POLLHUP)) != 0) return false;
    return true;
}

ssize_t ConnectionStream::fill() {
    if (!poll_for(fd_, POLLIN, read_timeout_ms_)) return -1;
    for (;;) {
        const ssize_t n = ::recv(fd_, buf_.data(), buf_.size(), 0);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return n;
        off_ = 0;
        len_ = size_t(n);
        return n;
    }
}

ssize_t ConnectionStream::read(char* ptr, size_t size) {
    if (left_ == 0) {
        if (in_body_ && !framed_) return 0;  // an unframed body is empty
        if (size > 0 && overrun_ == Overrun::none) overrun_ = in_body_ ? Overrun::body : Overrun::head;
        return -1;
    }
    if (off_ == len_) {
        const ssize_t n = fill();
        if (n <= 0) return n;
    }
    const size_t n = std::min<uint64_t>({uint64_t(size), uint64_t(len_ - off_), left_});
    std::memcpy(ptr, buf_.data() + off_, n);
    off_ += n;
    left_ -= n;
    if (in_body_) {
        body_read_ += n;
        if (on_body_progress_) on_body_progress_(body_read_);
    }
    return ssize_t(n);
}

ssize_t ConnectionStream::write(const char* ptr, size_t size) {
    if (!is_writable()) return -1;
    for (;;) {
        const ssize_t n = ::send(fd_, ptr, size, MSG_NOSIGNAL);
        if (n < 0 && errno == EINTR) continue;
        return n;
    }
}

void ConnectionStream::get_remote_ip_and_port(std::string& ip, int& port) const { socket_address(fd_, true, ip, port); }

void ConnectionStream::get_local_ip_and_port(std::string& ip, int& port) const { socket_address(fd_, false, ip, port); }

bool ConnectionStream::wait_for_request(double seconds) {
    if (off_ < len_) return true;
    if (!poll_for(fd_, POLLIN, int(seconds * 1000))) return false;
    // Readable may mean closed: look without taking the byte.
    char c;
    for (;;) {
        const ssize_t n = ::recv(fd_, &c, 1, MSG_PEEK);
        if (n < 0 && errno == EINTR) continue;
        return n > 0;
    }
}

void ConnectionStream::begin_request(uint64_t head_bytes) {
    left_ = head_bytes;
    in_body_ = false;
    framed_ = true;
    overrun_ = Overrun::none;
}

void ConnectionStream::begin_body(uint64_t body_bytes, bool framed) {
    left_ = framed ? body_bytes : 0;
    in_body_ = true;
    body_read_ = 0;
    framed_ = framed;
}

void ConnectionStream::drain(double seconds) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    char sink[4096];
    // Bounded in bytes too: a client that keeps sending at loopback speed is not read for long.
    for (size_t taken = 0; taken < (8u << 20);) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(until - std::chrono::steady_clock::now()).count();
        if (left <= 0 || !poll_for(fd_, POLLIN, int(std::min<int64_t>(left, 100)))) {
            if (left <= 0) return;
            continue;
        }
        const ssize_t n = ::recv(fd_, sink, sizeof sink, MSG_DONTWAIT);
        if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) return;
        if (n > 0) taken += size_t(n);
    }
}

}  // namespace tessera::server
