// Any byte string sent to the real server as one connection's bytes: httplib's parsing, our
// connection loop and budgets, the router and every handler, in process. Whatever the bytes,
// the process must go on (no crash, no exception out of a thread, no sanitizer report) and the
// connection must end. Seeds: tests/corpus/http (whole requests, some pipelined).
#include "build_paths.h"
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <thread>

#include <spdlog/spdlog.h>

#include "engine/io/image_io.h"
#include "server/http/http_api.h"
#include "server/farm/farm_queue.h"

namespace {
using namespace tessera::server;
struct Harness;
Harness* harness = nullptr;

// One server for the whole run, with small bounds so that what a fuzzed job asks for stays
// cheap: tiny images, few samples, short event streams.
struct Harness {
    Harness() {
        spdlog::set_level(spdlog::level::off);
        // The server's threads (and those they start) leave libFuzzer's SIGALRM watchdog to
        // this one: an accept() it interrupted would end httplib's listener, as no signal can
        // in `tessera serve`, whose threads block them all (cli/serve_command.cpp).
        sigset_t block, old;
        sigemptyset(&block);
        sigaddset(&block, SIGALRM);
        pthread_sigmask(SIG_BLOCK, &block, &old);
        dir = std::filesystem::temp_directory_path() / ("tessera_fuzz_requests_" + std::to_string(::getpid()));
        std::filesystem::remove_all(dir);
        std::filesystem::create_directories(dir);
        ServiceConfig cfg;
        cfg.data_dir = dir.string();
        cfg.project_scenes = TESSERA_PROJECT_SCENES;
        cfg.render_threads = 1;
        cfg.max_queued = 8;
        cfg.job_limits.max_pixels = 32 * 32;
        cfg.job_limits.max_spp = 4;
        cfg.job_limits.max_depth = 3;
        cfg.load_limits.max_texture_bytes = 16 << 20;
        // OpenEXR's global thread pool is a function-local static: made here, before the
        // atexit below, it is destroyed after the queue's workers have stopped, not under a
        // worker writing a frame when libFuzzer calls exit() at the end of its time.
        tessera::write_exr((dir / "warm.exr").string(), tessera::Image(1, 1));
        service = open_job_queue(cfg);
        std::ofstream(dir / "openapi.yaml") << "openapi: 3.0.3\n";
        HttpLimits limits;
        limits.max_job_body = 64 << 10;
        limits.max_upload = 256 << 10;
        limits.event_stream_s = 0.2;
        limits.event_keep_alive_s = 0.1;
        limits.connections.header_timeout_s = 2;
        limits.connections.body_timeout_s = 2;
        api = std::make_unique<HttpApi>(*service, limits, (dir / "openapi.yaml").string());
        port = api->bind("127.0.0.1", 0);
        thread = std::thread([this] { api->serve(); });
        pthread_sigmask(SIG_SETMASK, &old, nullptr);
    }
    // At exit: the listener and the workers stop before the libraries' statics go.
    ~Harness() {
        api->stop();
        thread.join();
        api.reset();
        service.reset();
        std::error_code ec;
        std::filesystem::remove_all(dir, ec);
    }
    std::filesystem::path dir;
    std::unique_ptr<JobQueue> service;
    std::unique_ptr<HttpApi> api;
    std::thread thread;
    int port = 0;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    static Harness* h = [] {
        auto* made = new Harness();
        std::atexit([] { delete harness; });
        return harness = made;
    }();
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(uint16_t(h->port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    // libFuzzer's own signals (its SIGALRM watchdog, LeakSanitizer stopping the world) interrupt
    // this thread's calls: EINTR is no verdict on the server.
    if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
        if (errno != EINTR) __builtin_trap();  // the server stopped listening
        pollfd w{fd, POLLOUT, 0};
        int err = 0;
        socklen_t len = sizeof err;
        while (::poll(&w, 1, 30000) < 0 && errno == EINTR) {}
        if (getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len) != 0 || err != 0) __builtin_trap();
    }
    // Reset rather than TIME_WAIT on close: a run opens hundreds of thousands of connections.
    const linger reset{1, 0};
    setsockopt(fd, SOL_SOCKET, SO_LINGER, &reset, sizeof reset);
    size_t sent = 0;
    while (sent < size) {
        const ssize_t n = ::send(fd, data + sent, size - sent, MSG_NOSIGNAL);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) break;  // the server ended the connection early (a refusal): fine
        sent += size_t(n);
    }
    ::shutdown(fd, SHUT_WR);
    // Read until the server closes: every connection must end (the input is all sent and our
    // side shut, so the server has nothing to wait for; its deadlines end the rest).
    char buf[16384];
    pollfd p{fd, POLLIN, 0};
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    for (;;) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
        if (left <= 0) __builtin_trap();  // a connection that never ends
        const int r = ::poll(&p, 1, int(left));
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) __builtin_trap();
        const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) break;
    }
    ::close(fd);
    return 0;
}
