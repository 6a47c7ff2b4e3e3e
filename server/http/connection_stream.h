#pragma once
// One connection's byte stream as httplib reads requests from it and writes answers to it.
//
// httplib 0.11 makes a new stream, with a new read buffer, for every request of a keep-alive
// connection: the bytes of a pipelined second request, read ahead into the first one's buffer,
// are dropped with it. This stream lives as long as the connection, so pipelined requests are
// answered in order. It also bounds what a client may send before the server has decided
// anything: a request's head, and its body however it is framed (Content-Length, chunked, or
// none), are read against budgets set per request; a read past one fails, and the connection
// says which budget it broke.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <httplib.h>

namespace tessera::server {

// A socket's address, its peer's (`peer`) or its own: "" and 0 when it has none.
void socket_address(int fd, bool peer, std::string& ip, int& port);

class ConnectionStream final : public httplib::Stream {
public:
    enum class Overrun { none, head, body };

    ConnectionStream(int fd, double read_timeout_s, double write_timeout_s);

    bool is_readable() const override;
    bool is_writable() const override;
    ssize_t read(char* ptr, size_t size) override;
    ssize_t write(const char* ptr, size_t size) override;
    void get_remote_ip_and_port(std::string& ip, int& port) const override;
    void get_local_ip_and_port(std::string& ip, int& port) const override;
    int socket() const override { return fd_; }

    // Waits up to `seconds` for the first byte of the next request: bytes already read ahead
    // (a pipelined request) count. False when the client closed or stayed silent.
    bool wait_for_request(double seconds);
    // A new request starts: its line and headers may take `head_bytes`.
    void begin_request(uint64_t head_bytes);
    // The head is parsed: its body may take `body_bytes` more. `framed` is false for a request
    // with neither Content-Length nor Transfer-Encoding, whose body is empty (RFC 9112 6.3):
    // reads then end at once instead of waiting for the client to close.
    void begin_body(uint64_t body_bytes, bool framed);
    Overrun overrun() const { return overrun_; }
    // Told the body's bytes read so far, after each read of it (the guard's rate deadline).
    void on_body_progress(std::function<void(uint64_t)> f) { on_body_progress_ = std::move(f); }
    // After a refused request whose body was not read: reads and drops what the client still
    // sends, for up to `seconds` or until it closes, so that it reads the answer, not a reset.
    void drain(double seconds);

private:
    ssize_t fill();

    int fd_;
    int read_timeout_ms_;
    int write_timeout_ms_;
    std::vector<char> buf_;
    size_t off_ = 0, len_ = 0;
    uint64_t left_ = 0;   // bytes the current phase may still read
    bool framed_ = true;  // past the budget: an error (true) or the end of an empty body
    bool in_body_ = false;
    uint64_t body_read_ = 0;
    std::function<void(uint64_t)> on_body_progress_;
    Overrun overrun_ = Overrun::none;
};

}  // namespace tessera::server
