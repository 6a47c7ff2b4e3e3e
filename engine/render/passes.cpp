#include "engine/render/passes.h"

#include <algorithm>
#include <tuple>

#include "engine/render/cryptomatte.h"
#include "engine/render/light_sampler.h"
#include "engine/render/sampling_guide.h"
#include "engine/render/tile_context.h"
#include "engine/scene/render_scene.h"

namespace tessera {

std::vector<TileRect> make_tiles(int width, int height, int size) {
    size = std::max(1, size);
    std::vector<TileRect> tiles;
    for (int y = 0; y < height; y += size)
        for (int x = 0; x < width; x += size) tiles.push_back({x, y, std::min(x + size, width), std::min(y + size, height)});
    return tiles;
}

bool guides_samples(const RenderSettings& settings) {
    return settings.denoise && settings.guided && !settings.adaptive && settings.spp > kGuidedFrom;
}

PassPlan plan_passes(const RenderSettings& settings, bool has_reference, bool observed) {
    PassPlan p;
    p.adaptive = settings.adaptive.has_value();
    p.measuring = settings.estimate_error || settings.target_error > 0 || observed || has_reference || settings.denoise;
    // Passes of doubling spp only when something is measured or a time limit may cut the
    // render short; otherwise one pass (nothing to report in between).
    p.progressive = p.measuring || settings.time_limit_s > 0;
    // A denoising render estimates its noisy error from its two independent halves instead.
    p.half_buffer = (settings.estimate_error || (settings.target_error > 0 && !has_reference)) && !settings.denoise;
    p.aovs = settings.aovs | (settings.denoise ? kDenoiseAovs : 0);
    p.guided = guides_samples(settings);
    p.max_passes = p.adaptive ? (settings.spp + std::max(1, settings.adaptive->batch) - 1) / std::max(1, settings.adaptive->batch) + 1
                              : 64;
    p.tiles = make_tiles(settings.width, settings.height, settings.tile_size);
    // The denoiser reads the whole image after every pass.
    p.whole_tiles = !p.adaptive && settings.target_error <= 0 && settings.time_limit_s <= 0 && !settings.denoise;
    if (!p.adaptive)
        for (int t = 0, k = 0; k < p.max_passes; ++k) {
            t = pass_target(settings, p, t);
            p.targets.push_back(t);
            if (t >= settings.spp) break;
        }
    return p;
}

int pass_target(const RenderSettings& settings, const PassPlan& plan, int previous) {
    // Uniform sampling doubles the samples per pixel (1, 2, 4, …, spp); adaptive sampling runs
    // one batch per pass on the pixels that have not converged (the target is its ceiling).
    if (plan.adaptive || !plan.progressive) return settings.spp;
    return std::min(settings.spp, previous == 0 ? 1 : previous * 2);
}

std::optional<StopReason> stop_after_pass(const RenderSettings& settings, const PassPlan& plan, const Film& film,
                                          int target, const ConvergencePoint& point, bool out_of_time, bool canceled) {
    if (canceled) return StopReason::canceled;
    if (out_of_time) return StopReason::time_limit;
    // A denoising render is good enough when its denoised image is.
    const double err = settings.denoise ? (point.denoised_rel_mse >= 0 ? point.denoised_rel_mse : point.denoised_est_rel_mse)
                                        : (point.rel_mse >= 0 ? point.rel_mse : point.est_rel_mse);
    if (settings.target_error > 0 && err >= 0 && err <= settings.target_error) return StopReason::target_error;
    const bool all_done = !plan.adaptive ? target >= settings.spp
                                         : std::all_of(film.done.begin(), film.done.end(), [](uint8_t d) { return d != 0; });
    if (all_done)
        return plan.adaptive && std::any_of(film.count.begin(), film.count.end(), [&](uint32_t c) { return int(c) < settings.spp; })
                   ? StopReason::converged : StopReason::spp;
    return std::nullopt;
}

PassEnd end_pass(const RenderSettings& settings, const PassPlan& plan, const Film& film, const Image* reference, int pass,
                 int target, uint64_t samples, double seconds, bool out_of_time, bool canceled, BlockPool* memory) {
    PassEnd e;
    if (plan.measuring) e.point = measure_error(film, reference);
    else e.point.spp_mean = double(samples) / (double(settings.width) * settings.height);
    // A pass below kDenoiseFrom is denoised only where it is the last (it stops on its spp, the
    // clock or the pass cap; not on target_error, which reads the denoised image): so
    // target_error is not tested before 4 spp unless the render ends sooner. A canceled pass is
    // never denoised: a paused job runs it again, a canceled one keeps nothing, and a pause,
    // cancel or shutdown waited for the denoiser (7-10 s at a megapixel on one thread).
    const bool denoise_now = settings.denoise && !canceled &&
                             (plan.adaptive || target >= kDenoiseFrom || pass + 1 >= plan.max_passes ||
                              stop_after_pass(settings, plan, film, target, e.point, out_of_time, canceled));
    if (denoise_now) {
        if (auto d = denoise(film, settings.threads, nullptr, memory)) {
            e.point.denoised_est_rel_mse = d->est_rel_mse;
            e.point.denoise_seconds = d->seconds;
            if (reference) e.point.denoised_rel_mse = relative_mse(d->image, *reference);
            e.denoised = std::make_shared<const Denoised>(std::move(*d));
        }
    }
    e.point.seconds = seconds;
    e.stop = stop_after_pass(settings, plan, film, target, e.point, out_of_time, canceled);
    if (!e.stop && pass + 1 >= plan.max_passes) e.stop = StopReason::spp;
    if (!e.stop) e.next_target = pass_target(settings, plan, target);
    // Every guided pass has targets, so that one process and a farm's tiles (which keep the
    // last ones they were given) never differ: even ones where nothing was denoised.
    if (!e.stop && plan.guided && target >= kGuidedFrom)
        e.goals = guided_targets(film, e.denoised ? e.denoised->error : std::vector<float>(film.count.size(), 0.f), e.next_target,
                                 kGuidedCap * e.next_target);
    return e;
}

WholeTile render_whole_tile(TileContext& ctx, const PassPlan& plan, size_t tile, Film& film, const Image* reference,
                            const std::function<bool()>& cut, const std::function<double()>& clock) {
    WholeTile out;
    for (int k : plan.targets) {
        if (!render_tile(ctx, plan.tiles.at(tile), film, k, cut)) {
            out.cut_short = true;
            break;
        }
        out.sums.push_back({k, clock ? clock() : 0.0, error_sums(film, reference)});
    }
    return out;
}

ConvergenceCurve whole_tile_curve(const PassPlan& plan, const std::vector<std::vector<TargetSums>>& per_tile) {
    ConvergenceCurve curve;
    for (size_t k = 0; k < plan.targets.size(); ++k) {
        ErrorSums total;
        double reached = 0;
        size_t tiles_at = 0;
        for (const auto& tile : per_tile) {
            if (k >= tile.size()) continue;
            total.add(tile[k].sums);
            reached = std::max(reached, tile[k].seconds);
            ++tiles_at;
        }
        if (tiles_at != plan.tiles.size()) break;  // a tile stopped short
        ConvergencePoint pt = total.point();
        pt.seconds = reached;
        curve.points.push_back(pt);
    }
    curve.stop = StopReason::spp;
    return curve;
}

void describe_denoised(const RenderSettings& settings, bool denoised, bool canceled, std::vector<std::string>& left_out) {
    if (settings.denoise && !denoised && !canceled)
        left_out.push_back("denoised image: the render ended before every pixel had the two samples the denoiser compares "
                           "(its time limit, or one sample per pixel)");
}

void describe_render(const RenderScene& scene, const RenderSettings& settings, const Film& film,
                     std::vector<std::string>& built, std::vector<std::string>& left_out) {
    film.describe(built, left_out);
    // A Cryptomatte layer keeps every id, but a header holds the manifest of names only up to
    // kCryptoManifestNames (cryptomatte.h): past it the compositor sees ids without names.
    for (const auto& [aov, names, what] : {std::tuple{Aov::crypto_object, &scene.object_names, "objects"},
                                           std::tuple{Aov::crypto_material, &scene.material_names, "materials"}})
        if (has_aov(settings.aovs, aov) && names->size() > kCryptoManifestNames)
            left_out.push_back(std::string("Cryptomatte manifest of ") + what + ": " + std::to_string(names->size()) +
                               " names, over the " + std::to_string(kCryptoManifestNames) +
                               " a header holds (the layer's ids are all there; a compositor shows them without names)");
    if (settings.denoise) built.push_back("denoiser: feature regression over 2 window sizes and cross-filtered NL-means, chosen per pixel by the error its two independent halves give (after every pass from " + std::to_string(kDenoiseFrom) + " spp on, and the last)");
    else left_out.push_back("denoiser (not asked for)");
    if (guides_samples(settings))
        built.push_back("guided sampling: past " + std::to_string(kGuidedFrom) +
                        " spp each pass spends its samples by the denoised image's error and each pixel's cost in rays");
    else if (settings.denoise)
        left_out.push_back(settings.adaptive ? "guided sampling (the adaptive sampler decides instead)"
                           : !settings.guided ? "guided sampling (guided_sampling false)"
                                              : "guided sampling (no pass past " + std::to_string(kGuidedFrom) + " spp)");
    if (settings.integrator == Integrator::path) {
        (settings.max_depth > 1 ? built : left_out)
            .push_back(settings.max_depth > 1 ? "indirect bounces up to depth " + std::to_string(settings.max_depth)
                                              : std::string("indirect bounces (max_depth <= 1)"));
        if (!scene.has_lights() && !settings.environment) left_out.push_back("direct lighting: no lights or emitters, no shadow rays");
        else if (settings.direct == DirectLighting::mis) built.push_back("MIS: light and BSDF samples");
        else if (std::any_of(scene.materials.begin(), scene.materials.end(), [](const Material& m) { return bsdf_has_glossy(m.bsdf); }))
            built.push_back("MIS of light and lobe samples for glossy lobes (the diffuse part as `direct` says)");
        if (scene.area_lights.size() > 1 && settings.direct != DirectLighting::hemisphere) {
            const LightSelection sel = chosen_light_selection(scene, settings.light_selection);
            const char* name = sel == LightSelection::tree ? "light tree" : sel == LightSelection::power ? "by power" : "every light";
            built.push_back(std::string("light selection: ") + name + " (" + std::to_string(scene.area_lights.size()) +
                            " area lights" +
                            (settings.light_selection == LightSelection::automatic
                                 ? std::string(", chosen automatically: the tree above ") + std::to_string(kTreeAboveLights) + ")"
                                 : std::string(")")));
        }
        describe_seen_emitters(scene, settings, built, left_out);
        if (settings.russian_roulette <= 0.f || settings.max_depth <= 1) left_out.push_back("Russian roulette");
        if (settings.lens_radius > 0.f)
            built.push_back("thin lens: radius " + std::to_string(settings.lens_radius) + ", focused " +
                            (settings.focal_distance > 0.f ? "at " + std::to_string(settings.focal_distance) : std::string("on the look-at point")));
        else
            left_out.push_back("thin lens: a pinhole camera, no lens sample");
    } else {
        left_out.push_back("light transport (normal shading)");
    }
}

bool render_tile(TileContext& ctx, const TileRect& t, Film& film, int target, const std::function<bool()>& out_of_time) {
    for (int y = t.y0; y < t.y1; ++y) {
        if (out_of_time && out_of_time()) return false;
        const size_t row = size_t(y - film.y0) * size_t(film.width);
        for (int x = t.x0; x < t.x1; ++x) {
            const size_t p = row + size_t(x - film.x0);
            ctx.render_pixel(x, y, film, p, film.goal.empty() ? target : int(film.goal[p]));
        }
    }
    return true;
}

namespace {

template <class Fn>
void for_tile_pixels(const TileRect& t, const Film& a, const Film& b, Fn&& fn) {
    for (int y = t.y0; y < t.y1; ++y)
        for (int x = t.x0; x < t.x1; ++x)
            fn(size_t(y - a.y0) * size_t(a.width) + size_t(x - a.x0), size_t(y - b.y0) * size_t(b.width) + size_t(x - b.x0));
}

void copy_entry(const Film& from, size_t i, Film& to, size_t j) {
    to.sum[j] = from.sum[i];
    to.count[j] = from.count[i];
    if (!to.sum_half.empty() && !from.sum_half.empty()) {
        to.sum_half[j] = from.sum_half[i];
        to.sum_quarter[j] = from.sum_quarter[i];
        to.sum_eighth[j] = from.sum_eighth[i];
    }
    if (!to.stats.empty() && !from.stats.empty()) {
        to.stats[j] = from.stats[i];
        to.done[j] = from.done[i];
    }
    if (!to.goal.empty() && !from.goal.empty()) to.goal[j] = from.goal[i];
    if (!to.sum_odd.empty() && !from.sum_odd.empty()) {
        to.sum_odd[j] = from.sum_odd[i];
        to.seen[j] = from.seen[i];
        to.seen_odd[j] = from.seen_odd[i];
    }
    if (!to.rays.empty() && !from.rays.empty()) to.rays[j] = from.rays[i];
    if (to.aov_layout.set == from.aov_layout.set && to.aov_layout.stride > 0) {
        const size_t n = size_t(to.aov_layout.stride);
        std::copy_n(&from.aov[i * n], n, &to.aov[j * n]);
    }
}

}  // namespace

void copy_tile_into(const Film& tile_film, const TileRect& tile, Film& image_film) {
    for_tile_pixels(tile, tile_film, image_film, [&](size_t i, size_t j) { copy_entry(tile_film, i, image_film, j); });
}

void copy_tile_from(const Film& image_film, const TileRect& tile, Film& tile_film) {
    for_tile_pixels(tile, image_film, tile_film, [&](size_t i, size_t j) { copy_entry(image_film, i, tile_film, j); });
}

std::vector<uint32_t> tile_goals(const std::vector<uint32_t>& image_goals, int image_width, const TileRect& tile) {
    std::vector<uint32_t> out;
    out.reserve(tile.pixels());
    for (int y = tile.y0; y < tile.y1; ++y)
        for (int x = tile.x0; x < tile.x1; ++x) out.push_back(image_goals.at(size_t(y) * size_t(image_width) + size_t(x)));
    return out;
}

}  // namespace tessera
