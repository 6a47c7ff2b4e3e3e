#pragma once
// Ray–triangle tests. The watertight test (Woop, Benthin, Wald, "Watertight Ray/Triangle
// Intersection", JCGT 2013) never lets a ray slip between triangles that share an edge or a
// vertex; Möller–Trumbore is kept for comparison (it can leak on shared edges).
#include <algorithm>
#include <cmath>
#include <utility>

#include <glm/glm.hpp>

#include "engine/core/float_util.h"
#include "engine/geometry/ray.h"

namespace tessera {

struct TriangleVerts { glm::vec3 p0, p1, p2; };

struct TriangleHit {
    float t;
    float b0, b1, b2;  // barycentric weights of p0, p1, p2
};

// Per-ray constants of the watertight test: the axis permutation and shear.
struct WatertightRay {
    int kx, ky, kz;
    float sx, sy, sz;
};

inline WatertightRay make_watertight_ray(const glm::vec3& d) {
    // kz = (a.x > a.y) ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2), kx and ky the other two
    // in cyclic order, swapped when d[kz] < 0 to keep the winding (so the sign tests stay
    // consistent). Masks instead of branches, and components through a plain array instead
    // of glm's operator[] (a switch): for incoherent rays each choice is a coin toss, and
    // the mispredictions showed in the profile of `tessera bench rays` (0.6 per ray).
    const glm::vec3 a = glm::abs(d);
    const float dv[3] = {d.x, d.y, d.z};
    const bool x_over_y = a.x > a.y;
    const int first = int(!x_over_y);
    const float larger = x_over_y ? a.x : a.y;
    const int kz = 2 + ((first - 2) & -int(larger > a.z));
    const int cx = kz == 2 ? 0 : kz + 1, cy = cx == 2 ? 0 : cx + 1;
    const int flip = (cx ^ cy) & -int(dv[kz] < 0.f);
    const int kx = cx ^ flip, ky = cy ^ flip;
    // One division: the shear only has to be the same for every triangle a ray meets, which
    // multiplying by the reciprocal keeps.
    const float sz = 1.f / dv[kz];
    return {kx, ky, kz, dv[kx] * sz, dv[ky] * sz, sz};
}

inline bool intersect_triangle_watertight(const Ray& ray, const WatertightRay& w, const glm::vec3& p0,
                                          const glm::vec3& p1, const glm::vec3& p2, TriangleHit& hit) {
    const glm::vec3 A = p0 - ray.o, B = p1 - ray.o, C = p2 - ray.o;
    const float ax = A[w.kx] - w.sx * A[w.kz], ay = A[w.ky] - w.sy * A[w.kz];
    const float bx = B[w.kx] - w.sx * B[w.kz], by = B[w.ky] - w.sy * B[w.kz];
    const float cx = C[w.kx] - w.sx * C[w.kz], cy = C[w.ky] - w.sy * C[w.kz];
    float u = cx * by - cy * bx;
    float v = ax * cy - ay * cx;
    float e = bx * ay - by * ax;
    // An edge function that rounds to exactly zero is recomputed in double, so that two
    // triangles sharing that edge cannot both reject the ray.
    if (u == 0.f || v == 0.f || e == 0.f) {
        u = float(double(cx) * double(by) - double(cy) * double(bx));
        v = float(double(ax) * double(cy) - double(ay) * double(cx));
        e = float(double(bx) * double(ay) - double(by) * double(ax));
    }
    if ((u < 0.f || v < 0.f || e < 0.f) && (u > 0.f || v > 0.f || e > 0.f)) return false;
    const float det = u + v + e;
    if (det == 0.f) return false;
    const float az = w.sz * A[w.kz], bz = w.sz * B[w.kz], cz = w.sz * C[w.kz];
    const float T = u * az + v * bz + e * cz;
    const float inv_det = 1.f / det;
    const float t = T * inv_det;
    if (!(t > ray.tmin && t < ray.tmax)) return false;
    // Reject t within its own rounding error of zero (pbrt-v4, section 6.8.4): a ray spawned
    // from this very plane, whose computed t may come out a hair positive, cannot re-hit it.
    const float max_zt = std::max(std::abs(az), std::max(std::abs(bz), std::abs(cz)));
    const float max_xt = std::max(std::abs(ax), std::max(std::abs(bx), std::abs(cx)));
    const float max_yt = std::max(std::abs(ay), std::max(std::abs(by), std::abs(cy)));
    const float delta_z = gamma(3) * max_zt;
    const float delta_x = gamma(5) * (max_xt + max_zt);
    const float delta_y = gamma(5) * (max_yt + max_zt);
    const float delta_e = 2.f * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    const float max_e = std::max(std::abs(u), std::max(std::abs(v), std::abs(e)));
    const float delta_t = 3.f * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * std::abs(inv_det);
    if (t <= delta_t) return false;
    hit = {t, u * inv_det, v * inv_det, e * inv_det};
    return true;
}

inline bool intersect_triangle_moller_trumbore(const Ray& ray, const glm::vec3& p0, const glm::vec3& p1,
                                               const glm::vec3& p2, TriangleHit& hit) {
    const glm::vec3 e1 = p1 - p0, e2 = p2 - p0;
    const glm::vec3 p = glm::cross(ray.d, e2);
    const float det = glm::dot(e1, p);
    if (det == 0.f) return false;
    const float inv_det = 1.f / det;
    const glm::vec3 s = ray.o - p0;
    const float b1 = glm::dot(s, p) * inv_det;
    if (b1 < 0.f || b1 > 1.f) return false;
    const glm::vec3 q = glm::cross(s, e1);
    const float b2 = glm::dot(ray.d, q) * inv_det;
    if (b2 < 0.f || b1 + b2 > 1.f) return false;
    const float t = glm::dot(e2, q) * inv_det;
    if (!(t > ray.tmin && t < ray.tmax)) return false;
    hit = {t, 1.f - b1 - b2, b1, b2};
    return true;
}

}  // namespace tessera
