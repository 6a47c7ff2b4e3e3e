// `tessera bench denoise`: the denoiser against the truth. Per scene: a reference of --ref-spp
// samples (its own seed), then renders at 4 … 1024 spp that denoise; the true relMSE of the
// noisy and the denoised image, the estimates beside them, also over the pixels at edges and in
// textures alone (found from the reference's albedo, normal and depth), the denoiser's time, and
// the time the denoised render needs to reach the error of the largest undenoised spp (a uniform
// render without the denoiser; the denoising renders are guided, as a job's are by default, or
// uniform with --uniform). Errors against the reference have the reference's own taken off.
// --until-reached renders that baseline first and stops at the first denoised render reaching it.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>

#include "api/job_runner.h"
#include "cli/bench_common.h"
#include "cli/command_line.h"
#include "cli/detail_mask.h"
#include "engine/io/image_io.h"
#include "engine/io/scene_loader.h"
#include "engine/render/film.h"
#include "engine/render/renderer.h"

namespace tessera::cli {

using server::parse_args;

namespace {

struct BenchScene {
    std::string label, source, environment;
};

const AovPlane* plane_of(const std::vector<AovPlane>& planes, Aov a) {
    for (const AovPlane& p : planes)
        if (p.aov == a) return &p;
    return nullptr;
}

// The edges and texture detail of the reference (detail_mask.h).
std::vector<uint8_t> reference_detail_mask(const RenderResult& ref, int w, int h) {
    const AovPlane* n = plane_of(ref.aovs, Aov::normal);
    const AovPlane* z = plane_of(ref.aovs, Aov::depth);
    const AovPlane* a = plane_of(ref.aovs, Aov::albedo);
    if (!n || !z || !a) return std::vector<uint8_t>(size_t(w) * h, 0);
    return detail_mask(n->values.data(), z->values.data(), a->values.data(), w, h);
}

double masked_rel_mse(const Image& img, const Image& ref, const std::vector<uint8_t>& mask) {
    double s = 0;
    size_t n = 0;
    for (size_t p = 0; p < mask.size(); ++p) {
        if (!mask[p]) continue;
        for (int k = 0; k < 3; ++k) {
            const double r = ref.rgb[p * 3 + k], d = double(img.rgb[p * 3 + k]) - r;
            s += d * d / (r * r + 0.01);
        }
        n += 3;
    }
    return n ? s / double(n) : 0.0;
}

// Each candidate's true relMSE over the image, the edges and elsewhere, and its variance from its
// own two halves (what the true error has beyond it is bias and the reference's own error); the
// blended image's; and a per-pixel choice by the true error (optimistic: it also picks whichever
// candidate's noise happens to land nearest the truth).
void print_candidates(const DenoiseCandidates& c, const Image& ref, const Image& chosen, const std::vector<uint8_t>& edges,
                      const std::vector<uint8_t>& rest) {
    const size_t n = c.taken.size();
    auto err = [&](const float* v, size_t p) {
        double s = 0;
        for (int k = 0; k < 3; ++k) {
            const double r = ref.rgb[p * 3 + k], d = double(v[p * 3 + k]) - r;
            s += d * d / (r * r + 0.01);
        }
        return s / 3.0;
    };
    struct Sums {
        double all = 0, edge = 0, else_ = 0;
    };
    const double ne = double(std::count(edges.begin(), edges.end(), 1)), nr = double(std::count(rest.begin(), rest.end(), 1));
    auto means = [&](const Sums& s) {
        return std::array<double, 3>{s.all / double(n), ne ? s.edge / ne : 0.0, nr ? s.else_ / nr : 0.0};
    };
    auto line = [&](const char* name, const Sums& s) {
        const auto m = means(s);
        std::printf(" %s %.3g (edges %.3g, elsewhere %.3g);", name, m[0], m[1], m[2]);
    };
    std::vector<double> best(n, 1e300);
    std::array<size_t, kDenoiseCandidates.size()> took{};
    std::printf("  candidates:");
    for (size_t k = 0; k < c.rgb.size(); ++k) {
        Sums s;
        for (size_t p = 0; p < n; ++p) {
            const double e = err(c.rgb[k].data(), p);
            best[p] = std::min(best[p], e);
            s.all += e;
            if (edges[p]) s.edge += e;
            else if (rest[p]) s.else_ += e;
        }
        // Its variance, (f(A) − f(B))²/4, relative as the error is.
        Sums v;
        for (size_t p = 0; p < n; ++p) {
            double e = 0;
            for (int j = 0; j < 3; ++j) {
                const double r = ref.rgb[p * 3 + j], g = c.half_gap[k][p * 3 + j];
                e += g * g / (r * r + 0.01);
            }
            e /= 3.0;
            v.all += e;
            if (edges[p]) v.edge += e;
            else if (rest[p]) v.else_ += e;
        }
        const auto m = means(s), mv = means(v);
        std::printf(" %s %.3g (edges %.3g, elsewhere %.3g), variance by its halves %.3g (%.3g, %.3g);", kDenoiseCandidates[k].name, m[0],
                    m[1], m[2], mv[0], mv[1], mv[2]);
    }
    Sums chosen_s, oracle;
    for (size_t p = 0; p < n; ++p) {
        const double e = err(chosen.rgb.data(), p);
        chosen_s.all += e;
        oracle.all += best[p];
        if (edges[p]) { chosen_s.edge += e; oracle.edge += best[p]; }
        else if (rest[p]) { chosen_s.else_ += e; oracle.else_ += best[p]; ++took[c.taken[p]]; }
    }
    line("blended", chosen_s);
    line("per-pixel oracle", oracle);
    std::printf(" leading the blend elsewhere:");
    for (size_t k = 0; k < took.size(); ++k) std::printf(" %.2f", nr ? double(took[k]) / nr : 0.0);
    std::printf("\n");
}

}  // namespace

int bench_denoise(int argc, char** argv) {
    std::string cs184 = default_cs184_dir(), gltf = default_gltf_pbr_dir(), figures, only;
    std::string sky = std::string(TESSERA_DEFAULT_SCENES_DIR) + "/sky.exr";
    std::pair<int, int> size{160, 120};
    int ref_spp = 16384, max_spp = 1024, depth = 5;
    CLI::App app{"The denoiser against a converged reference: true and estimated relMSE of the noisy and denoised images "
                 "at 4-1024 spp, over the image and at edges and textures, denoise time, and the time to the error of "
                 "1024 undenoised spp.", "bench denoise"};
    app.option_defaults()->always_capture_default();
    app.add_option("-r", size, "image width and height")->type_name("W H")->check(CLI::Range(16, 4096));
    app.add_option("--ref-spp", ref_spp, "samples per pixel of each reference")->check(CLI::Range(16, 1 << 20));
    app.add_option("--max-spp", max_spp, "the largest spp rendered (a power of two)")->check(CLI::Range(4, 1 << 16));
    app.add_option("--depth", depth, "maximum bounce depth")->check(CLI::Range(1, 100));
    app.add_option("--figures", figures, "write each scene's noisy, denoised and reference images here")->type_name("DIR");
    bool show_candidates = false, uniform = false, until_reached = false;
    app.add_flag("--uniform", uniform, "renders that denoise sample every pixel alike (guided_sampling false)");
    app.add_flag("--until-reached", until_reached,
                 "render the undenoised --max-spp baseline first and stop the denoising renders at the first whose error is "
                 "at or below it (the time ratio alone, for about half the run's time; the larger counts are not rendered)");
    app.add_flag("--candidates", show_candidates,
                 "after each row, each candidate's true relMSE (whole image, edges and textures, elsewhere) and its variance by its "
                 "two halves, the blended image's relMSE, and that of a per-pixel choice by the true error (an oracle: what a "
                 "perfect choice among these candidates reaches)");
    int seed = 1;
    app.add_option("--seed", seed, "the renders' seed (the references' is 7): two seeds' images differ by the noise alone, "
                                   "so their difference measures a candidate's variance without its halves")
        ->check(CLI::Range(0, 1 << 30));
    app.add_option("--scene", only, "only the scene whose label contains this")->type_name("TEXT");
    app.add_option("--cs184", cs184, "the CS184 scene folder")->type_name("DIR");
    app.add_option("--gltf-pbr", gltf, "the glTF sample models folder")->type_name("DIR");
    if (const auto status = parse_args(app, argc, argv)) return *status;
    if (seed == 7) {
        std::fprintf(stderr, "tessera bench denoise: --seed: 7 is the references' seed: the renders would repeat their samples\n");
        return 2;
    }
    const std::vector<BenchScene> scenes = {
        {"diffuse Cornell box (CBspheres_lambertian)", cs184 + "/sky/CBspheres_lambertian.dae", ""},
        {"glossy Cornell box (CBspheres_glossy)", cs184 + "/sky/CBspheres_glossy.dae", ""},
        {"textured model under an environment map (Duck)", gltf + "/Duck.gltf", sky},
        {"1,000-lamp room (builtin:lamp_room)", "builtin:lamp_room", ""},
    };
    const int W = size.first, H = size.second;
    std::printf("denoiser: %dx%d, depth %d, MIS, references of %d spp (seed 7), renders seed %d, %u threads\n\n", W, H, depth, ref_spp,
                seed, std::max(1u, std::thread::hardware_concurrency()));
    bool all_better = true, all_tracked = true;
    for (const BenchScene& bs : scenes) {
        if (!only.empty() && bs.label.find(only) == std::string::npos) continue;
        if (bs.source.rfind("builtin:", 0) != 0 && !std::filesystem::exists(bs.source)) {
            std::printf("## %s\nskipped: %s is absent\n\n", bs.label.c_str(), bs.source.c_str());
            continue;
        }
        SceneDescription desc = load_scene(bs.source);
        // The whole scene in view: the CS184 convention fixes the focal length for 800×600, which
        // crops a small image to the middle of the box (a flat wall, nothing to denoise).
        if (desc.camera) desc.camera->focal_px = 0.f;
        const RenderScene scene = build_render_scene(desc, {});
        RenderSettings base;
        base.width = W;
        base.height = H;
        base.max_depth = depth;
        if (!bs.environment.empty()) base.environment = api::load_environment(bs.environment);
        base = api::lit_settings(base, scene);
        RenderSettings rs = base;
        rs.spp = ref_spp;
        rs.seed = 7;
        rs.estimate_error = true;  // its own error, which adds to every error measured against it
        rs.aovs = aov_bit(Aov::albedo) | aov_bit(Aov::normal) | aov_bit(Aov::depth) | aov_bit(Aov::emission) | aov_bit(Aov::environment);
        const RenderResult ref = render(scene, rs);
        const std::vector<uint8_t> mask = reference_detail_mask(ref, W, H);
        // Elsewhere: the other pixels that saw a surface (the sky and a black void have nothing to denoise).
        std::vector<uint8_t> rest(mask.size(), 0);
        if (const AovPlane* z = plane_of(ref.aovs, Aov::depth))
            for (size_t p = 0; p < rest.size(); ++p) rest[p] = !mask[p] && z->values[p] < kNoDepth / 2;
        // Pixels whose reference sees a lamp or the sky (at all): their error is mostly coverage
        // (how much of the pixel the light fills), which no filter lowers and which a pixel whose
        // samples all missed the light cannot see in itself.
        std::vector<uint8_t> lit(mask.size(), 0);
        for (Aov a : {Aov::emission, Aov::environment})
            if (const AovPlane* e = plane_of(ref.aovs, a))
                for (size_t p = 0; p < lit.size(); ++p) lit[p] |= e->values[p * 3] + e->values[p * 3 + 1] + e->values[p * 3 + 2] > 0.f;
        const double lit_share = double(std::count(lit.begin(), lit.end(), 1)) / double(lit.size());
        const double mask_share = double(std::count(mask.begin(), mask.end(), 1)) / double(mask.size());
        const double ref_err = ref.curve.points.empty() ? 0.0 : std::max(0.0, ref.curve.points.back().est_rel_mse);
        // relMSE against the reference less the reference's own (independent of the render's).
        auto true_error = [&](const Image& img) { return std::max(1e-12, relative_mse(img, ref.image) - ref_err); };
        std::printf("## %s\nreference: %d spp in %.1f s, its own estimated relMSE %.3g (taken off every whole-image error "
                    "below); edges and textures: %.1f%% of the pixels\n\n",
                    bs.label.c_str(), ref_spp, ref.stats.render_seconds, ref_err, 100 * mask_share);
        std::printf("| spp | render (s) | denoise (s) | relMSE noisy | estimate | relMSE denoised | its estimate | estimate/true | "
                    "edges+textures noisy | denoised | elsewhere noisy | denoised | left as they are: pixels, share of the error | "
                    "seeing a light: pixels, share of the error |\n|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
        struct Row { int spp; double render_s, denoise_s, denoise_all_s, noisy, denoised; };
        std::vector<Row> rows;
        // The baseline: uniform sampling, no denoiser, at the largest count.
        auto render_baseline = [&] {
            RenderSettings s = base;
            s.spp = max_spp;
            s.seed = seed;
            const RenderResult r = render(scene, s);
            return Row{max_spp, r.stats.render_seconds, 0.0, 0.0, true_error(r.image), 0.0};
        };
        std::optional<Row> baseline;
        if (until_reached) baseline = render_baseline();
        for (int spp = 4; spp <= max_spp; spp *= 2) {
            RenderSettings s = base;
            s.spp = spp;
            s.seed = seed;
            s.denoise = true;
            s.guided = !uniform;
            // Denoised after every pass, as a job does; the render's own time is without them.
            // --candidates: the last pass's film denoised once more, keeping every candidate.
            DenoiseCandidates cands;
            RenderCallbacks calls;
            if (show_candidates)
                calls.on_pass = [&](const PassView& v) {
                    if (v.spp >= spp) denoise(v.film, 0, &cands);
                };
            const RenderResult r = render(scene, s, calls);
            if (!r.denoised || r.curve.points.empty()) continue;
            const Denoised* d = r.denoised.get();
            double denoising = 0;
            for (const ConvergencePoint& p : r.curve.points) denoising += p.denoise_seconds;
            const double render_s = r.stats.render_seconds - denoising;
            const double noisy = true_error(r.image), dn = true_error(d->image);
            const double est_noisy = r.curve.points.empty() ? -1 : r.curve.points.back().est_rel_mse;
            const double edge_noisy = masked_rel_mse(r.image, ref.image, mask), edge_dn = masked_rel_mse(d->image, ref.image, mask);
            const double rest_noisy = masked_rel_mse(r.image, ref.image, rest), rest_dn = masked_rel_mse(d->image, ref.image, rest);
            const double ratio = d->est_rel_mse / dn;
            // The pixels the denoiser left as they are (that saw a lamp or the sky in part, or
            // where no candidate may touch them) and their share of the denoised image's error:
            // what no filter of these candidates can lower.
            std::vector<uint8_t> kept(mask.size(), 0);
            for (size_t p = 0; p < kept.size(); ++p)
                kept[p] = r.image.rgb[p * 3] == d->image.rgb[p * 3] && r.image.rgb[p * 3 + 1] == d->image.rgb[p * 3 + 1] &&
                          r.image.rgb[p * 3 + 2] == d->image.rgb[p * 3 + 2];
            const double kept_share = double(std::count(kept.begin(), kept.end(), 1)) / double(kept.size());
            // Shares of the error against the reference as it is, as the regions' own errors are.
            const double dn_as_is = relative_mse(d->image, ref.image);
            const double kept_error = dn_as_is > 0 ? masked_rel_mse(d->image, ref.image, kept) * kept_share / dn_as_is : 0.0;
            const double lit_error = dn_as_is > 0 ? masked_rel_mse(d->image, ref.image, lit) * lit_share / dn_as_is : 0.0;
            std::printf("| %d | %.3f | %.3f | %.4g | %.4g | %.4g | %.4g | %.2f | %.4g | %.4g | %.4g | %.4g | %.2f, %.2f | %.3f, %.2f |\n",
                        spp, render_s, d->seconds, noisy, est_noisy, dn, d->est_rel_mse, ratio, edge_noisy, edge_dn, rest_noisy, rest_dn,
                        kept_share, kept_error, lit_share, lit_error);
            if (show_candidates && !cands.taken.empty()) print_candidates(cands, ref.image, d->image, mask, rest);
            all_better = all_better && dn < noisy && edge_dn < edge_noisy;
            all_tracked = all_tracked && ratio >= 0.5 && ratio <= 2.0;
            rows.push_back({spp, render_s, d->seconds, denoising, noisy, dn});
            if (!figures.empty() && (spp == 16 || spp == max_spp)) {
                std::filesystem::create_directories(figures);
                std::string stem = bs.source.substr(bs.source.find_last_of("/:") + 1);
                stem = stem.substr(0, stem.find('.'));
                write_png(figures + "/denoise_" + stem + "_" + std::to_string(spp) + "spp_noisy.png", r.image);
                write_png(figures + "/denoise_" + stem + "_" + std::to_string(spp) + "spp_denoised.png", d->image);
                if (spp == max_spp) write_png(figures + "/denoise_" + stem + "_reference.png", ref.image);
            }
            if (baseline && dn <= baseline->noisy) {
                if (spp < max_spp) std::printf("| (%d-%d: not rendered, --until-reached) |\n", spp * 2, max_spp);
                break;
            }
        }
        if (!rows.empty()) {
            Row top = rows.back();
            if (baseline) top = *baseline;
            else if (!uniform) top = render_baseline();
            // The first denoised row at or below that error, and the time to it interpolated in
            // log-log from the row before (error falls about as a power of the time). The time is
            // the render's and every pass's denoising: a job denoises after each, and guided
            // sampling needs each.
            const Row* reach = nullptr;
            const Row* before = nullptr;
            for (const Row& r : rows) {
                if (r.denoised <= top.noisy) { reach = &r; break; }
                before = &r;
            }
            if (reach) {
                const double t1 = reach->render_s + reach->denoise_all_s;
                double t = t1;
                if (before && before->denoised > reach->denoised && reach->denoised > 0) {
                    const double t0 = before->render_s + before->denoise_all_s;
                    const double f = std::log(top.noisy / before->denoised) / std::log(reach->denoised / before->denoised);
                    t = std::exp(std::log(t0) + f * (std::log(t1) - std::log(t0)));
                }
                std::printf("\nthe error of %d undenoised spp (%.4g, %.3f s) is reached denoised by %d spp (%.3f s; "
                            "%.3f s interpolated from %d spp): %.3f of the time\n\n",
                            top.spp, top.noisy, top.render_s, reach->spp, t1, t, before ? before->spp : reach->spp, t / top.render_s);
            } else {
                std::printf("\nno denoised render reached the error of %d undenoised spp\n\n", top.spp);
            }
        }
    }
    std::printf("denoised below noisy everywhere (image, edges and textures): %s; denoised estimate within 0.5-2x of the truth everywhere: %s%s\n",
                all_better ? "yes" : "NO", all_tracked ? "yes" : "NO",
                until_reached ? " (over the rows rendered: --until-reached left the larger counts out)" : "");
    return 0;
}

}  // namespace tessera::cli
