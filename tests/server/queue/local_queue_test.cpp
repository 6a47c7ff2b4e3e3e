// One process's queue through the JobQueue interface, with no HTTP: submissions are checked and
// refused with typed errors (the kind, a stable code and the field at fault), statuses are api/
// types, and the refusals for results, cancels and a stopped queue each have their kind.
#include "server/queue/local_queue.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

namespace tessera::server {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const json kSmall = {{"scene", "builtin:cornell_box"}, {"width", 16}, {"height", 12}, {"spp", 1}};
const json kLong = {{"scene", "builtin:cornell_spheres"}, {"width", 400}, {"height", 300}, {"spp", 4096}, {"tile_size", 16}};

class LocalQueueTest : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("tessera_local_queue_" + std::to_string(::getpid()) + "_" +
                                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
    }
    void open(size_t max_queued = 1000) {
        QueueConfig cfg;
        cfg.data_dir = dir_.string();
        cfg.project_scenes = TESSERA_PROJECT_SCENES;
        cfg.render_threads = 1;
        cfg.max_queued = max_queued;
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

TEST_F(LocalQueueTest, SubmissionsAreRefusedWithTheirKindCodeAndField) {
    open();
    struct Case {
        json body;
        QueueErrorKind kind;
        std::string code, field;
    };
    const Case cases[] = {
        {{{"scene", "no_such_scene"}}, QueueErrorKind::not_found, "unknown-scene", "/scene"},
        {{{"scene", "cornell_box?triangles=4"}}, QueueErrorKind::not_found, "unknown-scene", "/scene"},
        {{{"scene", "builtin:displaced_sphere?triangles=abc"}}, QueueErrorKind::invalid, "invalid-field", "/scene"},
        {{{"scene", "builtin:cornell_box"}, {"spp", -1}}, QueueErrorKind::invalid, "invalid-field", "/spp"},
        {{{"scene", "builtin:cornell_box"}, {"no_such_field", 1}}, QueueErrorKind::invalid, "invalid-field", "/no_such_field"},
        {{{"scene", "builtin:cornell_box"}, {"environment", "no_such_map"}}, QueueErrorKind::not_found, "unknown-environment", "/environment"},
        {{{"scene", "builtin:cornell_box"}, {"reference", "0123456789abcdef"}}, QueueErrorKind::invalid, "invalid-field", "/reference"},
    };
    for (const Case& c : cases) {
        const QueueError e = refusal([&] { queue_->submit(c.body); });
        EXPECT_EQ(e.kind, c.kind) << c.body.dump() << ": " << e.what();
        EXPECT_EQ(e.code, c.code) << c.body.dump();
        EXPECT_EQ(e.field.value_or("(none)"), c.field) << c.body.dump();
        EXPECT_FALSE(e.title.empty());
    }
    const QueueError cmp = refusal([&] { queue_->submit_comparison({{"scene", "nope"}}); });
    EXPECT_EQ(cmp.kind, QueueErrorKind::not_found) << cmp.what();
    EXPECT_EQ(cmp.code, "unknown-scene");
    const QueueError cmp_field = refusal([&] { queue_->submit_comparison({{"scene", "builtin:cornell_box"}, {"spp", "many"}}); });
    EXPECT_EQ(cmp_field.kind, QueueErrorKind::invalid) << cmp_field.what();
    EXPECT_EQ(cmp_field.title, "Invalid comparison");
    EXPECT_EQ(queue_->list("", 0, 10).total, 0u) << "a refused job was stored";
}

TEST_F(LocalQueueTest, AReferenceMustHaveSucceededAtTheJobsSize) {
    open();
    const std::string running = queue_->submit(kLong).id;
    json body = kSmall;
    body["reference"] = running;
    const QueueError unfinished = refusal([&] { queue_->submit(body); });
    EXPECT_EQ(unfinished.kind, QueueErrorKind::conflict);
    EXPECT_EQ(unfinished.field.value_or(""), "/reference");
    queue_->cancel(running);

    const std::string done = queue_->submit(kSmall).id;
    ASSERT_EQ(wait_final(done).state, api::JobState::succeeded);
    body["reference"] = done;
    body["width"] = 32;
    const QueueError size = refusal([&] { queue_->submit(body); });
    EXPECT_EQ(size.kind, QueueErrorKind::invalid);
    EXPECT_NE(std::string(size.what()).find("16×12"), std::string::npos) << size.what();
    body["width"] = 16;
    EXPECT_NO_THROW(queue_->submit(body));
}

TEST_F(LocalQueueTest, ReadsOfRecordsAndResultsHaveTheirKinds) {
    open();
    EXPECT_EQ(refusal([&] { queue_->status("not-an-id"); }).kind, QueueErrorKind::not_found);
    EXPECT_EQ(refusal([&] { queue_->status("0123456789abcdef"); }).kind, QueueErrorKind::not_found);
    EXPECT_EQ(refusal([&] { queue_->cancel("0123456789abcdef"); }).kind, QueueErrorKind::not_found);
    const QueueError bad_state = refusal([&] { queue_->list("sleeping", 0, 10); });
    EXPECT_EQ(bad_state.kind, QueueErrorKind::invalid);
    EXPECT_EQ(bad_state.field.value_or(""), "state");

    const std::string id = queue_->submit(kLong).id;
    EXPECT_EQ(refusal([&] { queue_->result_path(id, "image.png"); }).kind, QueueErrorKind::conflict);
    EXPECT_EQ(refusal([&] { queue_->delete_results(id); }).kind, QueueErrorKind::conflict);
    EXPECT_EQ(queue_->cancel(id).id, id);
    const api::JobStatus canceled = wait_final(id);
    EXPECT_EQ(canceled.state, api::JobState::canceled);
    EXPECT_EQ(queue_->cancel(id).state, api::JobState::canceled) << "cancel is idempotent";
    EXPECT_EQ(refusal([&] { queue_->result_path(id, "image.png"); }).kind, QueueErrorKind::gone);

    const std::string done = queue_->submit(kSmall).id;
    ASSERT_EQ(wait_final(done).state, api::JobState::succeeded);
    EXPECT_TRUE(fs::exists(queue_->result_path(done, "image.exr")));
    queue_->delete_results(done);
    const QueueError deleted = refusal([&] { queue_->result_path(done, "image.exr"); });
    EXPECT_EQ(deleted.kind, QueueErrorKind::gone);
    EXPECT_NE(std::string(deleted.what()).find("deleted"), std::string::npos) << deleted.what();
}

TEST_F(LocalQueueTest, AFullQueueAndAStoppedOneRefuseWithWhenToRetry) {
    open(/*max_queued=*/1);
    const std::string running = queue_->submit(kLong).id;
    // The worker takes the first job; the next one waits in the queue, and the one after is refused.
    for (int i = 0; i < 1000 && queue_->status(running).state == api::JobState::queued; ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    const api::JobStatus waiting = queue_->submit(kLong);
    EXPECT_EQ(waiting.queue_position.value_or(99), 0u);
    const QueueError full = refusal([&] { queue_->submit(kSmall); });
    EXPECT_EQ(full.kind, QueueErrorKind::queue_full);
    EXPECT_GT(full.retry_after_s, 0);
    EXPECT_EQ(queue_->queue_depth(), 1u);

    queue_->shutdown();
    const QueueError stopped = refusal([&] { queue_->submit(kSmall); });
    EXPECT_EQ(stopped.kind, QueueErrorKind::unavailable);
    EXPECT_EQ(stopped.code, "shutting-down");
    EXPECT_GT(stopped.retry_after_s, 0);
    EXPECT_NE(queue_->unready_reason(), "");
    // Interrupted by the stop, not lost: both are queued in the store for the next start.
    EXPECT_EQ(queue_->status(running).state, api::JobState::queued);
    EXPECT_EQ(queue_->status(waiting.id).state, api::JobState::queued);
}

TEST_F(LocalQueueTest, ARunningJobShowsItsProgressFromTheTypedJob) {
    open();
    const std::string id = queue_->submit(kLong).id;
    api::JobStatus s;
    for (int i = 0; i < 2000; ++i) {
        s = queue_->status(id);
        if (s.live_progress && s.live_progress->samples_done > 0) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ASSERT_TRUE(s.live_progress);
    EXPECT_GT(s.live_progress->fraction, 0.0);
    EXPECT_LT(s.live_progress->fraction, 1.0);
    // The fraction is samples over the job's budget (api::job_progress), whatever shows it.
    EXPECT_NEAR(s.live_progress->fraction,
                double(s.live_progress->samples_done) / (400.0 * 300.0 * 4096.0), 1e-12);
    queue_->cancel(id);
}

}  // namespace
}  // namespace tessera::server
