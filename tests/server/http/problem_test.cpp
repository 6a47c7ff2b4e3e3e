// The queue's typed refusals become HTTP here alone: every kind has its status, and the code,
// title, field, location and retry time reach the problem unchanged.
#include "server/http/problem.h"

#include <gtest/gtest.h>

#include <set>

namespace tessera::server {
namespace {

TEST(Problem, EveryQueueErrorKindHasItsStatus) {
    const std::pair<QueueErrorKind, int> expected[] = {
        {QueueErrorKind::invalid, 400},    {QueueErrorKind::not_found, 404},   {QueueErrorKind::conflict, 409},
        {QueueErrorKind::gone, 410},       {QueueErrorKind::broken_file, 422}, {QueueErrorKind::queue_full, 429},
        {QueueErrorKind::store_full, 507}, {QueueErrorKind::unavailable, 503},
    };
    std::set<int> statuses;
    for (const auto& [kind, status] : expected) {
        EXPECT_EQ(http_status(kind), status);
        statuses.insert(http_status(kind));
    }
    EXPECT_EQ(statuses.size(), std::size(expected)) << "two kinds share a status";
}

TEST(Problem, CarriesEverythingTheRefusalSays) {
    const Problem p = problem(QueueError(QueueErrorKind::broken_file, "invalid-scene", "The scene file is broken", "no buffer 3")
                                  .with_field("/scene")
                                  .with_location("a.gltf#/meshes/0")
                                  .with_retry_after(7));
    EXPECT_EQ(p.status, 422);
    EXPECT_EQ(p.slug, "invalid-scene");
    EXPECT_EQ(p.title, "The scene file is broken");
    EXPECT_STREQ(p.what(), "no buffer 3");
    EXPECT_EQ(p.field.value_or(""), "/scene");
    EXPECT_EQ(p.location, "a.gltf#/meshes/0");
    EXPECT_EQ(p.retry_after, 7);
    EXPECT_FALSE(problem(QueueError(QueueErrorKind::gone, "gone", "No such result", "deleted")).field);
}

TEST(Problem, AStoreRefusalSaysWhetherItIsFull) {
    const Problem f = store_problem(StoreError("disk full", true));
    EXPECT_EQ(f.status, 507);
    EXPECT_GT(f.retry_after, 0);
    const Problem u = store_problem(StoreError("locked", false));
    EXPECT_EQ(u.status, 503);
    EXPECT_GT(u.retry_after, 0);
}

}  // namespace
}  // namespace tessera::server
