// The render farm's nodes against a real redis-server (Debian's, on a random loopback port in a
// directory of the test's own): an API node's FarmQueue and two RenderNodes of one thread each,
// in this process, render jobs of every kind of pass schedule; each image must equal, bit for
// bit, the one the same job gives in one process (api::run_job, as `tessera render` and the
// server's workers run it), and the counters summed over the farm's tiles must equal one
// process's.
#include "build_paths.h"
#include "server/farm/render_node.h"

#include <algorithm>
#include <gtest/gtest.h>

#include <map>
#include <sstream>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <thread>

#include "api/job.h"
#include "api/job_fields.h"
#include "api/job_runner.h"
#include "engine/io/image_io.h"
#include "server/store/job_results.h"
#include "server/farm/farm_queue.h"
#include "server/store/cluster_keys.h"
#include "tests/server/redis_suite.h"
#include "tests/test_scale.h"

namespace tessera::server {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

class RenderNodeFarm : public test::WithSuiteRedis<> {
protected:
    void SetUp() override {
        if (!redis_ready("the render farm is not tested")) return;
        dir_ = fs::temp_directory_path() / ("tessera_render_node_" + std::to_string(::getpid()));
        fs::remove_all(dir_);
        fs::create_directories(dir_ / "scenes");
        // The Cornell box with its lamp off: lit by the default sky on both sides.
        std::ifstream in(fs::path(TESSERA_PROJECT_SCENES) / "cornell_box.gltf");
        std::string box((std::istreambuf_iterator<char>(in)), {});
        const std::string lamp = "\"emissiveStrength\": 10.0";
        ASSERT_NE(box.find(lamp), std::string::npos) << "the lamp of scenes/cornell_box.gltf";
        box.replace(box.find(lamp), lamp.size(), "\"emissiveStrength\": 0.0");
        std::ofstream(dir_ / "scenes" / "dark_box.gltf") << box;
        // A scene the catalog lists and no node can load: a job on it fails on the nodes.
        std::ofstream(dir_ / "scenes" / "broken_box.gltf") << "{\"asset\": {\"version\": \"2.0\"}, \"scenes\": [{\"nodes\": [7]}]}";
        ServiceConfig cfg;
        cfg.data_dir = (dir_ / "data").string();
        cfg.project_scenes = TESSERA_PROJECT_SCENES;
        cfg.scene_dirs = {(dir_ / "scenes").string()};
        cfg.redis_url = "redis://127.0.0.1:" + std::to_string(redis_->port());
        service_ = std::make_unique<FarmQueue>(cfg);
        for (int i = 0; i < 2; ++i) {
            NodeConfig nc;
            nc.redis = redis_->url();
            nc.data_dir = cfg.data_dir;
            nc.name = "test-node-" + std::to_string(i + 1);
            nc.threads = 1;
            nodes_.push_back(std::make_unique<RenderNode>(nc));
            nodes_.back()->start();
        }
        // A node takes tasks before its first heartbeat is in Redis; a task it fails goes to
        // another node only if that one is live by then. Tests about who ran what start once
        // both are.
        wait_registered({"test-node-1", "test-node-2"});
    }
    void wait_registered(const std::vector<std::string>& names) {
        Redis r(redis_->url());
        const auto t0 = std::chrono::steady_clock::now();
        for (;;) {
            size_t seen = 0;
            for (const std::string& n : names) seen += r.command({"HEXISTS", keys::nodes, n}).as_int() == 1;
            if (seen == names.size()) return;
            ASSERT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(30)) << "the render nodes never sent a heartbeat";
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
    }
    void TearDown() override {
        for (auto& n : nodes_) n->stop();
        nodes_.clear();
        if (service_) service_->shutdown();
        service_.reset();
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }

