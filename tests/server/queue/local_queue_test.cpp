// One process's queue (LocalQueue): its own bound and stop, a running job's progress from the
// worker's typed job, and a cancel that comes while the worker records a pause. What every kind of queue shares (submission checks, reads of records and
// results) is tested in job_queue_test.cpp.
#include "server/queue/local_queue.h"

#include <spdlog/sinks/base_sink.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <string_view>

#include "tests/server/queue/local_queue_fixture.h"

namespace tessera::server {
namespace {

using namespace test;

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

// Runs `act` on the thread that logs a line holding `needle`, as it logs it: a way in to the
// moment between two steps of a worker, which no poll from outside can hit every time.
class WhenLogged : public spdlog::sinks::base_sink<spdlog::details::null_mutex> {
public:
    WhenLogged(std::string needle, std::function<void()> act) : needle_(std::move(needle)), act_(std::move(act)) {}

protected:
    void sink_it_(const spdlog::details::log_msg& msg) override {
        if (done_ || std::string_view(msg.payload.data(), msg.payload.size()).find(needle_) == std::string_view::npos) return;
        done_ = true;  // before acting: what `act` logs comes back here (on this thread; others may log meanwhile)
        act_();
    }
    void flush_() override {}

private:
    std::string needle_;
    std::function<void()> act_;
    std::atomic<bool> done_{false};
};

TEST_F(LocalQueueTest, ACancelWhileTheWorkerRecordsAPauseCancelsTheJob) {
    open();
    // The cancel lands after the store says "paused" and before the worker lets go of the job:
    // what a client does that cancels as soon as it reads "paused".
    std::string id;
    std::atomic<int> seen{-1};
    auto sink = std::make_shared<WhenLogged>("paused; its film is kept", [&] {
        seen = int(queue_->status(id).state);
        queue_->cancel(id);
    });
    auto& sinks = spdlog::default_logger()->sinks();
    sinks.push_back(sink);  // before any job: no thread logs while the list changes
    id = queue_->submit(kLong).id;
    for (int i = 0; i < 2000 && queue_->status(id).state != api::JobState::running; ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    queue_->pause(id);
    const api::JobStatus end = wait_final(id);
    queue_.reset();  // its workers gone, the sink can go
    sinks.erase(std::remove(sinks.begin(), sinks.end(), sink), sinks.end());
    EXPECT_EQ(seen, int(api::JobState::paused));
    EXPECT_EQ(end.state, api::JobState::canceled);
    EXPECT_FALSE(fs::exists(dir_ / "jobs" / id / "checkpoint.tck")) << "a canceled job keeps no checkpoint";
}

}  // namespace
}  // namespace tessera::server
