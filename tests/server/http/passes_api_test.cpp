// Passes and the denoised image through the HTTP API of a one-process server: a job's
// multilayer EXR and each pass alone, its denoised image and the denoised error series; the
// denoised image while the job runs; a pass or denoised image the job did not ask for is 404 with
// its reason, a shot's are per frame; bad `passes` and `denoise` values are refused naming the
// field.
#include "tests/server/server_fixture.h"

#include "engine/render/aov.h"

#include <gtest/gtest.h>
#include <httplib.h>

#include <chrono>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

namespace tessera::server {
namespace {

using nlohmann::json;

const std::string kExrMagic("\x76\x2f\x31\x01", 4);

TEST_F(Server, PassesAndTheDenoisedImageAreServed) {
    start();
    json job = kSmallJob;
    job["scene"] = "cornell_box";  // the glTF: the whole box at any size (the builtin's CS184 camera would crop to the back wall)
    job["spp"] = 8;
    job["max_depth"] = 3;
    job["passes"] = {"albedo", "depth", "diffuse_direct", "glossy_indirect", "crypto_object"};
    job["denoise"] = true;
    const std::string id = submit(job);
    const json done = wait_state(id, {"succeeded", "failed"});
    ASSERT_EQ(done["state"], "succeeded") << done.dump();
    EXPECT_EQ(done["settings"]["passes"], job["passes"]);
    EXPECT_EQ(done["settings"]["denoise"], true);
    const std::string base = "/v1/jobs/" + id;
    for (const char* f : {"/passes.exr", "/passes/albedo.exr", "/passes/depth.exr", "/passes/crypto_object.exr", "/denoised.exr"}) {
        auto r = client_->Get(base + f);
        ASSERT_TRUE(r) << f;
        EXPECT_EQ(r->status, 200) << f << r->body;
        EXPECT_EQ(r->get_header_value("Content-Type"), "image/x-exr") << f;
        EXPECT_EQ(r->body.substr(0, 4), kExrMagic) << f;
    }
    auto png = client_->Get(base + "/denoised.png");
    ASSERT_TRUE(png && png->status == 200);
    EXPECT_EQ(png->body.substr(1, 3), "PNG");
    // Asked for neither: 404 with the reason, not 410.
    expect_problem(client_->Get(base + "/passes/normal.exr"), 404);
    expect_problem(client_->Get(base + "/passes/crypto_material.exr"), 404);
    EXPECT_NE(client_->Get(base + "/passes/normal.exr")->body.find("no-such-pass"), std::string::npos);
    // The denoised series beside the noisy one.
    const json report = json::parse(client_->Get(base + "/report.json")->body);
    const json& last = report["convergence"]["points"].back();
    EXPECT_TRUE(last["denoised_est_rel_mse"].is_number()) << last.dump();
    EXPECT_LT(last["denoised_est_rel_mse"].get<double>(), last["est_rel_mse"].get<double>());
    auto csv = client_->Get(base + "/convergence.csv");
    ASSERT_TRUE(csv && csv->status == 200);
    EXPECT_NE(csv->body.find("denoised_est_rel_mse"), std::string::npos);
    EXPECT_NE(client_->Get(base + "/convergence.svg")->body.find("denoised"), std::string::npos);

    // A job that asked for nothing has neither.
    const std::string plain = submit(kSmallJob);
    ASSERT_EQ(wait_state(plain, {"succeeded", "failed"})["state"], "succeeded");
    for (const char* f : {"/denoised.png", "/denoised.exr", "/passes.exr", "/passes/albedo.exr"}) {
        auto r = client_->Get("/v1/jobs/" + plain + f);
        expect_problem(r, 404);
    }
    EXPECT_NE(client_->Get("/v1/jobs/" + plain + "/denoised.png")->body.find("not-denoised"), std::string::npos);
    // No such pass at all: not a route.
    auto unknown = client_->Get(base + "/passes/beauty.exr");
    ASSERT_TRUE(unknown);
    EXPECT_EQ(unknown->status, 404);
    auto escape = client_->Get(base + "/passes/..%2Freport.json");
    ASSERT_TRUE(escape);
    EXPECT_EQ(escape->status, 404);
}

TEST_F(Server, TheDenoisedImageIsShownWhileTheJobRuns) {
    start();
    json job = {{"scene", "builtin:cornell_box"}, {"width", 160}, {"height", 120}, {"spp", 4096}, {"max_depth", 4},
                {"denoise", true}, {"time_limit_s", 60}};
    const std::string id = submit(job);
    const std::string base = "/v1/jobs/" + id;
    bool seen = false;
    const auto t0 = std::chrono::steady_clock::now();
    while (!seen && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(30)) {
        auto r = client_->Get(base + "/denoised.png");
        ASSERT_TRUE(r);
        if (r->status == 200) {
            EXPECT_FALSE(r->get_header_value("X-Tessera-Pass").empty());
            EXPECT_FALSE(r->get_header_value("X-Tessera-Pass-Error").empty()) << "the denoised image's estimated error";
            EXPECT_EQ(r->get_header_value("Cache-Control"), "no-store");
            seen = true;
        } else {
            EXPECT_EQ(r->status, 409) << r->body;  // before the 4-spp pass
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
    }
    EXPECT_TRUE(seen);
    // What the running job will never have is 404 now, not "poll" (409).
    for (const char* f : {"/passes/albedo.exr", "/passes.exr"}) {
        auto r = client_->Get(base + f);
        ASSERT_TRUE(r);
        EXPECT_EQ(r->status, 404) << f << ": " << r->body;
        EXPECT_NE(r->body.find("no-such-pass"), std::string::npos) << r->body;
    }
    const json st = status(id);
    if (st["latest_pass"].is_object()) {
        EXPECT_TRUE(st["latest_pass"].contains("denoised_est_rel_mse"));
    }
    client_->Delete(base);
    wait_state(id, {"canceled", "succeeded", "failed"});
}

// A denoising job whose time ran out before every pixel had two samples has no denoised image:
// fetching it says so (404), not that the results were deleted (410), and the report says why.
TEST_F(Server, AJobThatEndedBeforeTwoSamplesSaysNothingWasDenoised) {
    start();
    const json job = {{"scene", "builtin:cornell_box"}, {"width", 320}, {"height", 240}, {"spp", 65536}, {"max_depth", 5},
                      {"denoise", true}, {"time_limit_s", 0.001}};
    const std::string id = submit(job);
    ASSERT_EQ(wait_state(id, {"succeeded", "failed"})["state"], "succeeded");
    const std::string base = "/v1/jobs/" + id;
    for (const char* f : {"/denoised.png", "/denoised.exr"}) {
        auto r = client_->Get(base + f);
        expect_problem(r, 404);
        EXPECT_NE(r->body.find("two samples"), std::string::npos) << r->body;
    }
    auto report = client_->Get(base + "/report.json");
    ASSERT_TRUE(report && report->status == 200);
    EXPECT_NE(report->body.find("denoised image: the render ended before"), std::string::npos) << report->body;
    EXPECT_EQ(client_->Get(base + "/image.png")->status, 200);  // the image is there
}

// A streamed file and an image encoded on request serve a Range within themselves (httplib checks
// a range only against a body it holds: an encoded image's range read past its buffer), and a
// range past their end is 416.
TEST_F(Server, RangesOfStreamedAndEncodedAnswersStayInsideThem) {
    start();
    json job = kSmallJob;
    job["width"] = 160;
    job["height"] = 120;
    job["passes"] = {"albedo", "normal", "depth", "position", "diffuse_direct", "diffuse_indirect", "variance", "crypto_object"};
    const std::string id = submit(job);
    ASSERT_EQ(wait_state(id, {"succeeded", "failed"})["state"], "succeeded");
    const std::string base = "/v1/jobs/" + id;
    for (const std::string& path : {base + "/passes.exr", base + "/image.png?exposure=0.5"}) {
        auto whole = client_->Get(path);
        ASSERT_TRUE(whole && whole->status == 200) << path;
        const std::string& all = whole->body;
        if (path.ends_with(".exr")) {
            ASSERT_GT(all.size(), size_t(256) << 10) << "streamed, not answered from memory";
        }
        auto part = client_->Get(path, httplib::Headers{{"Range", "bytes=10-99999999"}});
        ASSERT_TRUE(part) << path;
        EXPECT_EQ(part->status, 206) << path;
        EXPECT_EQ(part->body, all.substr(10)) << path;
        auto tail = client_->Get(path, httplib::Headers{{"Range", "bytes=-7"}});
        ASSERT_TRUE(tail);
        EXPECT_EQ(tail->body, all.substr(all.size() - 7)) << path;
        auto past = client_->Get(path, httplib::Headers{{"Range", "bytes=" + std::to_string(all.size()) + "-"}});
        ASSERT_TRUE(past) << path;
        EXPECT_EQ(past->status, 416) << path << ": " << past->body.substr(0, 200);
        EXPECT_EQ(past->get_header_value_count("Content-Range"), 1u) << path;
        EXPECT_EQ(past->get_header_value("Content-Range"), "bytes */" + std::to_string(all.size())) << path;
        EXPECT_EQ(json::parse(past->body)["type"], "/problems/range-not-satisfiable") << path;
        EXPECT_EQ(client_->Get("/healthz")->status, 200);
    }
    // A file answered from memory alike: its range's end cut at the file's, 416 past it.
    auto png = client_->Get(base + "/image.png");
    ASSERT_TRUE(png && png->status == 200);
    const size_t n = png->body.size();
    auto part = client_->Get(base + "/image.png", httplib::Headers{{"Range", "bytes=0-99999999"}});
    ASSERT_TRUE(part);
    EXPECT_EQ(part->status, 206);
    EXPECT_EQ(part->get_header_value("Content-Range"), "bytes 0-" + std::to_string(n - 1) + "/" + std::to_string(n));
    auto past = client_->Get(base + "/image.png", httplib::Headers{{"Range", "bytes=" + std::to_string(n) + "-"}});
    ASSERT_TRUE(past);
    EXPECT_EQ(past->status, 416);
    EXPECT_EQ(past->get_header_value_count("Content-Range"), 1u);
    EXPECT_EQ(json::parse(past->body)["type"], "/problems/range-not-satisfiable");
    auto conditional = client_->Get(base + "/image.png", httplib::Headers{{"Range", "bytes=0-9"}, {"If-Range", "\"x\""}});
    ASSERT_TRUE(conditional);
    EXPECT_EQ(conditional->status, 200) << "If-Range: no validator of ours matches, so the whole file";
    EXPECT_EQ(conditional->body.size(), n);
}

// A Range is for result files alone: a job's status, a problem and a POST's answer are never
// cut by one, and a POST carrying one still says it queued the job (a 416 there had the client
// submit it again).
TEST_F(Server, ARangeTouchesNothingButResultFiles) {
    start();
    const httplib::Headers ranged{{"Range", "bytes=99999-"}};
    auto posted = client_->Post("/v1/jobs", ranged, kSmallJob.dump(), "application/json");
    ASSERT_TRUE(posted);
    EXPECT_EQ(posted->status, 202) << posted->body.substr(0, 200);
    EXPECT_FALSE(posted->has_header("Content-Range"));
    const std::string id = json::parse(posted->body)["id"];
    auto status = client_->Get("/v1/jobs/" + id, httplib::Headers{{"Range", "bytes=0-5"}});
    ASSERT_TRUE(status);
    EXPECT_EQ(status->status, 200);
    EXPECT_FALSE(status->has_header("Content-Range"));
    EXPECT_EQ(json::parse(status->body)["id"], id);
    auto missing = client_->Get("/v1/jobs/ffffffffffffffff/image.png", httplib::Headers{{"Range", "bytes=0-5"}});
    ASSERT_TRUE(missing);
    EXPECT_EQ(missing->status, 404);
    EXPECT_EQ(json::parse(missing->body)["status"], 404) << "the problem whole";
    auto bad = client_->Get("/v1/jobs/" + id + "/log?from=abc", httplib::Headers{{"Range", "bytes=0-9"}});
    ASSERT_TRUE(bad);
    EXPECT_EQ(bad->status, 400);
    EXPECT_EQ(json::parse(bad->body)["status"], 400);
    wait_state(id, {"succeeded", "failed"});
    // Only result files say they take ranges, on GET and HEAD alike (httplib said `bytes` on a
    // HEAD of any route); every answer has its Date.
    for (const std::string& path : {std::string("/healthz"), "/v1/jobs/" + id}) {
        auto got = client_->Get(path);
        auto head = client_->Head(path);
        ASSERT_TRUE(got && head) << path;
        EXPECT_EQ(got->get_header_value("Accept-Ranges"), "none") << path;
        EXPECT_EQ(head->get_header_value("Accept-Ranges"), "none") << path;
        EXPECT_EQ(got->get_header_value_count("Date"), 1u) << path;
    }
    auto file = client_->Head("/v1/jobs/" + id + "/image.exr");
    ASSERT_TRUE(file);
    EXPECT_EQ(file->get_header_value("Accept-Ranges"), "bytes");
    // A Range httplib cannot read is refused before routing, on any route: a problem that says
    // nothing was done, and the server serves on.
    httplib::Client other("127.0.0.1", port_);
    auto unreadable = other.Post("/v1/jobs", httplib::Headers{{"Range", "items=0-9"}}, kSmallJob.dump(), "application/json");
    ASSERT_TRUE(unreadable);
    EXPECT_EQ(unreadable->status, 416);
    EXPECT_EQ(json::parse(unreadable->body)["type"], "/problems/invalid-range");
    EXPECT_EQ(client_->Get("/healthz")->status, 200);
}

TEST_F(Server, BadPassesAndDenoiseAreRefusedNamingTheField) {
    start();
    auto with = [](const char* key, json v) {
        json j = kSmallJob;
        j[key] = std::move(v);
        return j;
    };
    expect_problem(post_job(with("passes", "albedo")), 400, "/passes");
    expect_problem(post_job(with("passes", {"albedo", "beauty"})), 400, "/passes/1");
    expect_problem(post_job(with("passes", {"albedo", "albedo"})), 400, "/passes/1");
    expect_problem(post_job(with("passes", {1})), 400, "/passes/0");
    expect_problem(post_job(with("passes", json::array({nullptr}))), 400, "/passes/0");
    json many = json::array();
    for (size_t i = 0; i <= kAovInfo.size(); ++i) many.push_back("albedo");  // more than there are passes
    expect_problem(post_job(with("passes", many)), 400, "/passes");
    expect_problem(post_job(with("denoise", 1)), 400, "/denoise");
    expect_problem(post_job(with("denoise", "true")), 400, "/denoise");
    expect_problem(post_job(with("denoise", nullptr)), 400, "/denoise");
    json one_sample = with("denoise", true);
    one_sample["spp"] = 1;  // the denoiser compares a pixel's two halves
    expect_problem(post_job(one_sample), 400, "/denoise");
    json normals = with("denoise", true);
    normals["integrator"] = "normals";
    expect_problem(post_job(normals), 400, "/denoise");
    // Passes multiply a pixel's film: not past what the largest plain job keeps.
    json huge = with("passes", {"albedo", "normal", "depth", "position", "object_id", "material_id", "emission", "environment",
                                "diffuse_direct", "diffuse_indirect", "glossy_direct", "glossy_indirect", "variance"});
    huge["width"] = 16384;
    huge["height"] = 16384;
    huge["denoise"] = true;
    expect_problem(post_job(huge), 400, "/passes");
    // The server goes on serving.
    EXPECT_EQ(post_job(with("passes", json::array()))->status, 202);
}

TEST_F(Server, AShotsPassesAndDenoisedImagesArePerFrame) {
    start();
    const json job = {{"scene", "cornell_shot"}, {"frames", {{"start", 1}, {"end", 2}}}, {"width", 24}, {"height", 18}, {"spp", 4},
                      {"max_depth", 2}, {"passes", {"normal"}}, {"denoise", true}};
    const std::string id = submit(job);
    ASSERT_EQ(wait_state(id, {"succeeded", "failed"}, 120)["state"], "succeeded");
    const std::string base = "/v1/jobs/" + id;
    for (int f : {1, 2})
        for (const char* file : {"/denoised.png", "/denoised.exr", "/passes.exr", "/passes/normal.exr"}) {
            auto r = client_->Get(base + "/frames/" + std::to_string(f) + file);
            ASSERT_TRUE(r);
            EXPECT_EQ(r->status, 200) << f << file << r->body;
        }
    expect_problem(client_->Get(base + "/denoised.png"), 404);
    expect_problem(client_->Get(base + "/frames/1/passes/albedo.exr"), 404);
}

}  // namespace
}  // namespace tessera::server
