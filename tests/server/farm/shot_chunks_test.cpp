// A farm's shot in chunks: the size chosen from measured times, and the cut that covers every
// frame once.
#include "server/farm/shot_chunks.h"

#include <gtest/gtest.h>

namespace tessera::server {
namespace {

TEST(ShotChunks, AJobsOwnChunkWins) {
    EXPECT_EQ(chunk_frames(5.0, 0.01, 1000, 4, 7), 7u);
}

// Starting a chunk against idle nodes at the end: 0.5 s to start and 0.1 s a frame over 10,000
// frames on 4 nodes is best at √(2·10,000·0.5 / (4·0.1)) ≈ 159 frames, evened to 64 chunks of
// 157 (16 rounds); over 120 frames, 18 evened to 8 chunks of 15.
TEST(ShotChunks, StartingIsAmortisedButEveryNodeGetsWork) {
    EXPECT_EQ(chunk_frames(0.5, 0.1, 10'000, 4, 0), 157u);
    EXPECT_EQ(chunk_frames(0.5, 0.1, 120, 4, 0), 15u);
    EXPECT_EQ(chunk_frames(0.05, 0.3, 119, 2, 0), 5u);   // √(2·119·0.05 / 0.6) ≈ 4.5: 24 chunks, 12 rounds
    EXPECT_EQ(chunk_frames(0.5, 0.1, 120, 1, 0), 30u);   // 35 evened to 4 chunks of 30
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
