#include "engine/scene/light_tree.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "engine/scene/render_scene.h"

namespace tessera {

namespace {

float safe_sqrt(float x) { return std::sqrt(std::max(0.f, x)); }

// cos(max(0, a − b)) and sin(max(0, a − b)) from the cosines and sines of a and b.
float cos_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
    return cos_a > cos_b ? 1.f : cos_a * cos_b + sin_a * sin_b;
}
float sin_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
    return cos_a > cos_b ? 0.f : sin_a * cos_b - cos_a * sin_b;
}

struct Builder {
    const RenderScene& s;
    std::vector<uint32_t> order;
    std::vector<glm::vec3> centroid;
    LightTree& t;

    // Builds the node for order[lo, hi) at `at`, depth `level`, path `bits`; returns it.
    void build(uint32_t lo, uint32_t hi, int level, uint64_t bits) {
        const uint32_t at = uint32_t(t.nodes.size());
        t.nodes.emplace_back();
        if (hi - lo == 1) {
            const uint32_t i = order[lo];
            const LightTriangle& lt = s.light_triangles[i];
            const AreaLight& al = s.area_lights[lt.light];
            LightTreeNode& n = t.nodes[at];
            n.leaf = true;
            n.child = i;
            n.bounds.expand(lt.p0);
            n.bounds.expand(lt.p0 + lt.e1);
            n.bounds.expand(lt.p0 + lt.e2);
            n.axis = lt.n;
            n.cos_o = 1.f;
            n.two_sided = al.double_sided;
            const float lum = 0.2126f * al.radiance.x + 0.7152f * al.radiance.y + 0.0722f * al.radiance.z;
            n.power = lum * lt.area * (al.double_sided ? 2.f : 1.f);
            t.path[i] = bits;
            t.depth[i] = uint8_t(level);
            return;
        }
        Aabb cb;
        for (uint32_t k = lo; k < hi; ++k) cb.expand(centroid[order[k]]);
        const glm::vec3 e = cb.extent();
        const int axis = e.x >= e.y && e.x >= e.z ? 0 : e.y >= e.z ? 1 : 2;
        const uint32_t mid = lo + (hi - lo) / 2;
        std::nth_element(order.begin() + lo, order.begin() + mid, order.begin() + hi,
                         [&](uint32_t a, uint32_t b) { return centroid[a][axis] < centroid[b][axis]; });
        build(lo, mid, level + 1, bits);
        const uint32_t second = uint32_t(t.nodes.size());
        build(mid, hi, level + 1, bits | (uint64_t(1) << level));
        const LightTreeNode& a = t.nodes[at + 1];
        const LightTreeNode& b = t.nodes[second];
        LightTreeNode n;
        n.child = second;
        n.bounds = a.bounds;
        n.bounds.expand(b.bounds);
        n.power = a.power + b.power;
        n.two_sided = a.two_sided || b.two_sided;
        // The cone of the normals below: around their mean, as wide as the farthest one (a
        // little wider, against rounding); all directions when they cancel.
        glm::vec3 sum(0.f);
        for (uint32_t k = lo; k < hi; ++k) sum += s.light_triangles[order[k]].n;
        const float len = glm::length(sum);
        if (len > 1e-3f * float(hi - lo)) {
            n.axis = sum / len;
            float c = 1.f;
            for (uint32_t k = lo; k < hi; ++k) c = std::min(c, glm::dot(n.axis, s.light_triangles[order[k]].n));
            n.cos_o = std::max(-1.f, c - 1e-4f);
        } else {
            n.axis = glm::vec3(0.f, 0.f, 1.f);
            n.cos_o = -1.f;
        }
        t.nodes[at] = n;
    }
};

}  // namespace

LightTree build_light_tree(const RenderScene& s) {
    LightTree t;
    const uint32_t n = uint32_t(s.light_triangles.size());
    if (n == 0) return t;
    t.path.assign(n, 0);
    t.depth.assign(n, 0);
    t.nodes.reserve(size_t(2) * n);
    Builder b{s, std::vector<uint32_t>(n), std::vector<glm::vec3>(n), t};
    std::iota(b.order.begin(), b.order.end(), 0u);
    for (uint32_t i = 0; i < n; ++i) {
        const LightTriangle& lt = s.light_triangles[i];
        b.centroid[i] = lt.p0 + (lt.e1 + lt.e2) * (1.f / 3.f);
    }
    b.build(0, n, 0, 0);
    for (LightTreeNode& node : t.nodes) {
        node.centre = node.bounds.centroid();
        node.radius2 = 0.25f * glm::dot(node.bounds.extent(), node.bounds.extent());
        node.radius = std::sqrt(node.radius2);
        node.sin_o = safe_sqrt(1.f - node.cos_o * node.cos_o);
    }
    return t;
}

