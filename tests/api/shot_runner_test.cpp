// A shot through the runner: each frame is the same image bit for bit alone, in any range and
// with any thread count; neighbouring frames differ (motion and decorrelated noise); results,
// contact sheet and report land where the server and the CLI look; progress counts every frame.
#include "api/shot_runner.h"

#include "api/preview_video.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <unistd.h>

#include "build_paths.h"
#include "engine/io/image_io.h"
#include "engine/render/image.h"
#include "tests/engine/io/gltf_test_files.h"
#include "tests/scratch_dir.h"
#include "tests/test_paths.h"

namespace tessera::api {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string shot_scene() { return (fs::path(TESSERA_DEFAULT_SCENES_DIR) / "cornell_shot.gltf").string(); }

class Shot : public ::testing::Test {
protected:
    void SetUp() override { dir_ = test::scratch_dir("tessera_shot"); }
    void TearDown() override { test::remove_scratch_dir(dir_); }
    static RenderJob job(const json& frames, const json& more = json::object()) {
        json body = {{"scene", shot_scene()}, {"width", 24}, {"height", 18}, {"spp", 3}, {"max_depth", 2}, {"frames", frames}};
        body.update(more);
        return parse_render_job(body);
    }
    JobOutcome run(const RenderJob& j, const std::string& sub, int threads = 2, const RunCallbacks& cb = {}) {
        RunOptions o;
        o.scene_source = j.scene;
        o.threads = threads;
        return run_job(j, o, RunOutputs::in_directory((dir_ / sub).string()), cb);
    }
    Image frame_image(const std::string& sub, int frame) const {
        return read_image((dir_ / sub / "frames" / std::to_string(frame) / "image.exr").string());
    }
    fs::path dir_;
};

TEST_F(Shot, AFrameIsTheSameAloneInARangeAndOnAnyThreadCount) {
    run(job(json{{"start", 10}, {"end", 13}}), "range", 2);
    run(job(json::array({12})), "alone", 1);
    const Image in_range = frame_image("range", 12), alone = frame_image("alone", 12);
    ASSERT_EQ(in_range.rgb.size(), size_t(24 * 18 * 3));
    EXPECT_EQ(in_range.rgb, alone.rgb);
    EXPECT_EQ(in_range.sample_count, alone.sample_count);
}

// A skinned mesh deforms every frame: its tree is built at every 8th frame and refitted between
// (shot_runner.cpp), from the frame number alone, so a frame within a group is the same image
// rendered in a range that built the group's first frame and alone (which builds it first).
TEST_F(Shot, ADeformingFrameIsTheSameAloneAndInItsRange) {
    const auto dir = test::gltf_anim_dir();
    if (!dir) {
        if (test::shared_required()) FAIL() << "the animated glTF samples (../shared/scenes/gltf-anim) are missing";
        GTEST_SKIP() << "the animated glTF samples (../shared/scenes/gltf-anim) are absent";
    }
    auto skinned = [&](const json& frames) {
        RenderJob j = job(frames);
        j.scene = *dir + "/RiggedSimple.gltf";
        return j;
    };
    run(skinned(json{{"start", 6}, {"end", 11}}), "range", 2);
    run(skinned(json::array({11})), "alone", 1);
    run(skinned(json::array({10, 13})), "sparse", 2);
    EXPECT_EQ(frame_image("range", 11).rgb, frame_image("alone", 11).rgb);
    EXPECT_EQ(frame_image("range", 10).rgb, frame_image("sparse", 10).rgb);
    EXPECT_NE(frame_image("range", 10).rgb, frame_image("range", 11).rgb);
    for (const char* run_dir : {"range", "alone"}) {
        const json report = json::parse(std::ifstream(dir_ / run_dir / "frames" / "11" / "report.json"));
        EXPECT_NE(report["scene"]["built"].dump().find("triangle BVH refitted"), std::string::npos) << run_dir << report["scene"]["built"].dump();
    }
    const json at_eight = json::parse(std::ifstream(dir_ / "range" / "frames" / "8" / "report.json"));
    EXPECT_EQ(at_eight["scene"]["built"].dump().find("refitted"), std::string::npos);
}

// With a shutter a frame is blurred (the cube and the camera move within it), reports so, and is
// still the same image alone and in its range; the same frame without one is sharp and differs.
TEST_F(Shot, AShutterBlursAFrameAndKeepsItReproducible) {
    const json shutter = {{"shutter", {{"open", -0.5}, {"close", 0.5}}}};
    const JobOutcome out = run(job(json{{"start", 10}, {"end", 12}}, shutter), "blur_range", 2);
    run(job(json::array({11}), shutter), "blur_alone", 1);
    run(job(json::array({11})), "sharp", 2);
    const Image in_range = frame_image("blur_range", 11), alone = frame_image("blur_alone", 11), sharp = frame_image("sharp", 11);
    EXPECT_EQ(in_range.rgb, alone.rgb);
    EXPECT_NE(in_range.rgb, sharp.rgb);
    const json report = json::parse(std::ifstream(dir_ / "blur_range" / "frames" / "11" / "report.json"));
    EXPECT_NE(report.dump().find("motion blur within the shutter"), std::string::npos) << report.dump();
    EXPECT_FALSE(out.stopped);
}

// Frame n and n + 1 of a scene where nothing moves differ (their seeds differ, so their noise
// is not the same), yet show the same picture (equal means within the noise); the same frame
// of another job with the same seed is identical.
TEST_F(Shot, NeighbouringFramesAreDecorrelated) {
    RenderJob j = job(json::array({0, 1}), {{"spp", 8}});
    j.scene = "builtin:cornell_box";
    run(j, "a");
    run(j, "b");
    const Image f0 = frame_image("a", 0), f1 = frame_image("a", 1);
    EXPECT_NE(f0.rgb, f1.rgb);
    EXPECT_EQ(frame_image("b", 1).rgb, f1.rgb);
    double m0 = 0, m1 = 0;
    size_t differ = 0;
    for (size_t i = 0; i < f0.rgb.size(); ++i) {
        m0 += f0.rgb[i];
        m1 += f1.rgb[i];
        differ += f0.rgb[i] != f1.rgb[i];
    }
    EXPECT_GT(differ, f0.rgb.size() / 2);  // decorrelated almost everywhere, not in a few pixels
    EXPECT_NEAR(m0 / m1, 1.0, 0.05);
    const json r1 = json::parse(std::ifstream(dir_ / "a" / "frames" / "1" / "report.json"));
    EXPECT_EQ(r1["settings"]["seed"], frame_seed(0, 1));
}

TEST_F(Shot, ResultsContactSheetAndReport) {
    std::mutex m;
    std::vector<FrameDone> done;
    uint64_t last_samples = 0;
    RunCallbacks cb;
    cb.frame = [&](const FrameDone& f) {
        std::lock_guard<std::mutex> lock(m);
        done.push_back(f);
    };
    cb.progress = [&](const RenderProgress& p) {
        std::lock_guard<std::mutex> lock(m);
        last_samples = std::max(last_samples, p.samples_done);
    };
    const JobOutcome out = run(job(json{{"start", 0}, {"end", 48}, {"step", 24}}, {{"animation", "Cube"}}), "s", 2, cb);
    ASSERT_EQ(done.size(), 3u);
    for (size_t i = 0; i < 3; ++i) {
        EXPECT_EQ(done[i].index, i);
        EXPECT_EQ(done[i].frame, int(24 * i));
        for (const char* f : {"image.png", "image.exr", "report.json"})
            EXPECT_TRUE(fs::exists(dir_ / "s" / "frames" / std::to_string(24 * i) / f)) << f;
    }
    // Progress counts the samples of every frame, not the current frame's alone.
    EXPECT_EQ(last_samples, uint64_t(3) * 24 * 18 * 3);
    const Image sheet = read_image((dir_ / "s" / "contact_sheet.png").string());
    EXPECT_EQ(sheet.width, 2 * 24);  // ceil(sqrt(3)) columns of full-size thumbnails
    EXPECT_EQ(sheet.height, 2 * 18);
    const json report = json::parse(std::ifstream(dir_ / "s" / "report.json"));
    EXPECT_EQ(report["shot"]["frames"].size(), 3u);
    EXPECT_EQ(report["shot"]["frames"][1]["frame"], 24);
    EXPECT_DOUBLE_EQ(report["shot"]["frames"][2]["time_s"].get<double>(), 2.0);
    EXPECT_EQ(report["shot"]["animations"].size(), 2u);
    EXPECT_EQ(out.summary["shot"]["frames_done"], 3);
    EXPECT_FALSE(fs::exists(dir_ / "s" / "image.exr"));  // a shot's images are per frame
}

// The job's input, not a scene that failed to read: InvalidJob, which no queue runs again.
TEST_F(Shot, AnUnknownAnimationFailsNamingTheFilesAnimations) {
    for (const json& which : {json("Jump"), json(2)}) {
        try {
            run(job(json::array({0}), {{"animation", which}}), "x");
            ADD_FAILURE() << "no InvalidJob for " << which;
        } catch (const InvalidJob& e) {
            EXPECT_EQ(e.pointer(), "/animation");
            EXPECT_NE(std::string(e.what()).find("'Cube', 'Dolly'"), std::string::npos) << e.what();
        }
    }
}

// An animation the file cannot play (a channel on a path Tessera does not animate) fails the
// job as its input does: the file was read whole, so no run of it would do better.
TEST_F(Shot, AnAnimationTheFileCannotPlayFailsAsTheJobsInput) {
    const fs::path file = dir_ / "pointer.gltf";
    fs::create_directories(dir_);
    std::ofstream(file) << test::gltf::triangle_file(R"([{"mesh":0}])", R"("animations":[{"name":"odd",
        "channels":[{"sampler":0,"target":{"node":0,"path":"pointer"}}],"samplers":[{"input":0,"output":0}]}])");
    RenderJob j = job(json::array({0}));
    j.scene = file.string();
    try {
        run(j, "pointer");
        ADD_FAILURE() << "no InvalidJob";
    } catch (const InvalidJob& e) {
        EXPECT_NE(std::string(e.what()).find("cannot be played"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("'pointer'"), std::string::npos) << e.what();
    }
}

