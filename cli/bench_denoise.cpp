// `tessera bench denoise`: the denoiser against the truth. Per scene: a reference of --ref-spp
// samples (its own seed), then renders at 4 … 1024 spp that denoise; the true relMSE of the
// noisy and the denoised image, the estimates beside them, also over the pixels at edges and in
// textures alone (found from the reference's albedo, normal and depth), the denoiser's time, and
// the time the denoised render needs to reach the error of the largest undenoised spp (a uniform
// render without the denoiser; the denoising renders are guided, as a job's are by default, or
// uniform with --uniform). Errors against the reference have the reference's own taken off, known per
// pixel from its two independent halves. --regions splits the error by what decides it (lamps and
// sky seen directly, their neighbours, edges and textures, other surfaces); --exr writes every
// image measured, so that anyone can cut it otherwise.
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

// The reference's own squared error, per pixel and relative as every error here: it is rendered
// as a denoising render is, its even and odd samples from two scrambles of their own, so the two
// halves' means A and B are independent and (A − B)²/4 is an unbiased estimate of the squared
// error of their mean, the image (whatever the samples' stratification, which an estimate from
// one net's sample variance would miss).
// `squared`, where given: each channel's own (A − B)²/4, absolute (the EXR's layer of it).
std::vector<double> half_gap_error(const Film& film, std::vector<float>* squared = nullptr) {
    const size_t n = size_t(film.width) * film.height;
    std::vector<double> e(n, 0.0);
    if (squared) squared->assign(n * 3, 0.f);
    if (film.sum_odd.size() != n) return e;
    for (size_t p = 0; p < n; ++p) {
        const uint32_t c = film.count[p], odd = c / 2, even = c - odd;
        if (odd == 0) continue;
        const glm::dvec3 a = film.sum_odd[p] / double(odd), b = (film.sum[p] - film.sum_odd[p]) / double(even),
                         m = film.sum[p] / double(c);
        for (int k = 0; k < 3; ++k) {
            const double g = (a[k] - b[k]) * (a[k] - b[k]) / 4.0;
            e[p] += g / (m[k] * m[k] + 0.01) / 3.0;
            if (squared) (*squared)[p * 3 + k] = float(g);
        }
    }
    return e;
}

// Regions that partition the pixels by what decides their error (--regions): those whose
// reference saw a lamp or the sky directly (coverage), their neighbours in 3×3, the edges and
// textures (detail_mask.h) and the other surfaces; the pixels that saw nothing at all (a black
// void) are in none.
struct Region {
    const char* name;
    std::vector<uint8_t> in;
    size_t pixels = 0;
    double ref_error = 0;  // the reference's own relMSE over the region (half_gap_error)
};

std::vector<Region> partition(const std::vector<uint8_t>& lit, const std::vector<uint8_t>& edges, const std::vector<uint8_t>& rest,
                              const std::vector<double>& ref_sq, int w, int h) {
    std::vector<Region> r = {{"seeing a light", {}}, {"beside one", {}}, {"edges+textures", {}}, {"other surfaces", {}}};
    for (Region& g : r) g.in.assign(lit.size(), 0);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const size_t p = size_t(y) * w + x;
            bool near = false;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const int xx = x + dx, yy = y + dy;
                    if (xx >= 0 && yy >= 0 && xx < w && yy < h && lit[size_t(yy) * w + xx]) near = true;
                }
            const int k = lit[p] ? 0 : near ? 1 : edges[p] ? 2 : rest[p] ? 3 : -1;
            if (k >= 0) r[size_t(k)].in[p] = 1;
        }
    for (Region& g : r) {
        double s = 0;
        for (size_t p = 0; p < g.in.size(); ++p)
            if (g.in[p]) { ++g.pixels; s += ref_sq[p]; }
        g.ref_error = g.pixels ? s / double(g.pixels) : 0.0;
    }
    return r;
}

