// Shots through the HTTP API of a one-process server: a job's frames rendered and served one by
// one under /frames/{n}/ (while the shot still runs, too), its contact sheet and report, the
// status's per-frame states, the still's routes refused for a shot and the shot's for a still,
// and shot fields refused at submission naming the field.
#include "api/job.h"
#include "tests/server/server_fixture.h"

#include <gtest/gtest.h>
#include <httplib.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/io/image_io.h"
#include "engine/render/image.h"

namespace tessera::server {
namespace {

using nlohmann::json;

// 0, 1 and 2 s at the default 24 fps: the start, middle and end of cornell_shot's two animations.
const std::vector<int> kFrames = {0, 24, 48};
constexpr uint64_t kSeed = 7;

// A shot of frames small enough to render in milliseconds each.
json shot_job(const json& frames) {
    return {{"scene", "cornell_shot"}, {"width", 32}, {"height", 24}, {"spp", 2}, {"max_depth", 2}, {"seed", kSeed}, {"frames", frames}};
}

std::string problem_type(const httplib::Result& r) {
    if (!r) return "";
    const json p = json::parse(r->body, nullptr, false);
    return p.is_object() ? p.value("type", "") : "";
}

class ShotApi : public Server {
protected:
    // A problem+json answer of this status, and of this type: the status alone does not tell
    // "not a shot" from "no such frame" from "no such route".
    void expect_problem_type(const std::string& path, int status, const std::string& type) {
        SCOPED_TRACE(path);
        const auto r = client_->Get(path);
        expect_problem(r, status);
        EXPECT_EQ(problem_type(r), "/problems/" + type) << (r ? r->body : httplib::to_string(r.error()));
    }
    // Bytes as served, read back by the image library.
    Image decoded(const std::string& bytes, const std::string& name) {
        const std::string path = (dir_ / name).string();
        std::ofstream(path, std::ios::binary) << bytes;
        return read_image(path);
    }
};

TEST_F(ShotApi, EveryFrameIsServedWithItsOwnSeedBesideAContactSheet) {
    start();
    const std::string id = submit(shot_job(kFrames));
    json done = wait_state(id, {"succeeded", "failed"});
    ASSERT_EQ(done["state"], "succeeded") << done.dump();
    const std::string base = "/v1/jobs/" + id;

    json& shot = done["shot"];
    ASSERT_TRUE(shot.is_object()) << done.dump();
    EXPECT_EQ(shot["frames_total"], kFrames.size());
    EXPECT_EQ(shot["frames_done"], kFrames.size());
    // Its progress counts every frame's samples and tiles, as while it ran (it read zero once done).
    const json& progress = done["progress"];
    EXPECT_EQ(progress["fraction"], 1.0);
    EXPECT_GT(progress["samples_done"].get<uint64_t>(), 0u) << progress;
    EXPECT_GT(progress["tiles_total"].get<uint64_t>(), 0u) << progress;
    EXPECT_EQ(progress["tiles_done"], progress["tiles_total"]) << progress;
    EXPECT_TRUE(shot["current_frame"].is_null()) << shot.dump();
    EXPECT_EQ(shot["eta_s"], 0.0);
    ASSERT_TRUE(shot["mean_frame_s"].is_number()) << shot.dump();
    EXPECT_GT(shot["mean_frame_s"].get<double>(), 0.0);
    ASSERT_EQ(shot["frames"].size(), kFrames.size()) << shot.dump();
    for (size_t i = 0; i < kFrames.size(); ++i) {
        EXPECT_EQ(shot["frames"][i]["frame"], kFrames[i]) << "in rendering order";
        EXPECT_EQ(shot["frames"][i]["state"], "succeeded");
    }
    EXPECT_EQ(done["links"]["contact_sheet"], base + "/contact_sheet.png");
    EXPECT_EQ(done["links"]["frame_exr"], base + "/frames/{n}/image.exr");

    std::set<uint64_t> seeds;
    for (int n : kFrames) {
        SCOPED_TRACE("frame " + std::to_string(n));
        const std::string frame = base + "/frames/" + std::to_string(n);
        auto exr = client_->Get(frame + "/image.exr");
        ASSERT_TRUE(exr);
        ASSERT_EQ(exr->status, 200) << exr->body;
        EXPECT_EQ(exr->get_header_value("Content-Type"), "image/x-exr");
        const Image image = decoded(exr->body, "frame.exr");
        EXPECT_EQ(image.width, 32);
        EXPECT_EQ(image.height, 24);
        for (const char* png_file : {"image.png", "rate.png"}) {
            auto png = client_->Get(frame + "/" + png_file);
            ASSERT_TRUE(png);
            ASSERT_EQ(png->status, 200) << png_file << ": " << png->body;
            EXPECT_EQ(png->get_header_value("Content-Type"), "image/png") << png_file;
            EXPECT_EQ(png->body.substr(0, 4), "\x89PNG") << png_file;
        }
        auto csv = client_->Get(frame + "/convergence.csv");
        ASSERT_TRUE(csv);
        ASSERT_EQ(csv->status, 200) << csv->body;
        EXPECT_EQ(csv->get_header_value("Content-Type"), "text/csv");
        EXPECT_EQ(csv->body.rfind("seconds,", 0), 0u) << csv->body;
        auto report = client_->Get(frame + "/report.json");
        ASSERT_TRUE(report);
        ASSERT_EQ(report->status, 200) << report->body;
        EXPECT_EQ(report->get_header_value("Content-Type"), "application/json");
        json r = json::parse(report->body);
        EXPECT_EQ(r["settings"]["scene"], "cornell_shot");
        // The frame's own seed, the one any other server would render it with.
        const uint64_t seed = r["settings"]["seed"];
        EXPECT_EQ(seed, api::frame_seed(kSeed, n));
        seeds.insert(seed);
    }
    EXPECT_EQ(seeds.size(), kFrames.size()) << "each frame has its own noise";

    auto sheet = client_->Get(base + "/contact_sheet.png");
    ASSERT_TRUE(sheet);
    ASSERT_EQ(sheet->status, 200) << sheet->body;
    EXPECT_EQ(sheet->get_header_value("Content-Type"), "image/png");
    EXPECT_EQ(sheet->body.substr(0, 4), "\x89PNG");
    // At this width a thumbnail is the whole frame: a grid of whole frames with room for every one.
    const Image s = decoded(sheet->body, "sheet.png");
    ASSERT_GT(s.width, 0);
    EXPECT_EQ(s.width % 32, 0) << s.width;
    EXPECT_EQ(s.height % 24, 0) << s.height;
    EXPECT_GE(size_t(s.width / 32) * size_t(s.height / 24), kFrames.size()) << s.width << "x" << s.height;

    // The shot's own report: every frame with the seed its report shows, and the file's animations.
    auto report = client_->Get(base + "/report.json");
    ASSERT_TRUE(report);
    ASSERT_EQ(report->status, 200) << report->body;
    json r = json::parse(report->body);
    ASSERT_EQ(r["shot"]["frames"].size(), kFrames.size()) << r.dump();
    for (size_t i = 0; i < kFrames.size(); ++i) {
        EXPECT_EQ(r["shot"]["frames"][i]["frame"], kFrames[i]);
        EXPECT_EQ(r["shot"]["frames"][i]["seed"], api::frame_seed(kSeed, kFrames[i]));
    }
    ASSERT_EQ(r["shot"]["animations"].size(), 2u) << r["shot"].dump();
    EXPECT_EQ(r["shot"]["animations"][0]["name"], "Cube");
    EXPECT_EQ(r["shot"]["animations"][1]["name"], "Dolly");
}

// A shot has no one image: the still's names point to the frames rather than to nothing.
TEST_F(ShotApi, AShotsStillRoutesPointToItsFrames) {
    start();
    const std::string id = submit(shot_job(json::array({0, 24})));
    ASSERT_EQ(wait_state(id, {"succeeded", "failed"})["state"], "succeeded");
    const std::string base = "/v1/jobs/" + id;
    for (const char* file : {"image.png", "image.exr", "rate.png", "convergence.csv", "convergence.svg"})
        expect_problem_type(base + "/" + file, 404, "per-frame-result");
    // A frame the shot does not render, however near one it does.
    for (const char* n : {"1", "23", "-24", "72"}) expect_problem_type(base + "/frames/" + n + "/image.exr", 404, "no-such-frame");
    // Not a frame number, or not a frame's file: no route at all (not a 500 from the number).
    for (const char* path : {"/frames/abc/image.png", "/frames/1.5/image.png", "/frames/0x0/image.png", "/frames/0/scene.gltf", "/frames/0"})
        expect_problem_type(base + path, 404, "not-found");
    // The frame routes exist under GET only.
    for (const std::string path : {"/frames/0/image.png", "/contact_sheet.png"}) {
        SCOPED_TRACE(path);
        auto r = client_->Post(base + path, "", "application/json");
        ASSERT_TRUE(r);
        expect_problem(r, 405);
        EXPECT_EQ(r->get_header_value("Allow"), "GET, HEAD");
    }
}

TEST_F(ShotApi, AStillHasNoFramesNorContactSheet) {
    start();
    json still = shot_job(nullptr);
    still.erase("frames");
    const std::string id = submit(still);
    json done = wait_state(id, {"succeeded", "failed"});
    ASSERT_EQ(done["state"], "succeeded") << done.dump();
    EXPECT_TRUE(done["shot"].is_null()) << done.dump();
    EXPECT_FALSE(done["links"].contains("contact_sheet")) << done.dump();
    const std::string base = "/v1/jobs/" + id;
    expect_problem_type(base + "/frames/0/image.png", 404, "not-a-shot");
    expect_problem_type(base + "/frames/0/report.json", 404, "not-a-shot");
    expect_problem_type(base + "/contact_sheet.png", 404, "not-a-shot");
    auto png = client_->Get(base + "/image.png");
    ASSERT_TRUE(png);
    EXPECT_EQ(png->status, 200) << "the still's own image is where it always was";
}

TEST_F(ShotApi, BadShotsAreRefusedNamingTheField) {
    start();
    // A finished still of the shot's size: a reference the shot could otherwise use.
    json still = shot_job(nullptr);
    still.erase("frames");
    const std::string ref = submit(still);
    ASSERT_EQ(wait_state(ref, {"succeeded", "failed"})["state"], "succeeded");

    expect_problem(post_job(shot_job(json::array())), 400, "/frames");
    expect_problem(post_job(shot_job(json::array({0, 24, 0}))), 400, "/frames");
    expect_problem(post_job(shot_job(json::array({0, 1.5}))), 400, "/frames/1");
    expect_problem(post_job(shot_job(json{{"start", 3}, {"end", 1}})), 400, "/frames/end");
    expect_problem(post_job(shot_job(json{{"start", 0}, {"end", 3}, {"step", 0}})), 400, "/frames/step");
    expect_problem(post_job(shot_job(json{{"start", 0}})), 400, "/frames");
    expect_problem(post_job(shot_job("0-3")), 400, "/frames");
    json fps = shot_job(kFrames);
    fps["fps"] = 0;
    expect_problem(post_job(fps), 400, "/fps");
    json animation = shot_job(kFrames);
    animation["animation"] = "";
    expect_problem(post_job(animation), 400, "/animation");
    // Refused for being a shot, not for its reference: the same body as a still is taken.
    json referenced = shot_job(kFrames);
    referenced["reference"] = ref;
    auto r = post_job(referenced);
    ASSERT_TRUE(r);
    expect_problem(r, 400, "/reference");
    EXPECT_NE(r->body.find("shot"), std::string::npos) << r->body;
    referenced.erase("frames");
    const std::string control = submit(referenced);
    // Nothing refused was stored: the reference and the control are the only jobs.
    auto list = client_->Get("/v1/jobs?limit=100");
    ASSERT_TRUE(list && list->status == 200);
    EXPECT_EQ(json::parse(list->body)["total"], 2) << list->body;
    EXPECT_EQ(wait_state(control, {"succeeded", "failed"})["state"], "succeeded");
}

TEST_F(ShotApi, AnUnknownAnimationFailsTheJobNamingTheFilesAnimations) {
    start();
    json walk = shot_job(json::array({0}));
    walk["animation"] = "Walk";
    json failed = wait_state(submit(walk), {"succeeded", "failed"});
    ASSERT_EQ(failed["state"], "failed") << failed.dump();
    const std::string error = failed["error"];
    for (const char* name : {"'Walk'", "'Cube'", "'Dolly'"}) EXPECT_NE(error.find(name), std::string::npos) << name << " in " << error;
    // The job's input, not a scene that failed to read: it is not run again.
    EXPECT_EQ(failed["attempts"], 1) << failed.dump();
    // One the file has plays, by name or by index.
    for (const json& which : {json("Dolly"), json(1)}) {
        json ok = shot_job(json::array({0}));
        ok["animation"] = which;
        const json s = wait_state(submit(ok), {"succeeded", "failed"});
        EXPECT_EQ(s["state"], "succeeded") << which << ": " << s.dump();
    }
    // A scene without animations has no animation of any name.
    json none = shot_job(json::array({0}));
    none["scene"] = "builtin:cornell_box";
    none["animation"] = "Cube";
    json f = wait_state(submit(none), {"succeeded", "failed"});
    ASSERT_EQ(f["state"], "failed") << f.dump();
    EXPECT_NE(f["error"].get<std::string>().find("none"), std::string::npos) << f.dump();
    EXPECT_EQ(f["attempts"], 1) << f.dump();
    auto health = client_->Get("/healthz");
    ASSERT_TRUE(health);
    EXPECT_EQ(health->status, 200);
}

TEST_F(ShotApi, TheSceneListShowsWhatAFileAnimates) {
    start();
    auto list = client_->Get("/v1/scenes");
    ASSERT_TRUE(list);
    ASSERT_EQ(list->status, 200) << list->body;
    const json scenes = json::parse(list->body);
    json shot, box;
    for (const json& s : scenes.value("scenes", json::array())) {
        if (s.value("name", "") == "cornell_shot") shot = s;
        if (s.value("name", "") == "cornell_box") box = s;
    }
    ASSERT_TRUE(shot.is_object()) << list->body;
    ASSERT_TRUE(shot["animations"].is_array()) << shot.dump();
    ASSERT_EQ(shot["animations"].size(), 2u) << shot.dump();
    json cube = shot["animations"][0], dolly = shot["animations"][1];
    EXPECT_EQ(cube["name"], "Cube");
    EXPECT_EQ(cube["channels"], 4);  // rotation, translation, scale, morph weights
    EXPECT_EQ(dolly["name"], "Dolly");
    EXPECT_EQ(dolly["channels"], 1);  // the camera's translation
    for (json* a : {&cube, &dolly}) {
        EXPECT_DOUBLE_EQ((*a)["start_s"].get<double>(), 0.0) << a->dump();
        EXPECT_DOUBLE_EQ((*a)["end_s"].get<double>(), 2.0) << a->dump();
    }
    ASSERT_TRUE(box.is_object()) << list->body;
    EXPECT_EQ(box["animations"], json::array()) << "a still scene animates nothing";
}

// Frame n is served once written while later frames still render: 409 before, 200 after,
// never a 5xx; the status tells which frame renders and how long the rest should take.
TEST_F(ShotApi, FramesAreServedWhileTheShotRuns) {
    start();
    // A thousand frames run for seconds, far longer than the requests below need; the shot is
    // canceled once they are made.
    constexpr size_t kTotal = 1000;
    const std::string id = submit(shot_job(json{{"start", 0}, {"end", int(kTotal) - 1}}));
    const std::string base = "/v1/jobs/" + id;
    expect_problem_type(base + "/frames/999/image.exr", 409, "not-finished");
    expect_problem_type(base + "/contact_sheet.png", 409, "not-finished");
    expect_problem_type(base + "/report.json", 409, "not-finished");
    // A running shot's curve is per frame whatever its state; its image at the job's URL is its
    // current frame's latest pass, or "not yet" (never 404 while it runs).
    expect_problem_type(base + "/convergence.csv", 404, "per-frame-result");

    json s;
    const auto t0 = std::chrono::steady_clock::now();
    for (;;) {
        auto live = client_->Get(base + "/image.png");
        ASSERT_TRUE(live);
        s = status(id);
        if (s["state"] == "queued" || s["state"] == "running") {
            EXPECT_TRUE(live->status == 200 || live->status == 409) << live->status << ": " << live->body.substr(0, 300);
        }
        auto f = client_->Get(base + "/frames/0/report.json");
        ASSERT_TRUE(f);
        ASSERT_TRUE(f->status == 200 || f->status == 409) << f->status << ": " << f->body;
        if (f->status == 409) {
            EXPECT_EQ(problem_type(f), "/problems/not-finished") << f->body;
        }
        s = status(id);
        if (s["state"] != "queued" && s["state"] != "running") break;
        if (s["state"] == "running" && s["shot"].is_object() && s["shot"]["frames_done"].get<size_t>() >= 2) break;
        ASSERT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 30.0) << s.dump();
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ASSERT_EQ(s["state"], "running") << s.dump();

    json& shot = s["shot"];
    const size_t done = shot["frames_done"];
    EXPECT_EQ(shot["frames_total"], kTotal);
    EXPECT_EQ(shot["current_frame"], done) << "frame n is the n-th of 0..999";
    ASSERT_TRUE(shot["mean_frame_s"].is_number() && shot["eta_s"].is_number()) << shot["mean_frame_s"] << " " << shot["eta_s"];
    const double mean = shot["mean_frame_s"];
    EXPECT_GT(mean, 0.0);
    EXPECT_DOUBLE_EQ(shot["eta_s"].get<double>(), mean * double(kTotal - done));
    ASSERT_EQ(shot["frames"].size(), kTotal);
    size_t misplaced = 0;
    for (size_t i = 0; i < kTotal; ++i) {
        const std::string want = i < done ? "succeeded" : i == done ? "running" : "queued";
        const json& e = shot["frames"][i];
        misplaced += !(e.is_object() && e.value("frame", -1) == int(i) && e.value("state", "") == want);
    }
    EXPECT_EQ(misplaced, 0u) << "of " << kTotal << " frames, " << done << " done";
    // The budget is every frame's samples: two frames of a thousand are not the whole job.
    EXPECT_LE(s["progress"]["fraction"].get<double>(), double(done + 1) / double(kTotal) + 1e-12) << s["progress"];

    for (int n : {0, 1}) {
        for (const char* file : {"image.exr", "image.png", "report.json"}) {
            SCOPED_TRACE("frame " + std::to_string(n) + " " + file);
            auto r = client_->Get(base + "/frames/" + std::to_string(n) + "/" + file);
            ASSERT_TRUE(r);
            EXPECT_EQ(r->status, 200) << r->body;
        }
    }
    expect_problem_type(base + "/frames/999/image.exr", 409, "not-finished");
    expect_problem_type(base + "/frames/1000/image.exr", 404, "no-such-frame");
    ASSERT_EQ(status(id)["state"], "running") << "the checks above were to be made while the shot ran";

    auto cancel = client_->Delete(base);
    ASSERT_TRUE(cancel);
    ASSERT_EQ(cancel->status, 200) << cancel->body;
    ASSERT_EQ(wait_state(id, {"canceled", "succeeded", "failed"}, 10)["state"], "canceled");
    // Ended without it: the last frame will never come, which is not "not finished".
    expect_problem_type(base + "/frames/999/image.exr", 410, "gone");
}

}  // namespace
}  // namespace tessera::server