    // Submits `body` to the farm and waits for it; returns its id.
    std::string run_on_farm(const json& body) {
        const std::string id = service_->submit(body).id;
        const auto t0 = std::chrono::steady_clock::now();
        for (;;) {
            const api::JobStatus s = service_->status(id);
            if (s.state == api::JobState::succeeded) return id;
            if (api::is_final(s.state)) {
                ADD_FAILURE() << "farm job " << api::to_json(s).dump();
                return id;
            }
            if (std::chrono::steady_clock::now() - t0 > std::chrono::seconds(120)) {
                ADD_FAILURE() << "farm job did not finish in 120 s: " << api::to_json(s).dump();
                return id;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
    }

    // The same job in one process, as `tessera render` runs it.
    fs::path run_in_one_process(const json& body, const std::string& scene_file, const std::string& name) {
        const api::RenderJob job = api::parse_render_job(body, api::JobLimits::none());
        api::RunOptions opt;
        opt.scene_source = scene_file;
        opt.threads = 2;
        const fs::path out = dir_ / name;
        api::run_job(job, opt, api::RunOutputs::in_directory(out.string()));
        return out;
    }

    // A render node of the test's own, beside (or instead of) the fixture's two.
    RenderNode& add_node(const std::string& name, std::vector<std::string> tags = {}, uint64_t max_triangles = 0, int visibility_ms = 10000) {
        NodeConfig nc;
        nc.visibility_ms = visibility_ms;
        nc.redis = redis_->url();
        nc.data_dir = (dir_ / "data").string();
        nc.name = name;
        nc.threads = 1;
        nc.tags = std::move(tags);
        if (max_triangles) nc.load_limits.max_triangles = max_triangles;
        nodes_.push_back(std::make_unique<RenderNode>(nc));
        nodes_.back()->start();
        wait_registered({name});
        return *nodes_.back();
    }
    // Stops the fixture's nodes and forgets their heartbeats: they are not live any more.
    void without_fixture_nodes() {
        for (int i = 0; i < 2; ++i) nodes_[size_t(i)]->stop();
        Redis(redis_->url()).command({"HDEL", keys::nodes, "test-node-1", "test-node-2"});
    }
    api::JobStatus wait_final(const std::string& id, int seconds = 120) {
        const auto t0 = std::chrono::steady_clock::now();
        api::JobStatus s = service_->status(id);
        while (!api::is_final(s.state) && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(seconds)) {
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
            s = service_->status(id);
        }
        return s;
    }

    fs::path dir_;
    std::unique_ptr<FarmQueue> service_;
    std::vector<std::unique_ptr<RenderNode>> nodes_;
};

struct Case {
    const char* what;
    json body;
    const char* scene_file;  // under scenes/ or the test's own folder
};

TEST_F(RenderNodeFarm, EveryPassScheduleGivesOneProcessImageBitForBit) {
    const std::string project = TESSERA_PROJECT_SCENES;
    const std::string own = (dir_ / "scenes").string();
    const std::vector<Case> cases = {
        // No stop rule needs the whole image: whole tiles, through every target in one task.
        {"whole tiles", {{"scene", "cornell_spheres"}, {"width", 48}, {"height", 36}, {"spp", 8}, {"max_depth", 3}, {"tile_size", 16}},
         "cornell_spheres.gltf"},
        // Adaptive sampling: pass by pass, each pass's film assembled and carried on.
        {"adaptive", {{"scene", "cornell_spheres"}, {"width", 40}, {"height", 30}, {"spp", 16}, {"max_depth", 3}, {"tile_size", 16},
                      {"adaptive", {{"batch", 4}, {"tolerance", 0.05}}}},
         "cornell_spheres.gltf"},
        // A target error never reached: pass by pass to the last target.
        {"target error", {{"scene", "cornell_box"}, {"width", 36}, {"height", 28}, {"spp", 8}, {"max_depth", 2}, {"tile_size", 12},
                          {"target_error", 1e-12}},
         "cornell_box.gltf"},
        // No lights: the default sky on the nodes as in one process.
        {"no lights", {{"scene", "dark_box"}, {"width", 32}, {"height", 24}, {"spp", 4}, {"max_depth", 2}, {"tile_size", 16}},
         "dark_box.gltf"},
        // Passes on whole tiles: the tiles ship films, not pixels.
        {"passes", {{"scene", "cornell_spheres"}, {"width", 40}, {"height", 30}, {"spp", 8}, {"max_depth", 3}, {"tile_size", 16},
                    {"passes", {"albedo", "depth", "object_id", "emission", "diffuse_direct", "glossy_indirect", "variance", "crypto_object", "crypto_material"}}},
         "cornell_spheres.gltf"},
        // Denoised after every pass from 4 spp on, from the assembled film; past 8 spp the passes are guided
        // (their per-pixel targets travel beside the tiles' films).
        {"denoise", {{"scene", "cornell_box"}, {"width", 40}, {"height", 30}, {"spp", 32}, {"max_depth", 3}, {"tile_size", 16},
                     {"denoise", true}, {"passes", {"normal"}}},
         "cornell_box.gltf"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.what);
        const std::string id = run_on_farm(c.body);
        const fs::path farm = job_results_dir((dir_ / "data").string(), id);
        const std::string file = (fs::exists(fs::path(own) / c.scene_file) ? fs::path(own) : fs::path(project)) / c.scene_file;
        const fs::path one = run_in_one_process(c.body, file, std::string("one-") + c.what);
        const Image a = read_image((farm / "image.exr").string()), b = read_image((one / "image.exr").string());
        ASSERT_EQ(a.rgb.size(), b.rgb.size());
        EXPECT_EQ(0, std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float))) << "pixels";
        EXPECT_EQ(a.sample_count, b.sample_count) << "sample counts";
        if (c.body.contains("passes")) {
            const ChannelImage la = read_channels((farm / "passes.exr").string()), lb = read_channels((one / "passes.exr").string());
            EXPECT_EQ(la.names, lb.names);
            ASSERT_EQ(la.data.size(), lb.data.size());
            EXPECT_EQ(0, std::memcmp(la.data.data(), lb.data.data(), la.data.size() * sizeof(float))) << "every pass, bit for bit";
            for (const auto& name : c.body["passes"]) {
                const std::string f = "passes/" + name.get<std::string>() + ".exr";
                const ChannelImage pa = read_channels((farm / f).string()), pb = read_channels((one / f).string());
                EXPECT_EQ(pa.names, pb.names) << f;
                EXPECT_EQ(pa.data, pb.data) << f;
            }
        }
        if (c.body.contains("denoise")) {
            const Image da = read_image((farm / "denoised.exr").string()), db = read_image((one / "denoised.exr").string());
            ASSERT_EQ(da.rgb.size(), db.rgb.size());
            EXPECT_EQ(0, std::memcmp(da.rgb.data(), db.rgb.data(), da.rgb.size() * sizeof(float))) << "denoised pixels";
            const auto [fewest, most] = std::minmax_element(a.sample_count.begin(), a.sample_count.end());
            EXPECT_LT(*fewest, *most) << "guided sampling gave some pixels more samples than others";
        }
        const json fr = json::parse(std::ifstream(farm / "report.json")), orep = json::parse(std::ifstream(one / "report.json"));
        for (const char* k : {"rays_camera", "rays_shadow", "rays_bounce", "nonfinite_samples", "spp_mean", "max_sample_luminance"})
            EXPECT_EQ(fr["stats"][k], orep["stats"][k]) << k;
        EXPECT_EQ(fr["convergence"]["stop_reason"], orep["convergence"]["stop_reason"]);
        EXPECT_EQ(fr["convergence"]["points"].size(), orep["convergence"]["points"].size());
        EXPECT_EQ(fr["scene"]["built"], orep["scene"]["built"]) << "the same light (the default sky where there is none)";
        EXPECT_EQ(fr["nodes"].size() >= 1, true) << "the farm's report names its nodes";
        // Its log: the start, every tile of every pass and each assembly, by named nodes; the
        // start with the line its node logged.
        std::istringstream log(service_->job_log(id, 0, 10000).ndjson);
        std::map<std::string, int> tasks;
        bool start_line = false;
        for (std::string line; std::getline(log, line);) {
            const json t = json::parse(line);
            if (t["outcome"] != "done") continue;
            ++tasks[t["task"].get<std::string>()];
            EXPECT_EQ(t["node"].get<std::string>().rfind("test-node-", 0), 0u) << line;
            if (t["task"] == "start")
                for (const auto& l : t["lines"]) start_line = start_line || l.get<std::string>().find("tiles per pass") != std::string::npos;
        }
        EXPECT_EQ(tasks["start"], 1);
        EXPECT_GE(tasks["tile"], 1);
        EXPECT_EQ(tasks["assemble"] >= 1, true);
        EXPECT_TRUE(start_line) << "the node's own line in its task";
    }
}

// Paused on the farm (at once, while queued or starting; mid-pass; twice) and resumed: its nodes
// drop its tasks, its film stays in Redis, and resumed it ends with one process's image bit for
// bit. Pass by pass (a target error never reached) and in whole tiles.
TEST_F(RenderNodeFarm, APausedJobResumedGivesOneProcessImageBitForBit) {
    const std::vector<Case> cases = {
        {"pass by pass", {{"scene", "cornell_spheres"}, {"width", 64}, {"height", 48}, {"spp", 128}, {"max_depth", 3}, {"tile_size", 16},
                          {"target_error", 1e-12}, {"denoise", true}},
         "cornell_spheres.gltf"},
        {"whole tiles", {{"scene", "cornell_spheres"}, {"width", 64}, {"height", 48}, {"spp", 128}, {"max_depth", 3}, {"tile_size", 16}},
         "cornell_spheres.gltf"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.what);
        const std::string id = service_->submit(c.body).id;
        int paused = 0;
        auto pause_resume = [&](uint64_t after_samples) {
            for (int i = 0; i < 2000 && service_->status(id).live_progress.value_or(api::JobProgress{}).samples_done < after_samples; ++i)
                std::this_thread::sleep_for(std::chrono::milliseconds(2));
            const api::JobStatus p = service_->pause(id);
            if (api::is_final(p.state)) return;  // finished first: nothing to pause
            EXPECT_EQ(p.state, api::JobState::paused);
            ++paused;
            std::this_thread::sleep_for(std::chrono::milliseconds(400));  // the nodes drop what they held
            EXPECT_EQ(service_->status(id).state, api::JobState::paused);
            EXPECT_EQ(service_->pause(id).state, api::JobState::paused) << "idempotent";
            const api::JobStatus r = service_->resume(id);
            EXPECT_NE(r.state, api::JobState::paused);
        };
        pause_resume(0);
        pause_resume(64 * 48 * 6);
        pause_resume(64 * 48 * 40);
        EXPECT_GE(paused, 2) << "paused before it finished";
        const auto t0 = std::chrono::steady_clock::now();
        api::JobStatus s = service_->status(id);
        while (!api::is_final(s.state) && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(120)) {
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
            s = service_->status(id);
        }
        ASSERT_EQ(s.state, api::JobState::succeeded) << api::to_json(s).dump();
        const fs::path farm = job_results_dir((dir_ / "data").string(), id);
        const fs::path one = run_in_one_process(c.body, std::string(TESSERA_PROJECT_SCENES) + "/" + c.scene_file, std::string("paused-") + c.what);
        const Image a = read_image((farm / "image.exr").string()), b = read_image((one / "image.exr").string());
        ASSERT_EQ(a.rgb.size(), b.rgb.size());
        EXPECT_EQ(0, std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float))) << "pixels";
        EXPECT_EQ(a.sample_count, b.sample_count);
        if (c.body.contains("denoise")) {
            const Image da = read_image((farm / "denoised.exr").string()), db = read_image((one / "denoised.exr").string());
            EXPECT_EQ(0, std::memcmp(da.rgb.data(), db.rgb.data(), da.rgb.size() * sizeof(float))) << "denoised pixels";
        }
    }
}

