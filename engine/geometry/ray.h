#pragma once
#include <glm/glm.hpp>

namespace tessera {

// A ray o + t·d accepts hits with tmin < t < tmax. d need not be unit length (shadow rays
// toward a point use d = target − origin and tmax just below 1).
struct Ray {
    glm::vec3 o{0.f};
    float tmin = 0.f;
    glm::vec3 d{0.f, 0.f, -1.f};
    float tmax = INFINITY;
};

}  // namespace tessera
