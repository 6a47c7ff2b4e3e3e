#pragma once
// A LocalQueue of the test's own in a temporary data directory, with the helpers the queue tests
// share: the refusal a call throws, and waiting for a job's final state.
#include "build_paths.h"
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "server/queue/local_queue.h"

namespace tessera::server::test {

namespace fs = std::filesystem;
using nlohmann::json;

inline const json kSmall = {{"scene", "builtin:cornell_box"}, {"width", 16}, {"height", 12}, {"spp", 1}};
inline const json kLong = {{"scene", "builtin:cornell_spheres"}, {"width", 400}, {"height", 300}, {"spp", 4096}, {"tile_size", 16}};

class LocalQueueTest : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("tessera_local_queue_" + std::to_string(::getpid()) + "_" +
                                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
    }
    void open(size_t max_queued = 1000, uint64_t max_triangles = LoadLimits{}.max_triangles) {
        QueueConfig cfg;
        cfg.data_dir = dir_.string();
        cfg.project_scenes = TESSERA_PROJECT_SCENES;
        cfg.render_threads = 1;
        cfg.max_queued = max_queued;
        cfg.load_limits.max_triangles = max_triangles;
        queue_ = std::make_unique<LocalQueue>(cfg);
    }
    void TearDown() override {
        queue_.reset();
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    // The refusal `f` throws; fails the test when it throws none.
    static QueueError refusal(const std::function<void()>& f) {
        try {
            f();
        } catch (const QueueError& e) {
            return e;
        }
        ADD_FAILURE() << "no QueueError";
        return QueueError(QueueErrorKind::invalid, "none", "none", "none");
    }
    api::JobStatus wait_final(const std::string& id) {
        for (int i = 0; i < 3000; ++i) {
            const api::JobStatus s = queue_->status(id);
            if (api::is_final(s.state)) return s;
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        ADD_FAILURE() << "job " << id << " did not finish";
        return queue_->status(id);
    }

    fs::path dir_;
    std::unique_ptr<LocalQueue> queue_;
};

}  // namespace tessera::server::test