// A shot paused on the farm stops between frames or inside one (its frame's checkpoint kept in
// the shared folder), and resumed it plans the frames not yet written afresh: every frame equals
// one process's, bit for bit. A comparison paused runs again whole when resumed.
TEST_F(RenderNodeFarm, APausedShotOrComparisonResumesOnTheFarm) {
    // Nodes that see a pause within 250 ms (a quarter of their visibility timeout): inside a frame.
    without_fixture_nodes();
    add_node("quick-1", {}, 0, 1000);
    add_node("quick-2", {}, 0, 1000);
    // A sanitizer build renders about ten times slower: a quarter of the pixels there.
    const int w = tessera::test::kWorkScale > 1 ? 48 : 96, h = tessera::test::kWorkScale > 1 ? 36 : 72;
    const json body = {{"scene", "cornell_shot"}, {"width", w}, {"height", h}, {"spp", 256}, {"max_depth", 3},
                       {"frames", {{"start", 0}, {"end", 48}, {"step", 8}}}, {"chunk", 1}};
    const std::string id = service_->submit(body).id;
    const fs::path farm = job_results_dir((dir_ / "data").string(), id);
    using Clock = std::chrono::steady_clock;
    auto frames_done = [&] {
        const api::JobStatus st = service_->status(id);
        return std::make_pair(api::is_final(st.state), st.shot ? st.shot->frames_done : size_t(0));
    };
    // Until `n` frames are written (false: it finished first).
    auto wait_frames = [&](size_t n) {
        for (int i = 0; i < 60000; ++i) {
            const auto [over, done] = frames_done();
            if (over) return false;
            if (done >= n) return true;
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
        return false;
    };
    auto has_checkpoint = [&] {
        std::error_code ec;
        for (fs::recursive_directory_iterator it(farm / "frames", ec), end; !ec && it != end; it.increment(ec))
            if (it->path().filename() == "checkpoint.tck") return true;
        return false;
    };
    int paused = 0;
    bool inside_a_frame = false;
    // Paused and resumed; true when it was paused (not finished first). `look` waits for a
    // checkpoint, which the nodes write when they see the pause (a quarter of their visibility
    // timeout) inside a frame.
    auto pause_resume = [&](bool look) {
        const api::JobStatus p = service_->pause(id);
        if (api::is_final(p.state)) return false;
        EXPECT_EQ(p.state, api::JobState::paused);
        ++paused;
        std::this_thread::sleep_for(std::chrono::milliseconds(1000));
        for (int i = 0; look && i < 100 && !has_checkpoint(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
        inside_a_frame = inside_a_frame || has_checkpoint();
        EXPECT_EQ(service_->status(id).state, api::JobState::paused);
        EXPECT_NE(service_->resume(id).state, api::JobState::paused);
        return true;
    };
    // Between frames: the node that started it has written the first frame and is queuing the rest.
    if (wait_frames(1) && pause_resume(false)) {
        // Inside a frame: half a frame's time after one was written. The nodes start afresh on the
        // resume and render in step, so a frames_done count alone can land between their frames.
        const auto resumed = Clock::now();
        Clock::duration frame{};  // a frame's time, from the resume to the next frame written
        for (int attempt = 0; attempt < 3 && !inside_a_frame; ++attempt) {
            if (!wait_frames(frames_done().second + 1)) break;
            if (attempt == 0) frame = Clock::now() - resumed;
            std::this_thread::sleep_for(frame / 2);
            if (!pause_resume(true)) break;
        }
    }
    EXPECT_GE(paused, 1) << "paused before it finished";
    EXPECT_TRUE(inside_a_frame) << "a pause inside a frame keeps the frame's checkpoint";
    const api::JobStatus s = wait_final(id, 400);  // a shot, paused twice: about a minute under the sanitizers
    ASSERT_EQ(s.state, api::JobState::succeeded) << api::to_json(s).dump();
    const fs::path one = run_in_one_process(body, (fs::path(TESSERA_PROJECT_SCENES) / "cornell_shot.gltf").string(), "one-paused-shot");
    for (int n = 0; n <= 48; n += 8) {
        SCOPED_TRACE(n);
        const std::string f = "frames/" + std::to_string(n) + "/image.exr";
        const Image a = read_image((farm / f).string()), b = read_image((one / f).string());
        ASSERT_EQ(a.rgb.size(), b.rgb.size());
        EXPECT_EQ(0, std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)));
        EXPECT_FALSE(fs::exists(farm / "frames" / std::to_string(n) / "checkpoint.tck")) << "a written frame keeps no checkpoint";
    }
    EXPECT_TRUE(fs::exists(farm / "contact_sheet.png"));

    const json comparison = {{"scene", "cornell_box"}, {"width", 32}, {"height", 24}, {"max_depth", 2},
                             {"seconds", 0.5}, {"reps", 1}, {"reference_spp", 64}};
    const std::string cid = service_->submit_comparison(comparison).id;
    for (int i = 0; i < 5000 && service_->status(cid).state != api::JobState::running; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    const api::JobStatus cp = service_->pause(cid);
    if (!api::is_final(cp.state)) {
        EXPECT_EQ(cp.state, api::JobState::paused);
        std::this_thread::sleep_for(std::chrono::milliseconds(1000));
        EXPECT_EQ(service_->status(cid).state, api::JobState::paused);
        service_->resume(cid);
    }
    EXPECT_EQ(wait_final(cid).state, api::JobState::succeeded);
}

// Jobs that run after others on the farm: a chain runs in order across the nodes; a job that fails
// on a node fails the jobs after it, each naming the job it waited for.
TEST_F(RenderNodeFarm, AChainRunsInOrderAndAFailureFailsTheRest) {
    const json small = {{"scene", "cornell_box"}, {"width", 32}, {"height", 24}, {"spp", 16}, {"max_depth", 2}, {"tile_size", 16}};
    auto after = [&](json j, const std::string& id) {
        j["after"] = json::array({id});
        return j;
    };
    auto wait_final = [&](const std::string& id) {
        const auto t0 = std::chrono::steady_clock::now();
        api::JobStatus s = service_->status(id);
        while (!api::is_final(s.state) && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(60)) {
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
            s = service_->status(id);
        }
        return s;
    };
    const std::string a = service_->submit(small).id;
    const std::string b = service_->submit(after(small, a)).id;
    const std::string c = service_->submit(after(small, b)).id;
    json bad = small;
    bad["scene"] = "broken_box";
    const std::string d = service_->submit(bad).id;
    const std::string e = service_->submit(after(small, d)).id;
    const std::string f = service_->submit(after(small, e)).id;
    const api::JobStatus sa = wait_final(a), sb = wait_final(b), sc = wait_final(c);
    ASSERT_EQ(sc.state, api::JobState::succeeded) << api::to_json(sc).dump();
    EXPECT_GE(sb.started_at, sa.finished_at);
    EXPECT_GE(sc.started_at, sb.finished_at);
    EXPECT_EQ(wait_final(d).state, api::JobState::failed);
    const api::JobStatus se = wait_final(e), sf = wait_final(f);
    EXPECT_EQ(se.state, api::JobState::failed);
    EXPECT_NE(se.error.find("job " + d + ", which it runs after, failed"), std::string::npos) << se.error;
    EXPECT_EQ(sf.state, api::JobState::failed);
    EXPECT_NE(sf.error.find("job " + e), std::string::npos) << sf.error;
}

// A shot on the farm: the node that starts it renders it through the one shot runner into the
// shared results folder, so every frame equals one process's bit for bit; a shot whose first
// frame an earlier run already wrote (a node that died) keeps it and renders the rest.
TEST_F(RenderNodeFarm, AShotGivesOneProcessFramesBitForBitAndResumes) {
    const json body = {{"scene", "cornell_shot"}, {"width", 32}, {"height", 24}, {"spp", 2}, {"max_depth", 2},
                       {"frames", {{"start", 0}, {"end", 48}, {"step", 24}}}};
    const std::string id = run_on_farm(body);
    const fs::path farm = job_results_dir((dir_ / "data").string(), id);
    const fs::path one = run_in_one_process(body, (fs::path(TESSERA_PROJECT_SCENES) / "cornell_shot.gltf").string(), "one-shot");
    for (int n : {0, 24, 48}) {
        SCOPED_TRACE(n);
        const std::string f = "frames/" + std::to_string(n) + "/image.exr";
        const Image a = read_image((farm / f).string()), b = read_image((one / f).string());
        ASSERT_EQ(a.rgb.size(), b.rgb.size());
        EXPECT_EQ(0, std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)));
    }
    EXPECT_TRUE(fs::exists(farm / "contact_sheet.png"));
    const json status = api::to_json(service_->status(id));
    EXPECT_EQ(status["shot"]["frames_done"], 3) << status.dump();
    EXPECT_EQ(nodes_[0]->metrics().frames + nodes_[1]->metrics().frames, 3u) << "each frame rendered once";

    // In chunks of one frame over both nodes: every frame rendered once, by whichever node
    // took its chunk, and the same images.
    json chunked = body;
    chunked["frames"] = {{"start", 0}, {"end", 48}, {"step", 12}};
    chunked["chunk"] = 1;
    const uint64_t before = nodes_[0]->metrics().frames + nodes_[1]->metrics().frames;
    const uint64_t opens_before = nodes_[0]->metrics().shot_opens + nodes_[1]->metrics().shot_opens;
    const std::string id3 = run_on_farm(chunked);
    EXPECT_EQ(nodes_[0]->metrics().frames + nodes_[1]->metrics().frames - before, 5u);
    // Five chunks and a finish, but each node opens the scene once for the shot at most.
    EXPECT_LE(nodes_[0]->metrics().shot_opens + nodes_[1]->metrics().shot_opens - opens_before, 2u);
    const fs::path spread = job_results_dir((dir_ / "data").string(), id3);
    for (int n : {0, 24, 48})
        EXPECT_EQ(read_image((spread / ("frames/" + std::to_string(n) + "/image.exr")).string()).rgb,
                  read_image((one / ("frames/" + std::to_string(n) + "/image.exr")).string()).rgb) << n;
    const json report = json::parse(std::ifstream(spread / "report.json"));
    EXPECT_EQ(report["shot"]["frames"].size(), 5u);

    // The same shot again, with frame 24 already written as a dead node would have left it (a
    // marker in its report shows whether it was kept). In a folder of its own: a farm job's
    // folder would be written by the nodes meanwhile.
    const fs::path again = dir_ / "resumed";
    fs::create_directories(again / "frames");
    fs::copy(farm / "frames" / "24", again / "frames" / "24", fs::copy_options::recursive);
    json kept = json::parse(std::ifstream(again / "frames" / "24" / "report.json"));
    kept["timings"]["total_s"] = 1234.5;
    std::ofstream(again / "frames" / "24" / "report.json") << kept.dump();
    api::RunOptions opt;
    opt.scene_source = (fs::path(TESSERA_PROJECT_SCENES) / "cornell_shot.gltf").string();
    opt.threads = 2;
    opt.resume_frames = true;
    const api::JobOutcome out = api::run_job(api::parse_render_job(body), opt, api::RunOutputs::in_directory(again.string()));
    EXPECT_EQ(out.report["shot"]["frames_resumed"], 1);
    EXPECT_EQ(out.report["shot"]["frames"][1]["seconds"], 1234.5);
    for (int n : {0, 24, 48}) {
        const std::string f = "frames/" + std::to_string(n) + "/image.exr";
        EXPECT_EQ(read_image((again / f).string()).rgb, read_image((one / f).string()).rgb) << n;
    }
}

