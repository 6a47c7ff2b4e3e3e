// The job runner: the one path from a typed job to its files, shared by the CLI and the server.
#include "api/job_runner.h"

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "engine/io/scene_loader.h"
#include "tests/scratch_dir.h"

namespace tessera::api {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

class Runner : public ::testing::Test {
protected:
    void SetUp() override { dir_ = test::scratch_dir("tessera_runner"); }
    void TearDown() override { test::remove_scratch_dir(dir_); }
    static RenderJob small_job() {
        return parse_render_job(json{{"scene", "builtin:cornell_box"}, {"width", 32}, {"height", 24}, {"spp", 4}, {"max_depth", 3}});
    }
    static RunOptions options_for(const RenderJob& job, int threads = 2) {
        RunOptions o;
        o.scene_source = job.scene;
        o.threads = threads;
        o.job_id = "0123456789abcdef";
        return o;
    }
    fs::path dir_;
};

bool same_pixels(const Image& a, const Image& b) {
    return a.width == b.width && a.height == b.height && a.rgb.size() == b.rgb.size() &&
           std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)) == 0;
}

// The runner adds nothing to the image: it is the engine's render of the same settings, bit
// for bit, and every result file and the report are there.
TEST_F(Runner, WritesTheEnginesImageAndEveryResult) {
    const RenderJob job = small_job();
    const JobOutcome out = run_job(job, options_for(job), RunOutputs::in_directory(dir_.string()));
    ASSERT_FALSE(out.stopped);
    for (const char* f : {"image.png", "image.exr", "rate.png", "convergence.csv", "convergence.svg", "report.json"})
        EXPECT_TRUE(fs::exists(dir_ / f)) << f;

    RenderSettings settings = job.render;
    settings.threads = 1;
    settings.estimate_error = true;
    const RenderResult direct = render(build_render_scene(load_scene(job.scene), job.scene_options), settings);
    EXPECT_TRUE(same_pixels(read_image((dir_ / "image.exr").string()), direct.image));

    std::ifstream in(dir_ / "report.json");
    const json report = json::parse(in);
    EXPECT_EQ(report["settings"], to_json(job));
    EXPECT_EQ(report["stats"]["rays_camera"], direct.stats.camera_rays);
    EXPECT_EQ(report["convergence"]["points"].size(), direct.curve.points.size());
    EXPECT_EQ(out.summary["progress"]["fraction"], 1.0);
    ASSERT_TRUE(out.render);
    EXPECT_EQ(out.render->stats.samples, 4u * 32 * 24);
}

TEST_F(Runner, SameImageWhateverTheThreadCount) {
    const RenderJob job = small_job();
    RunOutputs one, two;
    one.exr = (dir_ / "one.exr").string();
    two.exr = (dir_ / "two.exr").string();
    run_job(job, options_for(job, 1), one);
    run_job(job, options_for(job, 2), two);
    EXPECT_TRUE(same_pixels(read_image(one.exr), read_image(two.exr)));
}

// A stop writes no result, only the checkpoint the job continues from.
TEST_F(Runner, AStopWritesNothingButItsCheckpoint) {
    const RenderJob job = small_job();
    std::atomic<bool> stop{true};
    RunCallbacks cb;
    cb.stop = &stop;
    const RunOutputs out = RunOutputs::in_directory(dir_.string());
    const JobOutcome outcome = run_job(job, options_for(job), out, cb);
    EXPECT_TRUE(outcome.stopped);
    std::vector<std::string> files;
    for (const auto& e : fs::directory_iterator(dir_)) files.push_back(e.path().filename().string());
    EXPECT_EQ(files, std::vector<std::string>{"checkpoint.tck"});
}

// A canceled job's stop writes nothing at all: its film is thrown away, and writing it would only
// hold up the cancel.
TEST_F(Runner, ACanceledStopWritesNotEvenItsCheckpoint) {
    const RenderJob job = small_job();
    std::atomic<bool> stop{true}, cancel{true};
    RunCallbacks cb;
    cb.stop = &stop;
    cb.discard = &cancel;
    const RunOutputs out = RunOutputs::in_directory(dir_.string());
    EXPECT_TRUE(run_job(job, options_for(job), out, cb).stopped);
    EXPECT_TRUE(fs::is_empty(dir_)) << "a checkpoint or a result was written";
}

