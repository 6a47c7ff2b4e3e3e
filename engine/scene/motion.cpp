#include "engine/scene/motion.h"

#include <algorithm>
#include <cmath>

namespace tessera {

namespace {

// M's linear part as R · S with R a rotation and S symmetric: R is the limit of averaging R with
// its inverse transpose (Higham's iteration, as pbrt-v3's AnimatedTransform::Decompose).
void polar(const glm::dmat3& m, glm::dquat& r, glm::dmat3& s) {
    glm::dmat3 R = m;
    for (int i = 0; i < 100; ++i) {
        const glm::dmat3 next = 0.5 * (R + glm::transpose(glm::inverse(R)));
        double change = 0;
        for (int c = 0; c < 3; ++c)
            for (int k = 0; k < 3; ++k) change = std::max(change, std::abs(next[c][k] - R[c][k]));
        R = next;
        if (change < 1e-12) break;
    }
    // A mirror (negative determinant) stays in S: R is then a proper rotation.
    if (glm::determinant(R) < 0) R = -R;
    s = glm::inverse(R) * m;
    r = glm::normalize(glm::quat_cast(R));
}

glm::mat4 compose(const glm::vec3& t, const glm::quat& r, const glm::mat3& s) {
    const glm::mat3 l = glm::mat3_cast(r) * s;
    glm::mat4 m(l);
    m[3] = glm::vec4(t, 1.f);
    return m;
}

}  // namespace

InstanceMotion decompose_motion(const glm::mat4& open, const glm::mat4& close) {
    InstanceMotion m;
    glm::dquat r;
    glm::dmat3 s;
    polar(glm::dmat3(glm::dmat4(open)), r, s);
    m.t0 = glm::vec3(open[3]);
    m.r0 = glm::quat(r);
    m.s0 = glm::mat3(s);
    polar(glm::dmat3(glm::dmat4(close)), r, s);
    m.t1 = glm::vec3(close[3]);
    m.r1 = glm::quat(r);
    m.s1 = glm::mat3(s);
    if (glm::dot(m.r0, m.r1) < 0.f) m.r1 = -m.r1;  // the shorter way round
    return m;
}

void instance_maps_at(const InstanceMotion& m, float time, glm::mat4x3& to_world, glm::mat4x3& to_object) {
    const glm::vec3 t = m.t0 + time * (m.t1 - m.t0);
    const glm::quat r = glm::slerp(m.r0, m.r1, time);
    const glm::mat3 s = m.s0 + time * (m.s1 - m.s0);
    const glm::mat3 l = glm::mat3_cast(r) * s;
    to_world = glm::mat4x3(l[0], l[1], l[2], t);
    const glm::mat3 inv = glm::inverse(l);
    to_object = glm::mat4x3(inv[0], inv[1], inv[2], -(inv * t));
}

Aabb motion_bounds(const InstanceMotion& m, const Aabb& box) {
    Aabb out;
    if (box.empty()) return out;
    constexpr int kSteps = 64;
    glm::vec3 prev[8];
    float step = 0.f;
    for (int k = 0; k <= kSteps; ++k) {
        const float time = float(k) / kSteps;
        const glm::mat4 w = compose(m.t0 + time * (m.t1 - m.t0), glm::slerp(m.r0, m.r1, time), m.s0 + time * (m.s1 - m.s0));
        for (int c = 0; c < 8; ++c) {
            const glm::vec3 p(c & 1 ? box.hi.x : box.lo.x, c & 2 ? box.hi.y : box.lo.y, c & 4 ? box.hi.z : box.lo.z);
            const glm::vec3 q(w * glm::vec4(p, 1.f));
            out.expand(q);
            if (k > 0) step = std::max(step, glm::length(q - prev[c]));
            prev[c] = q;
        }
    }
    // Between two samples a point moves along an arc of at most 1/64 of the motion's turn; it
    // stays within half a step of the chord's ends, which the pad covers.
    out.lo -= glm::vec3(0.5f * step);
    out.hi += glm::vec3(0.5f * step);
    return out;
}

Camera camera_at(const Camera& a, const Camera& b, float time) {
    Camera c = a;
    auto mix = [time](const glm::vec3& x, const glm::vec3& y) { return x + time * (y - x); };
    c.position = mix(a.position, b.position);
    c.forward = glm::normalize(mix(a.forward, b.forward));
    c.right = glm::normalize(mix(a.right, b.right) - c.forward * glm::dot(mix(a.right, b.right), c.forward));
    c.up = glm::cross(c.right, c.forward);
    if (glm::dot(c.up, mix(a.up, b.up)) < 0.f) c.up = -c.up;
    c.tan_half_w = a.tan_half_w + time * (b.tan_half_w - a.tan_half_w);
    c.tan_half_h = a.tan_half_h + time * (b.tan_half_h - a.tan_half_h);
    c.focal_distance = a.focal_distance + time * (b.focal_distance - a.focal_distance);
    return c;
}

}  // namespace tessera