// A node that fails every task it takes (its --max-triangles refuses the scene) is blocklisted
// for the job after blocklist_after failures and hands the rest to the other node, which
// finishes it: the same image as one process's, bit for bit; the status names the node and
// the reasons, and a node blocklisted by two jobs is reported failing.
TEST_F(RenderNodeFarm, ANodeThatFailsEveryTaskIsBlocklistedAndTheOtherFinishes) {
    nodes_[1]->stop();
    Redis(redis_->url()).command({"HDEL", keys::nodes, "test-node-2"});
    add_node("failing-node", {}, 1);
    const json body = {{"scene", "cornell_box"}, {"width", 48}, {"height", 32}, {"spp", 8}, {"max_depth", 3}, {"tile_size", 8},
                       {"blocklist_after", 2}};
    // Which node takes which task is a race: jobs until one has blocklisted the failing node
    // (almost always the first: the failing node fails fast and reads again at once).
    std::string id;
    api::JobStatus st;
    for (int tries = 0; tries < 8; ++tries) {
        id = service_->submit(body).id;
        st = wait_final(id);
        ASSERT_EQ(st.state, api::JobState::succeeded) << api::to_json(st).dump();
        if (st.task_failures && !st.task_failures->blocklisted.empty()) break;
    }
    ASSERT_TRUE(st.task_failures) << "the failures stay in the status of the job that met them";
    EXPECT_EQ(st.task_failures->blocklisted, std::vector<std::string>{"failing-node"});
    EXPECT_GE(st.task_failures->failures, 2);
    ASSERT_FALSE(st.task_failures->latest.empty());
    for (const std::string& reason : st.task_failures->latest) {
        EXPECT_EQ(reason.rfind("failing-node: ", 0), 0u) << reason;
        EXPECT_NE(reason.find("scene: "), std::string::npos) << reason;
    }
    const fs::path farm = job_results_dir((dir_ / "data").string(), id);
    const json report = json::parse(std::ifstream(farm / "report.json"));
    for (const auto& share : report["nodes"]) EXPECT_EQ(share["node"], "test-node-1") << "no tile of the failing node";
    const fs::path one = run_in_one_process(body, fs::path(TESSERA_PROJECT_SCENES) / "cornell_box.gltf", "one-blocklisted");
    const Image a = read_image((farm / "image.exr").string()), b = read_image((one / "image.exr").string());
    ASSERT_EQ(a.rgb.size(), b.rgb.size());
    EXPECT_EQ(0, std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float))) << "the same image despite the failures";
    std::vector<std::string> ids = {id};
    // More jobs beside a fresh good node, until one more blocklists the failing node (which node
    // takes which task is a race: it may be the good one takes them all) while the other finishes
    // it: the node is then reported failing (blocklisted by two jobs that others finished).
    without_fixture_nodes();
    add_node("fresh-node");
    Redis r(redis_->url());
    auto blocklisted_by = [&] {
        const RedisValue v = r.command({"HGET", keys::node_blocklisted_jobs, "failing-node"});
        return v.is_nil() ? 0LL : v.as_int();
    };
    EXPECT_EQ(blocklisted_by(), 1);
    for (int tries = 0; tries < 8 && blocklisted_by() < 2; ++tries) {
        const api::JobStatus more = wait_final(service_->submit(body).id);
        EXPECT_EQ(more.state, api::JobState::succeeded) << api::to_json(more).dump();
    }
    ASSERT_EQ(blocklisted_by(), 2);
