#pragma once
// A redis-server child process (Debian's binary) for tests and benchmarks: its own temporary
// directory, a random loopback port, AOF on with the given fsync policy ("off": no AOF). Tests skip where the
// binary is absent, unless TESSERA_REQUIRE_REDIS=1 (CI), where they fail.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <thread>

#include "server/store/redis_client.h"

namespace tessera::server {

inline std::string find_redis_server() {
    for (const char* dir : {"/usr/bin", "/usr/local/bin", "/usr/sbin"}) {
        const std::string p = std::string(dir) + "/redis-server";
        if (::access(p.c_str(), X_OK) == 0) return p;
    }
    return "";
}

inline bool redis_required() {
    const char* v = std::getenv("TESSERA_REQUIRE_REDIS");
    return v && std::string(v) == "1";
}

class RedisServer {
public:
    explicit RedisServer(std::string appendfsync = "always") : appendfsync_(std::move(appendfsync)) {
        binary_ = find_redis_server();
        dir_ = std::filesystem::temp_directory_path() / ("tessera_redis_" + std::to_string(::getpid()) + "_" +
                                                         std::to_string(std::random_device{}()));
        std::filesystem::create_directories(dir_);
    }
    ~RedisServer() {
        stop();
        std::error_code ec;
        std::filesystem::remove_all(dir_, ec);
    }
    bool available() const { return !binary_.empty(); }

    // Starts it (again, on the same port and directory after a stop or kill); false if it
    // did not answer within 10 s.
    bool start() {
        for (int attempt = 0; attempt < 20; ++attempt) {
            if (port_ == 0) port_ = 20000 + int(std::random_device{}() % 40000);
            pid_ = ::fork();
            if (pid_ == 0) {
                const std::string port = std::to_string(port_), dir = dir_.string();
                ::execl(binary_.c_str(), binary_.c_str(), "--port", port.c_str(), "--bind", "127.0.0.1", "--dir", dir.c_str(),
                        "--appendonly", appendfsync_ == "off" ? "no" : "yes", "--appendfsync",
                        appendfsync_ == "off" ? "everysec" : appendfsync_.c_str(), "--save", "", "--daemonize", "no",
                        "--logfile", (dir + "/redis.log").c_str(), static_cast<char*>(nullptr));
                ::_exit(127);
            }
            for (int i = 0; i < 200; ++i) {
                try {
                    Redis r(url(), 1.0);
                    if (r.command({"PING"}).text == "PONG") return true;
                } catch (...) {
                }
                int status = 0;
                if (::waitpid(pid_, &status, WNOHANG) == pid_) { pid_ = -1; break; }  // port taken: another one
                std::this_thread::sleep_for(std::chrono::milliseconds(50));
            }
            if (pid_ > 0) return false;
            port_ = 0;
        }
        return false;
    }
    void stop(int sig = SIGTERM) {
        if (pid_ <= 0) return;
        ::kill(pid_, sig);
        int status = 0;
        ::waitpid(pid_, &status, 0);
        pid_ = -1;
    }
    RedisUrl url() const {
        RedisUrl u;
        u.host = "127.0.0.1";
        u.port = port_;
        return u;
    }
    int port() const { return port_; }

private:
    std::string appendfsync_;
    std::string binary_;
    std::filesystem::path dir_;
    int port_ = 0;
    pid_t pid_ = -1;
};

}  // namespace tessera::server