LightImportance light_importance(const LightTreeNode& node, const glm::vec3& p, const glm::vec3& n) {
    const glm::vec3& pc = node.centre;
    const float r2 = node.radius2;
    const glm::vec3 to_p = p - pc;
    const float dc2 = glm::dot(to_p, to_p), dc = std::sqrt(dc2);
    // Wholly behind the receiving surface (its box's farthest corner along n below p's plane,
    // by more than rounding): nothing, as in Cycles for opaque surfaces. The box is much tighter
    // than the sphere for the flat, wide nodes that lamps along a ceiling or a street make.
    const glm::vec3 far_corner = glm::mix(node.bounds.lo, node.bounds.hi, glm::step(glm::vec3(0.f), n));
    if (glm::dot(n, far_corner - p) < -1e-5f * (dc + node.radius)) return {};
    // The directions the node's bounding sphere subtends from p (all, from inside it).
    float cos_b = -1.f, sin_b = 0.f;
    if (dc2 > r2) {
        sin_b = node.radius / dc;
        cos_b = safe_sqrt(1.f - sin_b * sin_b);
    }
    const glm::vec3 wi = dc > 0.f ? to_p * (1.f / dc) : glm::vec3(0.f, 0.f, 1.f);
    float cos_w = glm::dot(node.axis, wi);
    if (node.two_sided) cos_w = std::abs(cos_w);
    const float sin_w = safe_sqrt(1.f - cos_w * cos_w);
    const float cos_x = cos_sub_clamped(sin_w, cos_w, node.sin_o, node.cos_o);
    const float sin_x = sin_sub_clamped(sin_w, cos_w, node.sin_o, node.cos_o);
    const float cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
    if (cos_p <= 0.f) return {};  // a Lambertian emitter sends nothing past its horizon (θe = π/2)
    // The receiving surface's cosine, bounded the same way and one-sided: light sampling counts
    // only light above the shading normal (the direct-light estimate reflects, it never
    // transmits), so a node behind the surface gets nothing. MIS asks with the same normal.
    const float cos_i = glm::dot(-wi, n);
    const float sin_i = safe_sqrt(1.f - cos_i * cos_i);
    const float angular = node.power * cos_p * cos_sub_clamped(sin_i, cos_i, sin_b, cos_b);
    if (!(angular > 0.f)) return {};
    // Two guesses at the distance that stands for the whole node. From its centre (clamped at a
    // quarter of the bounding radius, so a node around p is not infinitely close) suits lights
    // that fill their box; the geometric mean of the nearest and farthest distances to the box
    // (clamped at a tenth of the radius) suits a flat spread of lights p is near, such as lamps
    // over a floor, where the centre is far but half the lights are close. Each alone was worse
    // on one of the many-light scenes; sampling by their average probability costs at most twice
    // the better one's variance (docs/benchmarks.md, "The light tree").
    const glm::vec3 nearest = glm::clamp(p, node.bounds.lo, node.bounds.hi);
    const glm::vec3 farthest = glm::mix(node.bounds.lo, node.bounds.hi, glm::lessThan(p, pc));
    const float near2 = glm::dot(p - nearest, p - nearest), far2 = glm::dot(p - farthest, p - farthest);
    return {angular / std::max(std::sqrt(near2 * far2), 0.01f * r2), angular / std::max(dc2, 0.0625f * r2)};
}

namespace {

// The probability of the first child: the average of what the two distance guesses give.
bool first_child_probability(const LightTreeNode& a, const LightTreeNode& b, const glm::vec3& p, const glm::vec3& n, float& pa) {
    const LightImportance ia = light_importance(a, p, n), ib = light_importance(b, p, n);
    const float span = ia.span + ib.span, centre = ia.centre + ib.centre;
    const bool by_span = span > 0.f && std::isfinite(span), by_centre = centre > 0.f && std::isfinite(centre);
    if (by_span && by_centre) pa = 0.5f * (ia.span / span + ia.centre / centre);
    else if (by_span) pa = ia.span / span;
    else if (by_centre) pa = ia.centre / centre;
    else return false;
    return true;
}

}  // namespace

bool sample_light_tree(const LightTree& t, const glm::vec3& p, const glm::vec3& n, float& u, uint32_t& light_triangle, float& pmf) {
    if (t.nodes.empty()) return false;
    uint32_t at = 0;
    pmf = 1.f;
    if (t.nodes[0].leaf && !light_importance(t.nodes[0], p, n).any()) return false;
    while (!t.nodes[at].leaf) {
        const uint32_t a = at + 1, b = t.nodes[at].child;
        float pa;
        if (!first_child_probability(t.nodes[a], t.nodes[b], p, n, pa)) return false;
        if (u < pa) {
            u = std::min(u / pa, 0x1.fffffep-1f);
            pmf *= pa;
            at = a;
        } else {
            u = std::min((u - pa) / (1.f - pa), 0x1.fffffep-1f);
            pmf *= 1.f - pa;
            at = b;
        }
    }
    light_triangle = t.nodes[at].child;
    return pmf > 0.f;
}

float light_tree_pmf(const LightTree& t, const glm::vec3& p, const glm::vec3& n, uint32_t tri) {
    if (t.nodes.empty() || tri >= t.path.size()) return 0.f;
    uint32_t at = 0;
    float pmf = 1.f;
    if (t.nodes[0].leaf) return light_importance(t.nodes[0], p, n).any() ? 1.f : 0.f;
    for (int level = 0; !t.nodes[at].leaf; ++level) {
        const uint32_t a = at + 1, b = t.nodes[at].child;
        float pa;
        if (!first_child_probability(t.nodes[a], t.nodes[b], p, n, pa)) return 0.f;
        const bool second = (t.path[tri] >> level) & 1;
        pmf *= second ? 1.f - pa : pa;
        at = second ? b : a;
    }
    return pmf;
}

}  // namespace tessera