// A shot of a scene with no animation renders (every frame at rest, each with its own noise)
// and says so; naming an animation of such a scene is an error.
TEST_F(Shot, AStillSceneRendersAtRestAndSaysSo) {
    RenderJob j = job(json::array({1, 2}));
    j.scene = "builtin:cornell_box";
    run(j, "still");
    const json report = json::parse(std::ifstream(dir_ / "still" / "report.json"));
    ASSERT_TRUE(report["shot"].contains("warnings"));
    EXPECT_NE(report["shot"]["warnings"][0].get<std::string>().find("no animation"), std::string::npos);
    j.animation = "Walk";
    EXPECT_THROW(run(j, "still2"), InvalidJob);
}

TEST_F(Shot, AStopEndsTheShotWritingNoReport) {
    std::atomic<bool> stop{false};
    RunCallbacks cb;
    cb.stop = &stop;
    cb.frame = [&](const FrameDone&) { stop = true; };  // after the first frame
    const JobOutcome out = run(job(json{{"start", 0}, {"end", 5}}), "stopped", 2, cb);
    EXPECT_TRUE(out.stopped);
    EXPECT_TRUE(fs::exists(dir_ / "stopped" / "frames" / "0" / "image.exr"));
    EXPECT_FALSE(fs::exists(dir_ / "stopped" / "frames" / "1"));
    EXPECT_FALSE(fs::exists(dir_ / "stopped" / "report.json"));
}