// The log has each failed task with its node and reason.
    size_t failed_lines = 0;
    std::istringstream log(service_->job_log(ids[0], 0, 10000).ndjson);
    for (std::string line; std::getline(log, line);) {
        const json t = json::parse(line);
        if (t["outcome"] == "failed") {
            ++failed_lines;
            EXPECT_EQ(t["node"], "failing-node");
            EXPECT_FALSE(t["errors"].empty());
        }
    }
    EXPECT_GE(failed_lines, 2u);
    // Reported across jobs once its heartbeat carries the counts (every quarter of the visibility).
    json failing;
    for (int i = 0; i < 200 && failing.is_null(); ++i) {
        for (const json& n : service_->node_report())
            if (n["name"] == "failing-node" && n["blocklisted_jobs"] == 2) failing = n;
        if (failing.is_null()) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    ASSERT_FALSE(failing.is_null()) << service_->node_report().dump();
    EXPECT_TRUE(failing["failing"].get<bool>());
    EXPECT_GE(failing["failed_tasks"].get<int>(), 4);
}

// A task that fails on every node fails its job once it has failed more than max_retries times,
// with every reason, each naming its node; the job's task went to the other node first.
TEST_F(RenderNodeFarm, ATaskFailingEverywhereFailsItsJobAfterMaxRetriesWithEveryReason) {
    const json bad = {{"scene", "broken_box"}, {"width", 32}, {"height", 24}, {"spp", 4}, {"max_retries", 1}};
    const api::JobStatus st = wait_final(service_->submit(bad).id);
    ASSERT_EQ(st.state, api::JobState::failed);
    EXPECT_NE(st.error.find("failed 2 times, more than the job's max_retries (1)"), std::string::npos) << st.error;
    EXPECT_NE(st.error.find("test-node-1: the start task: scene: "), std::string::npos) << "every reason: " << st.error;
    EXPECT_NE(st.error.find("test-node-2: the start task: scene: "), std::string::npos) << "on the other node: " << st.error;
    ASSERT_TRUE(st.task_failures);
    EXPECT_EQ(st.task_failures->failures, 2);
    EXPECT_TRUE(st.task_failures->blocklisted.empty());
    // The scene is named by its place in the catalog, not by the node's copy of it.
    EXPECT_NE(st.error.find("scene: broken_box.gltf#/scenes/0/nodes/0: "), std::string::npos) << st.error;
    EXPECT_EQ(st.error.find("tessera-node-"), std::string::npos) << st.error;
    for (const std::string& reason : st.task_failures->latest) {
        EXPECT_NE(reason.find("broken_box.gltf#"), std::string::npos) << reason;
        EXPECT_EQ(reason.find("tessera-node-"), std::string::npos) << reason;
    }
}

