#include "engine/render/checkpoint.h"
#include "engine/render/passes.h"

#include <algorithm>
#include <gtest/gtest.h>

#include <atomic>
#include <cstring>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "engine/render/renderer.h"
#include "engine/scene/procedural.h"

namespace tessera {
namespace {

// Passes of their own (an on_pass callback makes the render progressive, as a server's is),
// the error estimate on, tiles small enough that a pass has many.
RenderSettings settings(const char* kind) {
    RenderSettings s;
    s.width = 48;
    s.height = 40;
    s.spp = 16;
    s.max_depth = 3;
    s.light_rays = 1;
    s.seed = 7;
    s.tile_size = 8;
    s.threads = 2;
    s.estimate_error = true;
    if (std::string(kind) == "adaptive") s.adaptive = AdaptiveSettings{4, 0.05f};
    if (std::string(kind) == "denoise") {
        s.denoise = true;
        s.aovs = aov_bit(Aov::albedo) | aov_bit(Aov::diffuse_direct);
    }
    return s;
}

struct Stopped {
    RenderResult result;
    std::vector<std::unique_ptr<RenderCheckpoint>> checkpoints;
};

// A render with every callback a server sets; `stop_after` tiles in, it is canceled.
Stopped render_with(const RenderScene& scene, const RenderSettings& s, const RenderCheckpoint* resume, size_t stop_after,
                double every_s) {
    Stopped run;
    std::atomic<bool> cancel{false};
    std::atomic<size_t> tiles{0};
    std::mutex m;
    RenderCallbacks cb;
    cb.cancel = &cancel;
    cb.resume = resume;
    cb.on_pass = [](const PassView&) {};
    cb.progress = [&](const RenderProgress&) {
        if (++tiles >= stop_after) cancel = true;
    };
    cb.checkpoint_seconds = every_s;
    cb.on_checkpoint = [&](const RenderCheckpoint& c) {
        std::lock_guard<std::mutex> lock(m);
        run.checkpoints.push_back(std::make_unique<RenderCheckpoint>(c));
    };
    run.result = render(scene, s, cb);
    return run;
}

bool same_bits(const Image& a, const Image& b) {
    return a.rgb.size() == b.rgb.size() && std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)) == 0 &&
           a.sample_count == b.sample_count;
}

// Stopped anywhere (early, mid-pass, late), with checkpoints taken while other threads render,
// and continued through the checkpoint's bytes: the same image as a render never stopped.
TEST(Checkpoint, AResumedRenderEndsBitForBitAsOneNeverStopped) {
    const RenderScene scene = build_render_scene(cornell_spheres(), {});
    for (const char* kind : {"uniform", "adaptive", "denoise"}) {
        const RenderSettings s = settings(kind);
        const Stopped whole = render_with(scene, s, nullptr, size_t(-1), 0);
        ASSERT_FALSE(whole.result.stats.canceled);
        // 30 tiles a pass; a denoising render's fifth pass (to 16 spp) is guided: 130 stops in it.
        std::vector<size_t> stops = {3, 40, 95};
        if (std::string(kind) == "denoise") stops.push_back(130);
        for (size_t stop_after : stops) {
            // Every tile a checkpoint is due: they are taken from render threads between tiles.
            const Stopped stopped = render_with(scene, s, nullptr, stop_after, 1e-9);
            ASSERT_TRUE(stopped.result.stats.canceled) << kind;
            ASSERT_GE(stopped.checkpoints.size(), 1u);
            // The last (at the stop) and one taken while rendering.
            for (size_t which : {stopped.checkpoints.size() - 1, stopped.checkpoints.size() / 2}) {
                const RenderCheckpoint c = decode_checkpoint(encode_checkpoint(*stopped.checkpoints[which]));
                const Stopped resumed = render_with(scene, s, &c, size_t(-1), 0);
                EXPECT_TRUE(same_bits(resumed.result.image, whole.result.image)) << kind << ", stopped after " << stop_after
                                                                               << " tiles, checkpoint " << which;
                EXPECT_GT(c.film_samples(), 0u);
                EXPECT_EQ(resumed.result.resumed_samples, c.film_samples());
                EXPECT_EQ(resumed.result.stats.samples, whole.result.stats.samples) << kind;
                if (whole.result.denoised) {
                    ASSERT_TRUE(resumed.result.denoised);
                    EXPECT_TRUE(same_bits(resumed.result.denoised->image, whole.result.denoised->image)) << kind;
                }
            }
        }
    }
}