// One row of the regions' table: per region its mean spp, and the image's relMSE there with the
// reference's own taken off (0 where that is the larger).
void print_region_row(const std::string& label, const Image& img, const Image* denoised, const Image& ref,
                      const std::vector<Region>& regions) {
    std::printf("| %s |", label.c_str());
    for (const Region& g : regions) {
        double spp = 0;
        for (size_t p = 0; p < g.in.size(); ++p)
            if (g.in[p]) spp += img.sample_count[p];
        auto err = [&](const Image& i) { return std::max(0.0, masked_rel_mse(i, ref, g.in) - g.ref_error); };
        if (!g.pixels) std::printf(" | | |");
        else if (denoised) std::printf(" %.0f | %.4g | %.4g |", spp / double(g.pixels), err(img), err(*denoised));
        else std::printf(" %.0f | %.4g | |", spp / double(g.pixels), err(img));
    }
    std::printf("\n");
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
    std::string cs184 = default_cs184_dir(), gltf = default_gltf_pbr_dir(), figures, exr_dir, only;
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
    app.add_option("--exr", exr_dir,
                   "write every image the run measures as OpenEXR here: the reference with its passes (albedo, normal, depth, "
                   "emission, environment) and its own error per pixel, each count's noisy and denoised image, and the baseline")
        ->type_name("DIR");
    bool show_candidates = false, uniform = false, until_reached = false, regions_table = false;
    app.add_flag("--regions", regions_table,
                 "after each scene's table, the error by region: the pixels that saw a lamp or the sky, those beside them, the "
                 "edges and textures, the other surfaces; per region each render's mean spp and its noisy and denoised relMSE "
                 "with the reference's own there taken off (and the baseline's)");
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
    // A --scene that names none is a typing error, not a run that measured nothing.
    auto picked = [&](const BenchScene& b) { return b.label.find(only) != std::string::npos; };
    if (std::none_of(scenes.begin(), scenes.end(), picked)) {
        std::fprintf(stderr, "tessera bench denoise: --scene %s: no scene's label contains it; the scenes:", only.c_str());
        for (const BenchScene& b : scenes) std::fprintf(stderr, " \"%s\"", b.label.c_str());
        std::fprintf(stderr, "\n");
        return 2;
    }
    const int W = size.first, H = size.second;
    std::printf("denoiser: %dx%d, depth %d, MIS, references of %d spp (seed 7), renders seed %d, %u threads\n\n", W, H, depth, ref_spp,
                seed, std::max(1u, std::thread::hardware_concurrency()));
    bool all_better = true, all_tracked = true;
    int given_back = 0;  // rows whose image the denoiser gave back as rendered
    int measured = 0;
    for (const BenchScene& bs : scenes) {
        if (!picked(bs)) continue;
        if (bs.source.rfind("builtin:", 0) != 0 && !std::filesystem::exists(bs.source)) {
            std::printf("## %s\nskipped: %s is absent\n\n", bs.label.c_str(), bs.source.c_str());
            continue;
        }
        ++measured;
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
        // Its own error adds to every error measured against it: rendered in two independent halves
        // (a denoising render, every pixel alike) so that it is known per pixel (half_gap_error).
        rs.denoise = true;
        rs.guided = false;
        rs.aovs = aov_bit(Aov::albedo) | aov_bit(Aov::normal) | aov_bit(Aov::depth) | aov_bit(Aov::emission) | aov_bit(Aov::environment);
        std::vector<double> ref_sq;
        std::vector<float> ref_gap;  // per channel, for --exr
        RenderCallbacks ref_calls;
        ref_calls.on_pass = [&](const PassView& v) {
            if (v.spp >= ref_spp) ref_sq = half_gap_error(v.film, &ref_gap);
        };
        const RenderResult ref = render(scene, rs, ref_calls);
        if (ref_sq.size() != ref.image.rgb.size() / 3) {
            ref_sq.assign(ref.image.rgb.size() / 3, 0.0);
            ref_gap.assign(ref.image.rgb.size(), 0.f);
        }
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
        double ref_err = 0;
        for (double e : ref_sq) ref_err += e;
        ref_err /= double(std::max<size_t>(1, ref_sq.size()));
        const std::vector<Region> regions = partition(lit, mask, rest, ref_sq, W, H);
        std::string stem = bs.source.substr(bs.source.find_last_of("/:") + 1);
        stem = stem.substr(0, stem.find('.'));
        if (!exr_dir.empty()) {
            std::filesystem::create_directories(exr_dir);
            // The reference's own error per pixel as one more layer, as a compositor reads it.
            std::vector<AovPlane> planes = ref.aovs;
            planes.push_back(AovPlane{Aov::variance, 3, ref_gap});
            write_layers_exr(exr_dir + "/" + stem + "_reference.exr", ref.image, planes,
                             {{"tessera:variance", "the reference's own squared error per pixel, (A - B)^2/4 of its two halves"}});
        }
        // relMSE against the reference less the reference's own (independent of the render's).
        auto true_error = [&](const Image& img) { return std::max(1e-12, relative_mse(img, ref.image) - ref_err); };
        std::printf("## %s\nreference: %d spp in %.1f s, its own relMSE %.3g by its two halves (taken off every whole-image error "
                    "below); edges and textures: %.1f%% of the pixels\n\n",
                    bs.label.c_str(), ref_spp, ref.stats.render_seconds, ref_err, 100 * mask_share);
        std::printf("| spp | render (s) | denoise (s) | relMSE noisy | estimate | relMSE denoised | its estimate | estimate/true | "
                    "edges+textures noisy | denoised | elsewhere noisy | denoised | left as they are: pixels, share of the error | "
                    "seeing a light: pixels, share of the error |\n|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
        struct Row { int spp; double render_s, denoise_s, denoise_all_s, noisy, denoised; };
        std::vector<Row> rows;
        struct Kept { std::string label; Image noisy; std::optional<Image> denoised; };
        std::vector<Kept> kept_images;  // for the regions' table
        auto keep = [&](const std::string& label, const std::string& file, const Image& noisy, const Image* dn) {
            if (regions_table) kept_images.push_back({label, noisy, dn ? std::optional<Image>(*dn) : std::nullopt});
            if (exr_dir.empty()) return;
            write_exr(exr_dir + "/" + stem + "_" + file + ".exr", noisy);
            if (dn) write_exr(exr_dir + "/" + stem + "_" + file + "_denoised.exr", *dn);
        };
        // The baseline: uniform sampling, no denoiser, at the largest count.
        auto render_baseline = [&] {
            RenderSettings s = base;
            s.spp = max_spp;
            s.seed = seed;
            const RenderResult r = render(scene, s);
            keep("plain " + std::to_string(max_spp), "plain_" + std::to_string(max_spp) + "spp", r.image, nullptr);
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
            // A row whose image the denoiser gave back as rendered (its estimate saw nothing to
            // gain: every pixel kept) is equal, not worse, and counted apart; every other row
            // must be below.
            if (kept_share == 1.0) ++given_back;
            else all_better = all_better && dn < noisy && edge_dn < edge_noisy;
            all_tracked = all_tracked && ratio >= 0.5 && ratio <= 2.0;
            rows.push_back({spp, render_s, d->seconds, denoising, noisy, dn});
            keep(std::to_string(spp), std::to_string(spp) + "spp", r.image, &d->image);
            if (!figures.empty() && (spp == 16 || spp == max_spp)) {
                std::filesystem::create_directories(figures);
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
        if (regions_table && !kept_images.empty()) {
            std::printf("by region (relMSE over the region's pixels, the reference's own there taken off):");
            for (const Region& g : regions)
                std::printf(" %s %.1f%% of the pixels (the reference's own %.3g);", g.name, 100.0 * double(g.pixels) / double(g.in.size()),
                            g.ref_error);
            size_t none = regions.front().in.size();
            for (const Region& g : regions) none -= g.pixels;
            std::printf(" nothing seen %.1f%% of the pixels;", 100.0 * double(none) / double(regions.front().in.size()));
            std::printf("\n\n| spp |");
            for (const Region& g : regions) std::printf(" %s: spp | noisy | denoised |", g.name);
            std::printf("\n|---:|");
            for (size_t k = 0; k < regions.size(); ++k) std::printf("---:|---:|---:|");
            std::printf("\n");
            for (const Kept& k : kept_images) print_region_row(k.label, k.noisy, k.denoised ? &*k.denoised : nullptr, ref.image, regions);
            std::printf("\n");
        }
    }
    if (measured == 0) {  // every scene asked for is absent: no verdict to give
        std::printf("no scene was measured (their files are absent: --cs184, --gltf-pbr)\n");
        return 1;
    }
    std::printf("denoised below noisy wherever it denoised (image, edges and textures; %d rows given back as rendered, equal): %s; denoised estimate within 0.5-2x of the truth everywhere: %s%s\n",
                given_back, all_better ? "yes" : "NO", all_tracked ? "yes" : "NO",
                until_reached ? " (over the rows rendered: --until-reached left the larger counts out)" : "");
    return 0;
}

}  // namespace tessera::cli