// A farm's report names the job's files as one process's does: by their places in the API
// node's catalog, not the node's copies of them nor the API node's folders.
TEST_F(RenderNodeFarm, AReportNamesItsFilesByTheirPlaceInTheCatalog) {
    const std::string id = run_on_farm({{"scene", "dark_box"}, {"environment", "sky"}, {"width", 16}, {"height", 12}, {"spp", 2}});
    std::ifstream in(job_results_dir((dir_ / "data").string(), id) / "report.json");
    const std::string report((std::istreambuf_iterator<char>(in)), {});
    EXPECT_NE(report.find("environment light: sky.exr ("), std::string::npos) << report;
    for (const std::string& folder : {std::string(TESSERA_PROJECT_SCENES), dir_.string(), std::string("tessera-node-")})
        EXPECT_EQ(report.find(folder), std::string::npos) << folder << " in " << report;
}

// A shot playing an animation its scene lacks fails on the node that starts it, once, naming the
// scene's animations: every node reads the scene alike, so no retry and no other node does better.
TEST_F(RenderNodeFarm, AShotOfAnAnimationTheSceneLacksFailsOnceNamingItsAnimations) {
    const json body = {{"scene", "cornell_shot"}, {"width", 16}, {"height", 12}, {"spp", 1}, {"frames", json::array({0})},
                       {"animation", "Walk"}};
    const api::JobStatus st = wait_final(service_->submit(body).id);
    ASSERT_EQ(st.state, api::JobState::failed) << api::to_json(st).dump();
    for (const char* name : {"'Walk'", "'Cube'", "'Dolly'"}) EXPECT_NE(st.error.find(name), std::string::npos) << name << " in " << st.error;
    EXPECT_EQ(st.error.find("max_retries"), std::string::npos) << "not retried: " << st.error;
    EXPECT_FALSE(st.task_failures) << api::to_json(st).dump();
}

