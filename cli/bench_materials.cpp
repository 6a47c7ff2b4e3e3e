// `tessera bench materials`: the energy each BSDF keeps (directional albedo of white materials,
// against glTF's sample formula), and the CS184 material scenes rendered with their time.
#include "build_paths.h"
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "engine/io/image_io.h"
#include "engine/io/scene_loader.h"
#include "engine/material/bsdf.h"
#include "engine/render/renderer.h"
#include "engine/scene/environment.h"
#include "engine/sampling/rng.h"
#include "cli/bench_common.h"
#include "cli/command_line.h"

namespace tessera::cli {

using server::parse_args;
namespace {

constexpr float kAngles[] = {0.f, 30.f, 60.f, 75.f, 85.f};
constexpr float kRoughness[] = {0.1f, 0.3f, 0.5f, 0.7f, 1.f};

glm::vec3 at_angle(float deg) {
    const float t = deg * kPi / 180.f;
    return {std::sin(t), 0.f, std::cos(t)};
}

// ∫ f·cos dωi, the mean sample weight (first channel).
double albedo(const Bsdf& b, const glm::vec3& wo, int n) {
    Pcg32 rng(7, 1);
    double sum = 0;
    for (int i = 0; i < n; ++i) {
        BsdfSample s;
        const float uc = rng.next_float();
        if (bsdf_sample(b, wo, uc, {rng.next_float(), rng.next_float()}, s)) sum += s.weight.x;
    }
    return sum / n;
}

// glTF's Appendix B sample formula for a white dielectric, f_spec + (1 − F(v·h))/π, integrated
// by the same BSDF's sampling (same lobes, same densities).
double gltf_sample_formula_albedo(const Bsdf& b, const glm::vec3& wo, int n) {
    Pcg32 rng(7, 1);
    double sum = 0;
    const float alpha = std::max(b.alpha, kMinAlpha);
    for (int i = 0; i < n; ++i) {
        BsdfSample s;
        const float uc = rng.next_float();
        if (!bsdf_sample(b, wo, uc, {rng.next_float(), rng.next_float()}, s)) continue;
        const glm::vec3 h = glm::normalize(wo + s.wi);
        const float vh = std::max(0.f, glm::dot(wo, h));
        const float F = fresnel_schlick(glm::vec3(0.04f), vh).x;
        const float g = 1.f / (1.f + ggx_lambda(wo, alpha) + ggx_lambda(s.wi, alpha));
        const float f = F * ggx_d(h, alpha) * g / (4.f * wo.z * s.wi.z) + (1.f - F) * kInvPi;
        sum += f * s.wi.z / bsdf_pdf(b, wo, s.wi);
    }
    return sum / n;
}

void energy_table(int n) {
    std::printf("Directional albedo of white BSDFs, ∫ f·cos dωi (%d samples each; 1 = nothing lost)\n\n", n);
    std::printf("| BSDF | roughness | 0° | 30° | 60° | 75° | 85° |\n|---|---:|---:|---:|---:|---:|---:|\n");
    for (int model = 0; model < 4; ++model) {
        for (float r : kRoughness) {
            Bsdf b;
            const char* label = "";
            if (model == 0) {
                b.kind = BsdfKind::conductor;  // F = 1: k → ∞
                b.alpha = r * r;
                b.eta = glm::vec3(1.f);
                b.k = glm::vec3(1e4f);
                label = "Beckmann conductor, F = 1 (α = roughness²)";
            } else {
                b.kind = BsdfKind::metallic_roughness;
                b.albedo = glm::vec3(1.f);
                b.alpha = r * r;
                b.metallic = model == 1 ? 1.f : 0.f;
                label = model == 1 ? "glTF metal, white" : model == 2 ? "glTF dielectric, white (ours)" : "glTF dielectric, white (Appendix B sample formula)";
            }
            std::printf("| %s | %.1f |", label, r);
            for (float a : kAngles) std::printf(" %.3f |", model == 3 ? gltf_sample_formula_albedo(b, at_angle(a), n) : albedo(b, at_angle(a), n));
            std::printf("\n");
        }
    }
    // Glass: the Fresnel split, sampled, keeps everything (η² undone).
    Bsdf g;
    g.kind = BsdfKind::glass;
    g.albedo = g.transmittance = glm::vec3(1.f);
    std::printf("\nGlass (ior 1.5, white): reflected + transmitted (× η²)");
    for (float a : kAngles) {
        Pcg32 rng(3, 3);
        double e = 0;
        for (int i = 0; i < n; ++i) {
            BsdfSample s;
            if (bsdf_sample(g, at_angle(a), rng.next_float(), {0.f, 0.f}, s)) e += s.wi.z > 0 ? s.weight.x : s.weight.x * 2.25;
        }
        std::printf(" %.0f°: %.4f", a, e / n);
    }
    std::printf("\n\n");
}

// Each glTF sample model under the environment map (the models have no lights), with the
// time of each stage and what the loader warned of.
void gltf_pbr_renders(const std::string& dir, const std::string& env_path, const std::string& out, const RenderSettings& base) {
    std::vector<std::filesystem::path> files;
    for (const auto& e : std::filesystem::directory_iterator(dir))
        if (e.path().extension() == ".gltf" || e.path().extension() == ".glb") files.push_back(e.path());
    std::sort(files.begin(), files.end());
    RenderSettings st = base;
    const Image sky = read_image(env_path);
    st.environment = std::make_shared<const EnvironmentMap>(build_environment(sky.width, sky.height, sky.rgb, env_path));
    std::printf("glTF sample models (%s), %dx%d, %d spp, %d light rays, max depth %d, MIS, lit by %s\n\n", dir.c_str(),
                st.width, st.height, st.spp, st.light_rays, st.max_depth, std::filesystem::path(env_path).filename().c_str());
    std::printf("| model | triangles | textures / images (KiB) | load (s) | build (s) | render (s) | vertex attributes | warnings |\n"
                "|---|---:|---:|---:|---:|---:|---|---|\n");
    for (const auto& f : files) {
        const auto t0 = std::chrono::steady_clock::now();
        const SceneDescription d = load_scene(f.string());
        const double load_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const RenderScene rs = build_render_scene(d, {});
        const RenderResult r = render(rs, st);
        size_t kib = 0;
        for (const auto& img : d.images) kib += img->rgba.size() >> 10;
        std::string built, warnings;
        for (const std::string& b : rs.report.built) {
            if (b.rfind("vertex attributes: ", 0) == 0) built += (built.empty() ? "" : "; ") + b.substr(19);
            if (b.rfind("alpha", 0) == 0) built += (built.empty() ? "" : "; ") + std::string("alpha tests");
        }
        // The environment lights these scenes: the loader's "no lights" is not this render's.
        for (const std::string& w : d.warnings)
            if (w.find("no lights") == std::string::npos) warnings += (warnings.empty() ? "" : "; ") + w;
        std::printf("| %s | %zu | %zu / %zu (%zu) | %.2f | %.3f | %.2f | %s | %s |\n", f.stem().c_str(), d.triangle_count(),
                    rs.textures.size(), d.images.size(), kib, load_s, rs.report.seconds, r.stats.render_seconds, built.c_str(),
                    warnings.c_str());
        if (r.stats.nonfinite_samples) std::printf("  (%llu non-finite samples dropped)\n", (unsigned long long)r.stats.nonfinite_samples);
        if (!out.empty()) {
            std::filesystem::create_directories(out + "/gltf-pbr");
            write_png(out + "/gltf-pbr/" + f.stem().string() + ".jpg", r.image);
        }
    }
}

}  // namespace

int bench_materials(int argc, char** argv) {
    std::string cs184 = default_cs184_dir();
    std::string gltf_pbr = default_gltf_pbr_dir();
    std::string environment = std::string(TESSERA_DEFAULT_SCENES_DIR) + "/sky.exr";
    std::string out;
    int samples = 200000, spp = 64, width = 480, height = 360, threads = 0;
    CLI::App app{"The energy each BSDF keeps, and the CS184 material scenes rendered (MIS, depth 5) with their time.",
                 "bench materials"};
    app.add_option("--cs184", cs184, "the CS184 scenes folder");
    app.add_option("--gltf-pbr", gltf_pbr, "the glTF sample models folder (rendered under --environment)");
    app.add_option("--environment", environment, "the environment map that lights the glTF models");
    app.add_option("--out", out, "write each scene's image here as PNG (none: no files)");
    app.add_option("--samples", samples, "BSDF samples per cell of the energy table")->check(CLI::Range(1000, 100000000));
    app.add_option("--spp", spp, "samples per pixel of the scene renders (0: table only)")->check(CLI::Range(0, 65536));
    app.add_option("--width", width, "render width")->check(CLI::Range(8, 4096));
    app.add_option("--height", height, "render height")->check(CLI::Range(8, 4096));
    app.add_option("-t,--threads", threads, "render threads (0: all cores)")->check(CLI::Range(0, 1024));
    if (const auto status = parse_args(app, argc, argv)) return *status;
    energy_table(samples);
    if (spp == 0) return 0;
    if (std::filesystem::is_directory(gltf_pbr)) {
        RenderSettings st;
        st.width = width;
        st.height = height;
        st.spp = spp;
        st.light_rays = 1;
        st.max_depth = 5;
        st.direct = DirectLighting::mis;
        st.threads = threads;
        gltf_pbr_renders(gltf_pbr, environment, out, st);
        std::printf("\n");
    } else {
        std::printf("glTF sample models not found at %s: their renders are skipped\n", gltf_pbr.c_str());
    }
    if (!std::filesystem::is_directory(cs184)) {
        std::printf("CS184 scenes not found at %s: scene renders skipped\n", cs184.c_str());
        return 0;
    }
    std::printf("CS184 material scenes, %dx%d, %d spp, 4 light rays, max depth 5, MIS\n\n", width, height, spp);
    std::printf("| scene | materials | render (s) | Msamples/s | mean radiance | warnings |\n|---|---|---:|---:|---:|---:|\n");
    for (const char* name : {"CBspheres", "CBspheres_microfacet_al_ag", "CBspheres_glossy", "CBgems", "CBcoil",
                             "CBbunny_microfacet_cu", "CBspheres_lambertian", "CBbunny"}) {
        const SceneDescription d = load_scene(cs184 + "/sky/" + name + ".dae");
        const RenderScene rs = build_render_scene(d, {});
        RenderSettings st;
        st.width = width;
        st.height = height;
        st.spp = spp;
        st.light_rays = 4;
        st.max_depth = 5;
        st.direct = DirectLighting::mis;
        st.threads = threads;
        const RenderResult r = render(rs, st);
        double mean = 0;
        for (float v : r.image.rgb) mean += v;
        mean /= double(r.image.rgb.size());
        std::string materials;
        for (const std::string& b : rs.report.built)
            if (b.rfind("materials: ", 0) == 0) materials = b.substr(11);
        std::printf("| %s | %s | %.2f | %.2f | %.4f | %zu |\n", name, materials.c_str(), r.stats.render_seconds,
                    double(width) * height * spp / r.stats.render_seconds * 1e-6, mean, d.warnings.size());
        if (!out.empty()) {
            std::filesystem::create_directories(out);
            write_image(out + "/" + name + ".png", r.image);
        }
    }
    return 0;
}

}  // namespace tessera::cli
