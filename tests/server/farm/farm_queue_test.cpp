// A farm's API node through the JobQueue interface, against a real redis-server with no render
// node: what a submission publishes for the nodes (the scene's and environment map's bytes under
// their content hash, a built-in by name), the farm's own queue bound, cancel, and readiness
// when Redis goes away. The checks it shares with one process are LocalQueue's test's.
#include "build_paths.h"
#include "server/farm/farm_queue.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "server/store/cluster_keys.h"
#include "server/store/scene_ref.h"
#include "tests/server/redis_suite.h"

namespace tessera::server {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

class FarmQueueTest : public test::WithSuiteRedis<> {
protected:
    void SetUp() override {
        if (!redis_ready("the farm's API node is not tested")) return;
        dir_ = fs::temp_directory_path() / ("tessera_farm_queue_" + std::to_string(::getpid()));
        fs::remove_all(dir_);
        cfg_.data_dir = (dir_ / "data").string();
        cfg_.project_scenes = TESSERA_PROJECT_SCENES;
        cfg_.redis_url = "redis://127.0.0.1:" + std::to_string(redis_->port());
        cfg_.max_queued = 2;
        queue_ = std::make_unique<FarmQueue>(cfg_);
    }
    void TearDown() override {
        if (queue_) queue_->shutdown();
        queue_.reset();
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    std::string get(const std::string& key) { return Redis(redis_->url()).command({"GET", key}).text; }

    fs::path dir_;
    ServiceConfig cfg_;
    std::unique_ptr<FarmQueue> queue_;
};

TEST_F(FarmQueueTest, ASubmissionPublishesWhatNodesLoad) {
    const api::JobStatus file_job = queue_->submit({{"scene", "cornell_box"}, {"environment", "sky"}, {"width", 8}, {"height", 8}});
    EXPECT_EQ(file_job.state, api::JobState::queued);
    EXPECT_EQ(file_job.queue_position.value_or(99), 0u);
    const SceneRef ref = SceneRef::decode(get(keys::job_scene(file_job.id)));
    const auto on_disk = read_scene_file((fs::path(TESSERA_PROJECT_SCENES) / "cornell_box.gltf").string());
    ASSERT_TRUE(on_disk);
    EXPECT_EQ(ref.hash, on_disk->ref.hash);
    EXPECT_EQ(ref.ext, ".gltf");
    EXPECT_EQ(get(keys::scene(ref.hash)), on_disk->bytes) << "the nodes load the bytes the job named";
    const SceneRef env = SceneRef::decode(get(keys::job_environment(file_job.id)));
    EXPECT_EQ(env.ext, ".exr");
    EXPECT_EQ(content_hash(get(keys::scene(env.hash))), env.hash);
    // Each named by its place in the catalog, which the nodes' errors and reports say.
    EXPECT_EQ(ref.name, "cornell_box.gltf");
    EXPECT_EQ(env.name, "sky.exr");

    const api::JobStatus built_in = queue_->submit({{"scene", "builtin:displaced_sphere?triangles=200"}, {"width", 8}, {"height", 8}});
    const SceneRef b = SceneRef::decode(get(keys::job_scene(built_in.id)));
    EXPECT_EQ(b.source, "builtin:displaced_sphere?triangles=200");
    EXPECT_EQ(b.hash, "");
    EXPECT_EQ(b.name, "builtin:displaced_sphere?triangles=200");
    EXPECT_EQ(queue_->queue_depth(), 2u);
}

TEST_F(FarmQueueTest, TheFarmsQueueBoundAndCancel) {
    const json small = {{"scene", "builtin:cornell_box"}, {"width", 8}, {"height", 8}};
    const std::string a = queue_->submit(small).id;
    queue_->submit(small);
    try {
        queue_->submit(small);
        ADD_FAILURE() << "a third job was queued past max_queued 2";
    } catch (const QueueError& e) {
        EXPECT_EQ(e.kind, QueueErrorKind::queue_full);
        EXPECT_GT(e.retry_after_s, 0);
    }
    EXPECT_EQ(queue_->cancel(a).state, api::JobState::canceled);
    EXPECT_EQ(queue_->queue_depth(), 1u);
    EXPECT_NO_THROW(queue_->submit(small)) << "a canceled job's place is free";
    try {
        queue_->cancel("0123456789abcdef");
        ADD_FAILURE() << "an unknown job was canceled";
    } catch (const QueueError& e) {
        EXPECT_EQ(e.kind, QueueErrorKind::not_found);
    }
    EXPECT_FALSE(queue_->live_pass(a)) << "no one process holds a farm's passes";
}

// What an autoscaler watches (no render node here, so nothing is taken): queued jobs by
// priority, and per priority stream the tasks no node has taken (each job's start task).
TEST_F(FarmQueueTest, TheBacklogByPriorityForAnAutoscaler) {
    const json small = {{"scene", "builtin:cornell_box"}, {"width", 8}, {"height", 8}, {"priority", 7}};
    queue_->submit(small);
    const auto by = queue_->queued_by_priority();
    ASSERT_TRUE(by.count(7)) << "the priority-7 job";
    EXPECT_EQ(by.at(7), 1u);
    bool seen = false;
    for (const auto& b : queue_->task_backlog())
        if (b.priority == 7) {
            seen = true;
            EXPECT_EQ(b.lag, 1) << "its start task, not taken";
            EXPECT_EQ(b.pending, 0);
        }
    EXPECT_TRUE(seen);
}

// A shot is a farm job like any other: stored with its scene published for the nodes (which
// render it through the one shot runner: RenderNodeFarm.AShotGivesOneProcessFramesBitForBitAndResumes),
// and its status shows its frames, none written yet.
TEST_F(FarmQueueTest, AShotIsStoredWithItsSceneForTheNodes) {
    const size_t queued = queue_->store().count(api::JobState::queued);
    const api::JobStatus st = queue_->submit({{"scene", "cornell_shot"}, {"width", 8}, {"height", 8}, {"frames", json::array({0, 24, 48})}});
    EXPECT_EQ(queue_->store().count(api::JobState::queued), queued + 1);
    const auto shot_file = read_scene_file((fs::path(TESSERA_PROJECT_SCENES) / "cornell_shot.gltf").string());
    ASSERT_TRUE(shot_file);
    EXPECT_EQ(Redis(redis_->url()).command({"EXISTS", keys::scene(shot_file->ref.hash)}).as_int(), 1)
        << "the shot's scene is published for the nodes";
    const json status = api::to_json(queue_->status(st.id));
    ASSERT_TRUE(status["shot"].is_object()) << status.dump();
    EXPECT_EQ(status["shot"]["frames_total"], 3);
    EXPECT_EQ(status["shot"]["frames_done"], 0);
    EXPECT_EQ(status["shot"]["frames"][2]["state"], "queued");
}

TEST_F(FarmQueueTest, ReadinessSaysWhenRedisIsAway) {
    EXPECT_EQ(queue_->unready_reason(), "");
    // Redis goes: the queue says why it takes no job, and refuses one with when to retry.
    redis_->stop();
    EXPECT_NE(queue_->unready_reason().find("Redis"), std::string::npos) << queue_->unready_reason();
    try {
        queue_->submit({{"scene", "builtin:cornell_box"}, {"width", 8}, {"height", 8}});
        ADD_FAILURE() << "a job was accepted without Redis";
    } catch (const QueueError& e) {
        EXPECT_EQ(e.kind, QueueErrorKind::unavailable) << e.what();
        EXPECT_GT(e.retry_after_s, 0);
    }
    ASSERT_TRUE(redis_->start());
}

}  // namespace
}  // namespace tessera::server