// A job a node cannot read (a field an API node newer than it wrote) is not the job's input
// error: it is retried like any task that failed on a node, saying why, until no node is left.
TEST_F(RenderNodeFarm, AJobANodeCannotReadIsRetriedNotFailedAtOnce) {
    without_fixture_nodes();
    const std::string id = service_->submit({{"scene", "cornell_box"}, {"width", 16}, {"height", 12}, {"spp", 1}, {"max_retries", 1}}).id;
    Redis r(redis_->url());
    json spec = json::parse(r.command({"HGET", keys::job(id), "spec"}).text);
    spec["a_field_from_a_newer_version"] = 1;
    r.command({"HSET", keys::job(id), "spec", spec.dump()});
    add_node("older-node");
    const api::JobStatus st = wait_final(id);
    ASSERT_EQ(st.state, api::JobState::failed) << api::to_json(st).dump();
    EXPECT_NE(st.error.find("this node cannot read the job"), std::string::npos) << st.error;
    ASSERT_TRUE(st.task_failures) << "retried as a task that failed: " << st.error;
    EXPECT_GE(st.task_failures->failures, 2) << st.error;
}

// Where every live node is blocklisted for a job, it fails saying so, with the reasons.
TEST_F(RenderNodeFarm, AJobNoLiveNodeCanTakeFailsWithEveryReason) {
    without_fixture_nodes();
    add_node("failing-node", {}, 1);
    const json body = {{"scene", "cornell_box"}, {"width", 32}, {"height", 24}, {"spp", 4}, {"blocklist_after", 2}};
    const api::JobStatus st = wait_final(service_->submit(body).id);
    ASSERT_EQ(st.state, api::JobState::failed);
    EXPECT_NE(st.error.find("no live render node can take its tasks: failing-node"), std::string::npos) << st.error;
    EXPECT_NE(st.error.find("failing-node: the start task: scene: "), std::string::npos) << st.error;
}

