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
    return t;
}

float light_importance(const LightTreeNode& node, const glm::vec3& p, const glm::vec3& n) {
    const glm::vec3 pc = node.bounds.centroid();
    // The directions the node's bounds subtend from p (all, from inside its bounding sphere).
    const float r2 = 0.25f * glm::dot(node.bounds.extent(), node.bounds.extent());
    // Distance² no less than the bounding sphere's radius²: pbrt-v4 clamps at half the diagonal's
    // length (a length, not an area), which for 3 cm lamps treats everything within 14 cm as 14 cm
    // away, exactly where a nearby lamp dominates (measured: variance 3.3 against 2.2 for
    // sampling every lamp, on builtin:scattered_lights).
    const float d2 = std::max(glm::dot(p - pc, p - pc), r2);
    float cos_b = -1.f;
    const float dc2 = glm::dot(p - pc, p - pc);
    if (dc2 > r2) cos_b = safe_sqrt(1.f - r2 / dc2);
    const float sin_b = safe_sqrt(1.f - cos_b * cos_b);
    const glm::vec3 wi = dc2 > 0.f ? (p - pc) / std::sqrt(dc2) : glm::vec3(0.f, 0.f, 1.f);
    float cos_w = glm::dot(node.axis, wi);
    if (node.two_sided) cos_w = std::abs(cos_w);
    const float sin_w = safe_sqrt(1.f - cos_w * cos_w);
    const float sin_o = safe_sqrt(1.f - node.cos_o * node.cos_o);
    const float cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, node.cos_o);
    const float sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, node.cos_o);
    const float cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
    if (cos_p <= 0.f) return 0.f;  // a Lambertian emitter sends nothing past its horizon (θe = π/2)
    float importance = node.power * cos_p / d2;
    // The receiving surface's cosine, bounded the same way.
    const float cos_i = std::abs(glm::dot(-wi, n));
    const float sin_i = safe_sqrt(1.f - cos_i * cos_i);
    importance *= cos_sub_clamped(sin_i, cos_i, sin_b, cos_b);
    return std::max(importance, 0.f);
}

bool sample_light_tree(const LightTree& t, const glm::vec3& p, const glm::vec3& n, float& u, uint32_t& light_triangle, float& pmf) {
    if (t.nodes.empty()) return false;
    uint32_t at = 0;
    pmf = 1.f;
    if (t.nodes[0].leaf && !(light_importance(t.nodes[0], p, n) > 0.f)) return false;
    while (!t.nodes[at].leaf) {
        const uint32_t a = at + 1, b = t.nodes[at].child;
        const float ia = light_importance(t.nodes[a], p, n), ib = light_importance(t.nodes[b], p, n);
        if (!(ia + ib > 0.f)) return false;
        const float pa = ia / (ia + ib);
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
    if (t.nodes[0].leaf) return light_importance(t.nodes[0], p, n) > 0.f ? 1.f : 0.f;
    for (int level = 0; !t.nodes[at].leaf; ++level) {
        const uint32_t a = at + 1, b = t.nodes[at].child;
        const float ia = light_importance(t.nodes[a], p, n), ib = light_importance(t.nodes[b], p, n);
        if (!(ia + ib > 0.f)) return 0.f;
        const bool second = (t.path[tri] >> level) & 1;
        pmf *= (second ? ib : ia) / (ia + ib);
        at = second ? b : a;
    }
    return pmf;
}

}  // namespace tessera
