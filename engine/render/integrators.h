#pragma once
// The closed set of integrators, chosen once per render by a switch: no virtual call per ray.
#include "engine/render/path_integrator.h"

namespace tessera {

// Shading normals mapped to colours (the write-ups' Part 1/2 images).
class NormalsIntegrator {
public:
    NormalsIntegrator(const RenderScene& scene, RenderStats& stats) : s_(scene), stats_(stats) {}
    glm::vec3 radiance(Ray ray, Sampler&, SampleAovs* aovs) {
        Hit hit;
        if (!intersect(s_, ray, hit, stats_.traversal)) return glm::vec3(0.f);
        const SurfaceInteraction si = surface_at(s_, ray, hit);
        if (aovs) record_first_hit(s_, ray, hit, si, *aovs);
        return 0.5f * si.ns + 0.5f;
    }

private:
    const RenderScene& s_;
    RenderStats& stats_;
};

class IntegratorDispatch {
public:
    IntegratorDispatch(const RenderScene& scene, const RenderSettings& settings, RenderStats& stats)
        : kind_(settings.integrator), normals_(scene, stats), path_(scene, settings, stats) {}
    glm::vec3 radiance(const Ray& ray, Sampler& rng, SampleAovs* aovs = nullptr) {
        return kind_ == Integrator::normals ? normals_.radiance(ray, rng, aovs) : path_.radiance(ray, rng, aovs);
    }

private:
    Integrator kind_;
    NormalsIntegrator normals_;
    PathIntegrator path_;
};

}  // namespace tessera