// The preview holds every frame at the shot's rate (counted by ffprobe). CI sets
// TESSERA_REQUIRE_FFMPEG=1: there a missing ffmpeg fails instead of skipping.
TEST_F(Shot, ThePreviewHoldsEveryFrame) {
    if (find_ffmpeg().empty()) {
        const char* req = std::getenv("TESSERA_REQUIRE_FFMPEG");
        if (req && std::string(req) == "1") FAIL() << "ffmpeg is not installed (scripts/setup.sh installs it)";
        GTEST_SKIP() << "ffmpeg is not installed";
    }
    run(job(json{{"start", 0}, {"end", 4}}, {{"fps", 10}}), "p");
    const fs::path mp4 = dir_ / "p" / "preview.mp4";
    ASSERT_TRUE(fs::exists(mp4));
    std::ifstream in(mp4, std::ios::binary);
    char head[8] = {};
    in.read(head, 8);
    EXPECT_EQ(std::string(head + 4, 4), "ftyp");
    const std::string probe = "ffprobe -v error -count_frames -select_streams v:0 -show_entries stream=nb_read_frames,avg_frame_rate "
                              "-of csv=p=0 '" + mp4.string() + "'";
    FILE* p = ::popen(probe.c_str(), "r");
    ASSERT_TRUE(p);
    char line[128] = {};
    const bool read = std::fgets(line, sizeof line, p) != nullptr;
    ::pclose(p);
    ASSERT_TRUE(read);
    EXPECT_EQ(std::string(line).substr(0, std::string(line).find_last_not_of("\n") + 1), "10/1,5");
    const json report = json::parse(std::ifstream(dir_ / "p" / "report.json"));
    EXPECT_EQ(report["shot"]["preview"]["written"], true);
    EXPECT_FALSE(fs::exists(dir_ / "p" / ".preview_frames"));  // the links are gone
}