// Node tags: a job that requires a tag no live node has stays queued and says so; a node with
// the tag takes it, and no other node renders any of its tiles.
TEST_F(RenderNodeFarm, AJobRequiringTagsWaitsForANodeThatHasThem) {
    json body = {{"scene", "cornell_box"}, {"width", 32}, {"height", 24}, {"spp", 4}, {"tile_size", 8}, {"requires", {"bigmem", "avx512"}}};
    const std::string id = service_->submit(body).id;
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));
    api::JobStatus st = service_->status(id);
    EXPECT_EQ(st.state, api::JobState::queued) << "no node has the tags";
    EXPECT_NE(st.unplaceable.find("no live render node has every tag the job requires"), std::string::npos) << st.unplaceable;
    EXPECT_NE(st.unplaceable.find("avx512"), std::string::npos) << st.unplaceable;
    add_node("half-node", {"bigmem"});
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));
    EXPECT_EQ(service_->status(id).state, api::JobState::queued) << "a node with one of the two tags does not take it";
    add_node("big-node", {"avx512", "bigmem", "gpu"});
    st = wait_final(id);
    ASSERT_EQ(st.state, api::JobState::succeeded) << api::to_json(st).dump();
    EXPECT_TRUE(st.unplaceable.empty());
    const json report = json::parse(std::ifstream(job_results_dir((dir_ / "data").string(), id) / "report.json"));
    ASSERT_FALSE(report["nodes"].empty());
    for (const auto& share : report["nodes"]) EXPECT_EQ(share["node"], "big-node");
    // A job without tags still runs anywhere, the tagged node included.
    body.erase("requires");
    EXPECT_EQ(wait_final(service_->submit(body).id).state, api::JobState::succeeded);
}

}  // namespace
}  // namespace tessera::server
