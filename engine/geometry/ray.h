#pragma once
#include <cstdint>

#include <glm/glm.hpp>

namespace tessera {

inline constexpr uint32_t kNoTriangle = ~0u;

// A ray o + t·d accepts hits with tmin < t < tmax. d need not be unit length (shadow rays
// toward a point use d = target − origin and tmax just below 1).
struct Ray {
    glm::vec3 o{0.f};
    float tmin = 0.f;
    glm::vec3 d{0.f, 0.f, -1.f};
    float tmax = INFINITY;
    // The triangle the ray leaves (a secondary ray), or kNoTriangle. A ray that leaves a flat
    // triangle cannot meet it again, so the triangle test skips it without the division and
    // error bound that would reject it anyway: about a quarter of a shadow ray's block tests
    // (Cycles' self-primitive skip). Spheres are curved and are never skipped.
    uint32_t origin_tri = kNoTriangle;
    // With instances: the placement origin_tri belongs to (its triangle is skipped there only).
    uint32_t origin_instance = ~0u;
    // Within a shutter: 0 at its opening, 1 at its closing (a camera ray draws it; the rays of its
    // path carry it). A still's rays leave it 0.
    float time = 0.f;
};

}  // namespace tessera