// Without a working ffmpeg the shot succeeds and its report says why it has no preview.
TEST_F(Shot, AFailingEncoderLeavesAReasonNotAFailure) {
    ::setenv("TESSERA_FFMPEG", "/bin/false", 1);
    run(job(json::array({0, 1})), "f");
    ::setenv("TESSERA_FFMPEG", "/nonexistent/ffmpeg", 1);
    run(job(json::array({0, 1})), "g");
    ::unsetenv("TESSERA_FFMPEG");
    const json failed = json::parse(std::ifstream(dir_ / "f" / "report.json"));
    EXPECT_EQ(failed["shot"]["preview"]["written"], false);
    EXPECT_NE(failed["shot"]["preview"]["why_not"].get<std::string>().find("ffmpeg failed"), std::string::npos);
    const json absent = json::parse(std::ifstream(dir_ / "g" / "report.json"));
    EXPECT_NE(absent["shot"]["preview"]["why_not"].get<std::string>().find("not installed"), std::string::npos);
    EXPECT_FALSE(fs::exists(dir_ / "f" / "preview.mp4"));
    EXPECT_TRUE(fs::exists(dir_ / "f" / "frames" / "1" / "image.exr"));
}

TEST(FramePath, HashesBecomeThePaddedFrameNumber) {
    EXPECT_EQ(frame_path("out_####.exr", 7), "out_0007.exr");
    EXPECT_EQ(frame_path("out_##.png", 12345), "out_12345.png");
    EXPECT_EQ(frame_path("dir/f#.exr", 3), "dir/f3.exr");
    EXPECT_EQ(frame_path("out_####.exr", -7), "out_-0007.exr");
    EXPECT_EQ(frame_path("shot.png", 9), "shot_9.png");
    EXPECT_EQ(frame_path("a/b/shot.exr", 10), "a/b/shot_10.exr");
}

}  // namespace
}  // namespace tessera::api