// Stopped mid-render and run again: the job continues from its checkpoint, ends with the image
// of a job never stopped, says what it recovered, and leaves no checkpoint behind.
TEST_F(Runner, AStoppedJobRunAgainContinuesToTheSameImage) {
    RenderJob job = small_job();
    job.render.spp = 64;
    job.render.tile_size = 8;  // a pass of 12 tiles: stopped between them
    const RunOutputs whole = RunOutputs::in_directory((dir_ / "whole").string());
    const RunOutputs resumed = RunOutputs::in_directory((dir_ / "resumed").string());
    fs::create_directories(whole.directory);
    fs::create_directories(resumed.directory);
    RunCallbacks pass_cb;
    pass_cb.pass = [](const PassSnapshot&) {};  // progressive, as a server runs it
    run_job(job, options_for(job, 2), whole, pass_cb);
    std::atomic<bool> stop{false};
    RunCallbacks cb = pass_cb;
    cb.stop = &stop;
    cb.progress = [&](const RenderProgress& p) {
        if (p.samples_done > 1000) stop = true;
    };
    ASSERT_TRUE(run_job(job, options_for(job, 2), resumed, cb).stopped);
    ASSERT_TRUE(fs::exists(resumed.checkpoint));
    const JobOutcome again = run_job(job, options_for(job, 2), resumed, pass_cb);
    ASSERT_TRUE(again.render);
    EXPECT_GT(again.render->recovered_samples, 1000u);
    EXPECT_TRUE(again.summary.contains("recovered"));
    EXPECT_TRUE(same_pixels(read_image(whole.exr), read_image(resumed.exr)));
    EXPECT_FALSE(fs::exists(resumed.checkpoint));
}

// Real faults, not mocks: a folder that does not exist, a scene file that does not.
TEST_F(Runner, AnUnwritableResultFailsNamingTheFile) {
    const RenderJob job = small_job();
    RunOutputs out;
    out.png = (dir_ / "no_such_folder" / "image.png").string();
    try {
        run_job(job, options_for(job), out);
        FAIL() << "the write did not fail";
    } catch (const std::exception& e) {
        EXPECT_NE(std::string(e.what()).find("no_such_folder/image.png"), std::string::npos) << e.what();
        EXPECT_EQ(std::string(e.what()).rfind("cannot write results: ", 0), 0u) << e.what();
    }
    RunOutputs report_only;
    report_only.report_json = (dir_ / "no_such_folder" / "report.json").string();
    EXPECT_THROW(run_job(job, options_for(job), report_only), std::runtime_error);
}

// A server's job folder removed while the job renders (someone freeing space by hand): the
// results are written to the folder made again, not lost to an error.
TEST_F(Runner, AJobFolderRemovedWhileRenderingIsMadeAgain) {
    const RenderJob job = small_job();
    const fs::path folder = dir_ / "jobs" / "0123456789abcdef";
    fs::create_directories(folder);
    std::atomic<bool> removed{false};
    RunCallbacks cb;
    cb.progress = [&](const RenderProgress&) {
        if (!removed.exchange(true)) fs::remove_all(dir_ / "jobs");
    };
    const JobOutcome out = run_job(job, options_for(job), RunOutputs::in_directory(folder.string()), cb);
    ASSERT_TRUE(removed.load());
    ASSERT_FALSE(out.stopped);
    for (const char* f : {"image.png", "image.exr", "rate.png", "report.json"}) EXPECT_TRUE(fs::exists(folder / f)) << f;
}

TEST_F(Runner, AMissingSceneIsASceneError) {
    RenderJob job = small_job();
    RunOptions o = options_for(job);
    o.scene_source = (dir_ / "gone.gltf").string();
    EXPECT_THROW(run_job(job, o, RunOutputs::in_directory(dir_.string())), SceneError);
    EXPECT_FALSE(fs::exists(dir_ / "image.png"));
}

TEST_F(Runner, ComparisonReportsEveryConfiguration) {
    const ComparisonJob job = parse_comparison_job(json::parse(R"({"scene":"builtin:cornell_box","width":16,"height":12,
        "seconds":0.05,"reps":1,"reference_spp":4,"max_depth":2,
        "configs":[{"label":"light","light_rays":2},{"label":"MIS","direct":"mis","max_depth":2}]})"));
    RunOptions o;
    o.scene_source = job.scene;
    o.threads = 2;
    const JobOutcome out = run_job(job, o, RunOutputs::in_directory(dir_.string()));
    ASSERT_FALSE(out.stopped);
    const json rows = out.report["comparison"]["rows"];
    ASSERT_EQ(rows.size(), 2u);
    EXPECT_EQ(rows[0]["label"], "light");
    EXPECT_EQ(rows[1]["label"], "MIS");
    EXPECT_EQ(out.report["settings"], to_json(job));
    EXPECT_TRUE(fs::exists(dir_ / "convergence.svg"));
    EXPECT_TRUE(out.summary.contains("comparison"));
}

}  // namespace
}  // namespace tessera::api
