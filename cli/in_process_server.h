#pragma once
// A fresh server in this process on a free loopback port, with its own temporary data
// directory and the project's scenes: what the server benches drive. Stopped and removed when
// it goes out of scope.
#include "build_paths.h"
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>
#include <thread>

#include "server/farm/farm_queue.h"
#include "server/http/http_api.h"

namespace tessera::cli {

struct InProcessServer {
    std::filesystem::path dir;
    std::unique_ptr<server::JobQueue> service;
    std::unique_ptr<server::HttpApi> api;
    int port = 0;
    std::thread serving;

    explicit InProcessServer(const std::string& name, server::HttpLimits limits = {}) {
        dir = std::filesystem::temp_directory_path() / ("tessera_bench_" + name + "_" + std::to_string(::getpid()));
        std::filesystem::remove_all(dir);
        server::ServiceConfig cfg;
        cfg.data_dir = dir.string();
        cfg.project_scenes = TESSERA_DEFAULT_SCENES_DIR;
        service = server::open_job_queue(cfg);
        api = std::make_unique<server::HttpApi>(*service, limits, (dir / "none.yaml").string());
        port = api->bind("127.0.0.1", 0);
        serving = std::thread([this] { api->serve(); });
    }
    // Ends the HTTP side (open event streams included), then the workers.
    void stop() {
        if (!api) return;
        api->stop();
        if (serving.joinable()) serving.join();
        service->shutdown();
        api.reset();
    }
    ~InProcessServer() {
        stop();
        std::error_code ec;
        std::filesystem::remove_all(dir, ec);
    }
    InProcessServer(const InProcessServer&) = delete;
    InProcessServer& operator=(const InProcessServer&) = delete;
};

}  // namespace tessera::cli
