// What every kind of queue shares (JobQueue, job_queue.cpp), through one process's queue: a
// submission is checked and refused with a typed error (the kind, a stable code and the field at
// fault), statuses are api/ types, and reads of records and results refuse with their kinds.
#include "server/queue/job_queue.h"

#include "tests/server/queue/local_queue_fixture.h"

namespace tessera::server {
namespace {

using namespace test;

// The shared code, run by the kind of queue every test can start.
class JobQueueTest : public LocalQueueTest {};

TEST_F(JobQueueTest, SubmissionsAreRefusedWithTheirKindCodeAndField) {
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

TEST_F(JobQueueTest, AReferenceMustHaveSucceededAtTheJobsSize) {
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

TEST_F(JobQueueTest, ReadsOfRecordsAndResultsHaveTheirKinds) {
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

// A built-in's parameters are held to the loader's bounds at submission, before a triangle is
// made: a server started with --max-triangles is not bloated through a built-in scene.
TEST_F(JobQueueTest, ABuiltInSceneIsHeldToTheTriangleBound) {
    open(1000, /*max_triangles=*/100'000);
    const QueueError e = refusal([&] { queue_->submit({{"scene", "builtin:displaced_sphere?triangles=200000"}}); });
    EXPECT_EQ(e.kind, QueueErrorKind::invalid);
    EXPECT_EQ(e.field.value_or(""), "/scene");
    EXPECT_NE(std::string(e.what()).find("over the limit of 100000"), std::string::npos) << e.what();
    EXPECT_NO_THROW(queue_->submit({{"scene", "builtin:displaced_sphere?triangles=50000"}, {"width", 8}, {"height", 8}}));
}

}  // namespace
}  // namespace tessera::server
