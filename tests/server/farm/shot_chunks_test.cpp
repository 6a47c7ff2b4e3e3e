// A farm's shot in chunks: the size chosen from measured times, and the cut that covers every
// frame once.
#include "server/farm/shot_chunks.h"

#include <gtest/gtest.h>

namespace tessera::server {
namespace {

TEST(ShotChunks, AJobsOwnChunkWins) {
    EXPECT_EQ(chunk_frames(5.0, 0.01, 1000, 4, 7), 7u);
}

// Opening the scene again costs at most a twentieth of a chunk: 0.5 s to open and 0.1 s a
// frame make chunks of 100 frames, unless that would leave nodes idle.
TEST(ShotChunks, OpeningIsAmortisedButEveryNodeGetsWork) {
    EXPECT_EQ(chunk_frames(0.5, 0.1, 10'000, 4, 0), 100u);
    EXPECT_EQ(chunk_frames(0.5, 0.1, 120, 4, 0), 30u);   // 120 frames over 4 nodes
    EXPECT_EQ(chunk_frames(0.001, 10.0, 120, 4, 0), 1u);  // cheap to open, slow to render: one frame a task
    EXPECT_EQ(chunk_frames(0.5, 0.0, 50, 2, 0), 25u);     // a frame too fast to time
    EXPECT_EQ(chunk_frames(0.5, 0.1, 0, 4, 0), 1u);
    EXPECT_EQ(chunk_frames(0.5, 0.1, 7, 0, 0), 7u);       // no node seen live: one chunk
}

TEST(ShotChunks, TheCutCoversEveryFrameOnce) {
    const auto c = plan_chunks(1, 11, 4);
    ASSERT_EQ(c.size(), 3u);
    EXPECT_EQ(c[0], std::make_pair(size_t(1), size_t(4)));
    EXPECT_EQ(c[1], std::make_pair(size_t(5), size_t(4)));
    EXPECT_EQ(c[2], std::make_pair(size_t(9), size_t(2)));
    EXPECT_TRUE(plan_chunks(1, 1, 4).empty());
    EXPECT_EQ(plan_chunks(0, 3, 0).size(), 3u);  // a chunk of 0 is a chunk of 1
}

}  // namespace
}  // namespace tessera::server
