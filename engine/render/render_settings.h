#pragma once
// What a render does, as plain data with defaults; validated once at the edge (api/, CLI).
// A job's defaults are api/job_fields.cpp's; these agree with them (tests/api/job_fields_test.cpp).
#include <cstdint>
#include <memory>
#include <optional>

#include "engine/render/aov.h"
#include "engine/sampling/sampler.h"

namespace tessera {

struct EnvironmentMap;  // engine/scene/environment.h

enum class Integrator { normals, path };
enum class DirectLighting { hemisphere, importance, mis };
enum class BounceMode { accumulate, nth };
// How area lights share the light samples: `all` gives every light `light_rays` samples
// (CS184); `power` draws `light_rays` samples in all, each from one light chosen with
// probability proportional to its emitted power (better when there are many lights).
// automatic: the tree where a scene has many area lights, every light otherwise
// (chosen_light_selection in engine/render/light_sampler.h).
enum class LightSelection { all, power, tree, automatic };
// Which bounces reach the image (the write-ups' direct-only and indirect-only renders):
// direct = bounces 0 and 1, indirect = bounces 2 and up.
enum class LightingOutput { all, direct, indirect };

struct AdaptiveSettings {
    int batch = 32;           // samples between convergence checks
    float tolerance = 0.05f;  // stop when 1.96·σ/√n ≤ tolerance·μ
};

struct RenderSettings {
    int width = 800;
    int height = 600;
    int spp = 1;
    int light_rays = 1;       // samples per area light per shading point
    int max_depth = 1;        // CS184 meaning: 0 emitted only, 1 direct, n bounces
    Integrator integrator = Integrator::path;
    // MIS by default: at equal time it is 14x better than light sampling under an environment
    // map and within 15% elsewhere (docs/benchmarks.md, "The default direct lighting").
    DirectLighting direct = DirectLighting::mis;
    float russian_roulette = 0.f;  // continuation probability; 0 disables
    BounceMode bounces = BounceMode::accumulate;
    LightingOutput output = LightingOutput::all;
    LightSelection light_selection = LightSelection::automatic;
    SamplerKind sampler = SamplerKind::sobol;  // engine/sampling/sampler.h
    std::optional<AdaptiveSettings> adaptive;
    // Thin lens (CS184 -b, -d): a lens of this radius focused at this distance along the view;
    // radius 0 is the pinhole (no lens sample is drawn); distance 0 focuses on the camera's
    // look-at point.
    float lens_radius = 0.f;
    float focal_distance = 0.f;
    // An environment light around the scene (CS184 -e), loaded by the caller; none: black.
    std::shared_ptr<const EnvironmentMap> environment;
    int tile_size = 32;
    uint64_t seed = 0;
    int threads = 0;          // 0: all hardware threads
    // Stop conditions besides spp (whichever comes first); 0 disables each. The render runs in
    // passes (doubling spp, or one adaptive batch) and checks them between passes (time also
    // between tiles).
    double time_limit_s = 0;
    double target_error = 0;   // relative MSE: against the reference if given, else estimated
    bool estimate_error = false;  // keep the half-sample buffer and report the estimated error
    // AOVs for compositing (engine/render/aov.h), accumulated with the image.
    AovSet aovs = 0;
    // Denoise after every pass from kDenoiseFrom spp on and the last (engine/render/denoise.h,
    // passes.h) and report the denoised image's error; target_error then applies to the
    // denoised image.
    bool denoise = false;
    // With denoise: after the first passes, each pass spends its samples where the denoised
    // image's estimated error is (engine/render/sampling_guide.h); spp is then the mean.
    bool guided = true;
};

// Whether light reaching the camera after `bounce` bounces is in the image (0: emitters seen
// directly), by the output and bounce settings.
inline bool counts_bounce(const RenderSettings& st, int bounce) {
    if (st.output == LightingOutput::direct && bounce > 1) return false;
    if (st.output == LightingOutput::indirect && bounce < 2) return false;
    return st.bounces == BounceMode::accumulate ? bounce <= st.max_depth : bounce == st.max_depth;
}

}  // namespace tessera
