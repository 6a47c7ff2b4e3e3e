// What a job's status links to and what the server serves follow one rule: every file a job may
// be asked for through the API's routes (ResultFiles::routed, what server/http builds them from)
// is served exactly where its status links to it.
#include "api/result_files.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>


namespace tessera::api {
namespace {

using nlohmann::json;

std::vector<std::string> linked(const ResultFiles& r, bool frame) {
    std::vector<std::string> out;
    for (const auto& [name, file] : r.links()) {
        const bool per_frame = file.starts_with("frames/{n}/");
        if (per_frame == frame) out.push_back(per_frame ? file.substr(11) : file);
    }
    return out;
}

TEST(ResultFiles, WhatIsServedIsWhatIsLinked) {
    const json still = {{"scene", "a.gltf"}};
    const json denoising = {{"scene", "a.gltf"}, {"denoise", true}, {"passes", {"albedo", "depth"}}};
    const json shot = {{"scene", "a.gltf"}, {"frames", {{"start", 1}, {"end", 3}}}, {"denoise", true}, {"passes", {"normal"}}};
    const json comparison = {{"kind", "comparison"}, {"scene", "a.gltf"}};
    for (const json& settings : {still, denoising, shot, comparison}) {
        const ResultFiles r = ResultFiles::of(settings);
        for (bool frame : {false, true}) {
            const std::vector<std::string> links = linked(r, frame);
            for (const std::string& f : ResultFiles::routed(frame)) {
                const bool served = r.unoffered(f, frame) == Unoffered::none;
                const bool is_linked = std::find(links.begin(), links.end(), f) != links.end();
                EXPECT_EQ(served, is_linked) << settings.dump() << (frame ? " frame " : " ") << f;
            }
            const std::vector<std::string> routed = ResultFiles::routed(frame);
            for (const std::string& f : links)
                EXPECT_NE(std::find(routed.begin(), routed.end(), f), routed.end()) << "a link no route serves: " << f;
        }
    }
}

TEST(ResultFiles, SaysWhyAFileIsNeverMade) {
    const ResultFiles still = ResultFiles::of({{"scene", "a.gltf"}});
    EXPECT_EQ(still.unoffered("denoised.png", false), Unoffered::not_denoised);
    EXPECT_EQ(still.unoffered("passes.exr", false), Unoffered::no_such_pass);
    EXPECT_EQ(still.unoffered("contact_sheet.png", false), Unoffered::not_a_shot);
    EXPECT_EQ(still.unoffered("image.png", true), Unoffered::not_a_shot);
    const ResultFiles shot = ResultFiles::of({{"scene", "a.gltf"}, {"frames", {{"start", 1}, {"end", 2}}}, {"passes", {"normal"}}});
    EXPECT_EQ(shot.unoffered("image.png", false), Unoffered::per_frame);
    EXPECT_EQ(shot.unoffered("passes/normal.exr", true), Unoffered::none);
    EXPECT_EQ(shot.unoffered("passes/depth.exr", true), Unoffered::no_such_pass);
    const ResultFiles comparison = ResultFiles::of({{"kind", "comparison"}});
    EXPECT_EQ(comparison.unoffered("image.exr", false), Unoffered::not_a_render);
    EXPECT_EQ(comparison.unoffered("convergence.csv", false), Unoffered::not_a_render);
}

TEST(ResultFiles, AnEndedJobsSummaryTakesAwayWhatWasNotMade) {
    const json settings = {{"scene", "a.gltf"}, {"frames", {{"start", 1}, {"end", 2}}}, {"denoise", true}};
    auto names = [](const ResultFiles& r) {
        std::vector<std::string> n;
        for (const auto& l : r.links()) n.push_back(l.first);
        return n;
    };
    const auto before = names(ResultFiles::of(settings));
    EXPECT_NE(std::find(before.begin(), before.end(), "frame_denoised_png"), before.end());
    EXPECT_NE(std::find(before.begin(), before.end(), "preview"), before.end());
    const auto after = names(ResultFiles::of(settings, {{"denoised", false}, {"shot", {{"preview", {{"written", false}}}}}}));
    EXPECT_EQ(std::find(after.begin(), after.end(), "frame_denoised_png"), after.end());
    EXPECT_EQ(std::find(after.begin(), after.end(), "preview"), after.end());
}

}  // namespace
}  // namespace tessera::api
