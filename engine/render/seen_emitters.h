#pragma once
// Lamps the camera sees directly, by the exact share of each pixel they cover: a control
// variate for the emission a camera ray finds. A pixel on a lamp's rim is otherwise the noisiest
// kind there is (its samples either hit a lamp of radiance up to 100 or a grey ceiling), its
// error falls slowest, and no filter may touch it, since its neighbours do not share it.
//
// Through a pinhole, a flat lamp in front of the camera projects to a polygon on the image, and
// a box-filtered pixel's mean of "this ray hits the lamp, unoccluded" is the area of that
// polygon within the pixel's square, exactly. Each camera sample then adds
//     Σ_j L_j · (coverage_j − hits_j(ray))
// over the lamps j over its pixel: its expectation is zero, so the image stays unbiased, and
// where nothing hides a lamp the sample's emission (L_j when it hit lamp j) and −L_j·hits_j
// cancel, leaving the exact Σ L_j·coverage_j. What hides a lamp (something in front of it) is
// left to the samples, as before. Applied to every sample in the sample loop, so the film, the
// two halves, the passes and the farm need nothing else.
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "engine/camera/camera.h"
#include "engine/geometry/ray.h"
#include "engine/render/render_settings.h"
#include "engine/scene/render_scene.h"

namespace tessera {

struct SeenEmitters {
    struct Lamp {
        glm::vec3 p0, e1, e2;  // the triangle
        glm::vec3 radiance;    // toward the camera
    };
    int x0 = 0, y0 = 0, width = 0, height = 0;  // the image pixels it holds
    std::vector<Lamp> lamps;
    std::vector<uint32_t> first;     // per pixel of the rectangle, and one more: its entries in `lamp_of`
    std::vector<uint32_t> lamp_of;   // the lamps over each pixel
    std::vector<glm::vec3> mean;     // per pixel: Σ coverage × radiance, the exact mean of what the lamps give it
    size_t lamps_considered = 0;     // light triangles looked at before the work bound stopped it

    bool empty() const { return lamp_of.empty(); }

    // The correction a camera sample of image pixel (x, y) along `ray` adds (zero where no lamp
    // is over the pixel): the pixel's exact mean less what the ray would see of its lamps with
    // nothing in front of them.
    glm::vec3 correction(int x, int y, const Ray& ray) const {
        if (lamp_of.empty()) return glm::vec3(0.f);
        const int lx = x - x0, ly = y - y0;
        if (lx < 0 || ly < 0 || lx >= width || ly >= height) return glm::vec3(0.f);
        const size_t q = size_t(ly) * size_t(width) + size_t(lx);
        const uint32_t a = first[q], b = first[q + 1];
        if (a == b) return glm::vec3(0.f);
        glm::vec3 c = mean[q];
        for (uint32_t k = a; k < b; ++k) {
            const Lamp& l = lamps[lamp_of[k]];
            if (hits(l, ray)) c -= l.radiance;
        }
        return c;
    }

    // Möller–Trumbore, both faces, within the ray's interval.
    static bool hits(const Lamp& l, const Ray& ray) {
        const glm::vec3 pv = glm::cross(ray.d, l.e2);
        const float det = glm::dot(l.e1, pv);
        if (det == 0.f) return false;
        const float inv = 1.f / det;
        const glm::vec3 tv = ray.o - l.p0;
        const float u = glm::dot(tv, pv) * inv;
        if (u < 0.f || u > 1.f) return false;
        const glm::vec3 qv = glm::cross(tv, l.e1);
        const float v = glm::dot(ray.d, qv) * inv;
        if (v < 0.f || u + v > 1.f) return false;
        const float t = glm::dot(l.e2, qv) * inv;
        return t >= ray.tmin && t <= ray.tmax;
    }
};

// Light triangles looked at, at most: beyond it (an emissive mesh of many small triangles rather
// than lamps) the render goes without (each tile of a farm looks at every one).
inline constexpr size_t kSeenEmittersMaxTriangles = 1u << 16;

// The lamps over image pixels [x0, x0 + w) × [y0, y0 + h). Empty where it does not hold or has
// nothing to do: a thin lens or a moving camera (no single projection), lamps that move within
// the shutter, emission seen directly left out of the output (max_depth, output) or the normals
// integrator, no light triangles or more than kSeenEmittersMaxTriangles. A lamp is left to the
// samples where its emission is textured or cut by alpha, it faces away (one-sided), or it is
// not wholly between the clip planes; a pixel takes at most four lamps, and once the lamps'
// bounding boxes on the image add up to 64 images the lamps after are left to the samples (a
// hostile scene of many large emitters costs no more). Every rectangle holds what the whole
// image holds over its pixels, so a farm's tiles give one process's image.
SeenEmitters seen_emitters(const RenderScene& scene, const RenderSettings& settings, const Camera& camera, int x0, int y0, int w, int h);

// The report's line on it: built (how many lamps over how many pixels) or left out, and why.
void describe_seen_emitters(const RenderScene& scene, const RenderSettings& settings, std::vector<std::string>& built,
                            std::vector<std::string>& left_out);

}  // namespace tessera
