// One process's queue (LocalQueue): its own bound and stop, and a running job's progress from
// the worker's typed job. What every kind of queue shares (submission checks, reads of records and
// results) is tested in job_queue_test.cpp.
#include "server/queue/local_queue.h"

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

}  // namespace
}  // namespace tessera::server
