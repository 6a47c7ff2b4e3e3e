#pragma once
// A real server started in-process on an ephemeral loopback port, with a temporary data
// directory, and a client for it: the fixture of the HTTP tests.
#include "build_paths.h"
#include <gtest/gtest.h>
#include <httplib.h>

#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/farm/farm_queue.h"
#include "server/http/http_api.h"

namespace tessera::server {

// A long render: cancellation and priorities need a job that is still running.
inline const nlohmann::json kLongJob = {{"scene", "builtin:cornell_spheres"}, {"width", 400}, {"height", 300}, {"spp", 4096}, {"max_depth", 5}, {"tile_size", 16}};
inline const nlohmann::json kSmallJob = {{"scene", "builtin:cornell_box"}, {"width", 32}, {"height", 24}, {"spp", 2}};

class Server : public ::testing::Test {
protected:
    void start(size_t max_queued = 1000, int64_t max_store_bytes = 0) {
        dir_ = std::filesystem::temp_directory_path() / ("tessera_http_" + std::to_string(::getpid()) + "_" +
                                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
        std::filesystem::remove_all(dir_);
        max_queued_ = max_queued;
        max_store_bytes_ = max_store_bytes;
        open();
    }
    // Stops the server as SIGTERM does and starts it again on the same data directory.
    void restart() {
        service_->shutdown();
        api_->stop();
        thread_.join();
        api_.reset();
        service_.reset();
        open();
    }
    void open() {
        ServiceConfig cfg;
        cfg.data_dir = dir_.string();
        cfg.project_scenes = TESSERA_PROJECT_SCENES;
        cfg.render_threads = 2;
        cfg.max_queued = max_queued_;
        cfg.max_store_bytes = max_store_bytes_;
        cfg.scene_dirs = scene_dirs_;
        cfg.notify = notify_;
        service_ = open_job_queue(cfg);
        std::ofstream(dir_ / "openapi.yaml") << "openapi: 3.0.3\n";
        api_ = std::make_unique<HttpApi>(*service_, limits_, (dir_ / "openapi.yaml").string());
        port_ = api_->bind("127.0.0.1", 0);
        thread_ = std::thread([this] { api_->serve(); });
        client_ = std::make_unique<httplib::Client>("127.0.0.1", port_);
        client_->set_read_timeout(30, 0);
        for (int i = 0; i < 100 && !client_->Get("/healthz"); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    void TearDown() override {
        if (service_) service_->shutdown();
        if (api_) api_->stop();
        if (thread_.joinable()) thread_.join();
        api_.reset();
        service_.reset();
        std::error_code ec;
        std::filesystem::remove_all(dir_, ec);
    }
    httplib::Result post_job(const nlohmann::json& j) { return client_->Post("/v1/jobs", j.dump(), "application/json"); }
    std::string submit(const nlohmann::json& j) {
        auto r = post_job(j);
        EXPECT_TRUE(r);
        EXPECT_EQ(r->status, 202) << r->body;
        return nlohmann::json::parse(r->body)["id"];
    }
    nlohmann::json status(const std::string& id) {
        auto r = client_->Get("/v1/jobs/" + id);
        EXPECT_TRUE(r && r->status == 200);
        return nlohmann::json::parse(r->body);
    }
    nlohmann::json wait_state(const std::string& id, const std::vector<std::string>& states, double timeout_s = 60) {
        const auto t0 = std::chrono::steady_clock::now();
        for (;;) {
            nlohmann::json s = status(id);
            for (const auto& st : states) if (s["state"] == st) return s;
            if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > timeout_s) {
                ADD_FAILURE() << "timed out waiting for " << id << ": " << s.dump();
                return s;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
    }
    void expect_problem(const httplib::Result& r, int status, const std::string& field = "") {
        ASSERT_TRUE(r);
        EXPECT_EQ(r->status, status) << r->body;
        EXPECT_EQ(r->get_header_value("Content-Type"), "application/problem+json") << r->body;
        const nlohmann::json p = nlohmann::json::parse(r->body, nullptr, false);
        ASSERT_FALSE(p.is_discarded()) << r->body;
        EXPECT_EQ(p["status"], status);
        EXPECT_TRUE(p.contains("type") && p.contains("title") && p.contains("detail")) << r->body;
        if (!field.empty()) {
            EXPECT_EQ(p.value("field", ""), field) << r->body;
        }
    }

    static HttpLimits test_limits() {
        HttpLimits limits;
        limits.max_job_body = 4096;
        limits.max_upload = 1 << 20;
        return limits;
    }

    HttpLimits limits_ = test_limits();  // a test may change them before start()
    std::vector<std::string> scene_dirs_;
    std::filesystem::path dir_;
    size_t max_queued_ = 1000;
    NotifyPolicy notify_;  // set before start(): the server's --notify-secret and --notify-allow
    int64_t max_store_bytes_ = 0;
    std::unique_ptr<JobQueue> service_;
    std::unique_ptr<HttpApi> api_;
    std::unique_ptr<httplib::Client> client_;
    std::thread thread_;
    int port_ = 0;
};

}  // namespace tessera::server