// A checkpoint whose guided targets are absurd (a damaged or foreign file) is continued without
// them: the render ends, and no pixel gets more than the cap's samples.
TEST(Checkpoint, AbsurdGuidedTargetsAreDropped) {
    const RenderScene scene = build_render_scene(cornell_spheres(), {});
    const RenderSettings s = settings("denoise");
    const Stopped stopped = render_with(scene, s, nullptr, 130, 0);
    ASSERT_TRUE(stopped.result.stats.canceled);
    RenderCheckpoint c = *stopped.checkpoints.back();
    ASSERT_FALSE(c.film.goal.empty()) << "stopped in a guided pass";
    // Four times the cap (kGuidedCap × 16 spp): without the check, every pixel would be taken there.
    std::fill(c.film.goal.begin(), c.film.goal.end(), uint32_t(4 * kGuidedCap * s.spp));
    const Stopped resumed = render_with(scene, s, &c, size_t(-1), 0);
    EXPECT_FALSE(resumed.result.stats.canceled);
    EXPECT_EQ(resumed.result.resumed_samples, c.film_samples());
    const float most = *std::max_element(resumed.result.image.sample_count.begin(), resumed.result.image.sample_count.end());
    EXPECT_LE(most, float(kGuidedCap * s.spp));
}

// Twice stopped, twice resumed (a job paused twice): still the same image.
TEST(Checkpoint, StoppedAgainAfterAResumeStillEndsTheSame) {
    const RenderScene scene = build_render_scene(cornell_spheres(), {});
    const RenderSettings s = settings("uniform");
    const Stopped whole = render_with(scene, s, nullptr, size_t(-1), 0);
    const Stopped first = render_with(scene, s, nullptr, 20, 0);
    ASSERT_EQ(first.checkpoints.size(), 1u);  // only at the stop: no interval asked
    const Stopped second = render_with(scene, s, first.checkpoints.back().get(), 30, 0);
    ASSERT_TRUE(second.result.stats.canceled);
    ASSERT_EQ(second.checkpoints.size(), 1u);
    EXPECT_GT(second.checkpoints.back()->film_samples(), first.checkpoints.back()->film_samples());
    const Stopped last = render_with(scene, s, second.checkpoints.back().get(), size_t(-1), 0);
    EXPECT_TRUE(same_bits(last.result.image, whole.result.image));
}

// A checkpoint of other settings (size, buffers) is not continued: the render starts afresh.
TEST(Checkpoint, OneThatDoesNotFitIsIgnored) {
    const RenderScene scene = build_render_scene(cornell_spheres(), {});
    const RenderSettings s = settings("uniform");
    const Stopped stopped = render_with(scene, s, nullptr, 20, 0);
    ASSERT_EQ(stopped.checkpoints.size(), 1u);
    for (const char* other : {"size", "adaptive", "denoise"}) {
        RenderSettings t = other == std::string("size") ? settings("uniform") : settings(other);
        if (other == std::string("size")) t.width = 40;
        const Stopped fresh = render_with(scene, t, nullptr, size_t(-1), 0);
        const Stopped run = render_with(scene, t, stopped.checkpoints.back().get(), size_t(-1), 0);
        EXPECT_EQ(run.result.resumed_samples, 0u) << other;
        EXPECT_TRUE(same_bits(run.result.image, fresh.result.image)) << other;
    }
}

TEST(Checkpoint, BytesRoundTripAndDamageIsRefused) {
    const RenderScene scene = build_render_scene(cornell_spheres(), {});
    const Stopped stopped = render_with(scene, settings("adaptive"), nullptr, 30, 0);
    ASSERT_EQ(stopped.checkpoints.size(), 1u);
    const RenderCheckpoint& c = *stopped.checkpoints.back();
    const std::string bytes = encode_checkpoint(c);
    const RenderCheckpoint d = decode_checkpoint(bytes);
    EXPECT_EQ(encode_checkpoint(d), bytes);
    EXPECT_EQ(d.pass, c.pass);
    EXPECT_EQ(d.target, c.target);
    EXPECT_EQ(d.tiles_done, c.tiles_done);
    EXPECT_EQ(d.points.size(), c.points.size());
    EXPECT_EQ(d.stats.samples, c.stats.samples);
    EXPECT_EQ(d.stats.camera_rays, c.stats.camera_rays);
    EXPECT_THROW(decode_checkpoint(""), std::runtime_error);
    EXPECT_THROW(decode_checkpoint(bytes.substr(0, bytes.size() / 2)), std::runtime_error);
    EXPECT_THROW(decode_checkpoint(bytes + "x"), std::runtime_error);
    // One flipped bit anywhere (here: in the sums, in the header, in the checksum).
    for (size_t at : {bytes.size() / 2, size_t(5), bytes.size() - 1}) {
        std::string bad = bytes;
        bad[at] = char(bad[at] ^ 0x10);
        EXPECT_THROW(decode_checkpoint(bad), std::runtime_error) << at;
    }
}

}  // namespace
}  // namespace tessera
