// `tessera bench figures`: regenerates the write-ups' comparisons (direct-lighting strategies
// against light rays, bounce depths, samples per pixel, uniform against adaptive sampling)
// as images and one Markdown table with times and sample rates.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "engine/io/image_io.h"
#include "engine/io/scene_loader.h"
#include "engine/render/renderer.h"
#include "cli/bench_common.h"
#include "cli/command_line.h"

namespace tessera::cli {

using server::parse_args;
namespace {

struct Figure {
    std::string group, label, file;
    double seconds;
    uint64_t samples, rays;
    double mean;      // mean linear radiance over pixels and channels
    double mean_spp;
};

double image_mean(const Image& img) {
    double s = 0;
    for (float v : img.rgb) s += v;
    return s / double(img.rgb.size());
}

const char* strategy_name(DirectLighting d) {
    return d == DirectLighting::hemisphere ? "hemisphere" : d == DirectLighting::importance ? "importance" : "mis";
}

}  // namespace

int bench_figures(int argc, char** argv) {
    std::string cs184 = default_cs184_dir(), out = "docs/figures";
    std::pair<int, int> size{320, 240};
    int depth_spp = 64, max_spp = 1024;
    CLI::App app{"The write-ups' comparisons (direct-lighting strategies against light rays, bounce depths, samples "
                 "per pixel, uniform against adaptive sampling) as images and one Markdown table.", "bench figures"};
    app.option_defaults()->always_capture_default();
    app.add_option("--cs184", cs184, "the CS184 scene folder")->type_name("DIR");
    app.add_option("--out", out, "folder for the images and README.md")->type_name("DIR");
    app.add_option("-r", size, "image width and height (320 240)")->type_name("W H")->check(CLI::Range(8, 4096));
    app.add_option("--depth-spp", depth_spp, "samples per pixel of the bounce-depth figures")->check(CLI::Range(1, 1 << 16));
    app.add_option("--max-spp", max_spp, "the largest samples per pixel of the spp series, and the budget of uniform "
                                         "against adaptive")
        ->check(CLI::Range(1, 1 << 16));
    if (const auto status = parse_args(app, argc, argv)) return *status;
    const int width = size.first, height = size.second;
    std::filesystem::create_directories(out);
    std::ofstream md(out + "/README.md");
    md << "# Figures\n\nMade by `tessera bench figures --out " << out << " -r " << width << " " << height << " --depth-spp "
       << depth_spp << " --max-spp " << max_spp << "` (Release build, all threads of this 2-core machine). "
       << "\"mean\" is the mean linear radiance of the image: estimators of the same integral agree on it "
       << "up to noise.\n";
    for (const char* scene_file : {"sky/CBspheres_lambertian.dae", "sky/CBbunny.dae"}) {
        const std::string path = cs184 + "/" + scene_file;
        if (!std::filesystem::exists(path)) {
            std::fprintf(stderr, "tessera bench: %s not found (pass --cs184 DIR); skipping it\n", path.c_str());
            continue;
        }
        const std::string name = std::filesystem::path(scene_file).stem().string();
        const RenderScene scene = build_render_scene(load_scene(path), RenderSceneOptions{});
        std::vector<Figure> figs;
        auto run = [&](const std::string& group, const std::string& label, RenderSettings st) {
            st.width = width;
            st.height = height;
            const RenderResult r = render(scene, st);
            const std::string file = name + "_" + label + ".jpg";
            write_png(out + "/" + file, r.image);
            double spp = double(r.stats.samples) / (double(width) * height);
            if (st.adaptive) write_rate_png(out + "/" + name + "_" + label + "_rate.png", r.image, st.spp);
            figs.push_back({group, label, file, r.stats.render_seconds, r.stats.samples, r.stats.rays(), image_mean(r.image), spp});
            std::fprintf(stderr, "%s %s: %.2f s\n", name.c_str(), label.c_str(), r.stats.render_seconds);
        };
        // 1. Direct lighting: strategy × light rays, 1 spp, depth 1 (the write-ups' Part 3).
        for (DirectLighting d : {DirectLighting::hemisphere, DirectLighting::importance, DirectLighting::mis}) {
            for (int l : {1, 4, 16, 64}) {
                RenderSettings st;
                st.spp = 1;
                st.light_rays = l;
                st.max_depth = 1;
                st.direct = d;
                run("direct lighting, 1 spp, depth 1", std::string(strategy_name(d)) + "_l" + std::to_string(l), st);
            }
        }
        // 2. Bounce depth 0..5, accumulated and n-th bounce only (Part 4).
        for (BounceMode b : {BounceMode::accumulate, BounceMode::nth}) {
            for (int m = 0; m <= 5; ++m) {
                RenderSettings st;
                st.spp = depth_spp;
                st.light_rays = 4;
                st.max_depth = m;
                st.bounces = b;
                run(std::string(b == BounceMode::accumulate ? "accumulated" : "n-th bounce only") + ", " +
                        std::to_string(depth_spp) + " spp, 4 light rays",
                    std::string(b == BounceMode::accumulate ? "acc" : "nth") + "_m" + std::to_string(m), st);
            }
        }
        // 3. Samples per pixel (Part 4), 4 light rays, depth 5.
        for (int spp : {1, 2, 4, 8, 16, 64, 256, 1024}) {
            if (spp > max_spp) break;
            RenderSettings st;
            st.spp = spp;
            st.light_rays = 4;
            st.max_depth = 5;
            run("samples per pixel, 4 light rays, depth 5", "spp" + std::to_string(spp), st);
        }
        // 4. Uniform against adaptive sampling (Part 5: -s max -a 64 0.05 -l 1 -m 5).
        for (bool adaptive : {false, true}) {
            RenderSettings st;
            st.spp = max_spp;
            st.light_rays = 1;
            st.max_depth = 5;
            if (adaptive) st.adaptive = AdaptiveSettings{64, 0.05f};
            run("uniform against adaptive, " + std::to_string(max_spp) + " spp max, 1 light ray, depth 5",
                adaptive ? "adaptive" : "uniform", st);
        }
        md << "\n## " << name << " (" << width << "×" << height << ")\n";
        std::string group;
        for (const Figure& f : figs) {
            if (f.group != group) {
                group = f.group;
                md << "\n### " << group << "\n\n| run | image | time (s) | spp (mean) | samples/s | Mrays/s | mean |\n|---|---|---:|---:|---:|---:|---:|\n";
            }
            char line[512];
            std::snprintf(line, sizeof line, "| %s | [%s](%s) | %.3f | %.1f | %.3g | %.2f | %.4f |\n", f.label.c_str(), f.file.c_str(),
                          f.file.c_str(), f.seconds, f.mean_spp, double(f.samples) / f.seconds, double(f.rays) / f.seconds * 1e-6, f.mean);
            md << line;
            if (f.label == "adaptive") md << "\nSample-rate map: [" << name << "_adaptive_rate.png](" << name << "_adaptive_rate.png)\n";
        }
    }
    std::printf("wrote %s/README.md\n", out.c_str());
    return 0;
}

}  // namespace tessera::cli
