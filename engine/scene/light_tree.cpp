#include "engine/scene/light_tree.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#if defined(__SSE__)
#include <immintrin.h>
#endif

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
    std::vector<LightTreeNode>& nodes;  // the binary tree, depth first

    bool moves(uint32_t i) const {
        if (s.motion.light_triangles_close.empty()) return false;
        const LightTriangle &a = s.light_triangles[i], &c = s.motion.light_triangles_close[i];
        return a.p0 != c.p0 || a.e1 != c.e1 || a.e2 != c.e2;
    }

    // Builds the node for order[lo, hi) at the end of `nodes`.
    void build(uint32_t lo, uint32_t hi) {
        const uint32_t at = uint32_t(nodes.size());
        nodes.emplace_back();
        if (hi - lo == 1) {
            const uint32_t i = order[lo];
            const LightTriangle& lt = s.light_triangles[i];
            const AreaLight& al = s.area_lights[lt.light];
            LightTreeNode& n = nodes[at];
            n.leaf = true;
            n.child = i;
            n.bounds.expand(lt.p0);
            n.bounds.expand(lt.p0 + lt.e1);
            n.bounds.expand(lt.p0 + lt.e2);
            n.axis = lt.n;
            n.cos_o = 1.f;
            if (moves(i)) {
                // Within a shutter: its box holds it at the opening and the closing (so, being
                // convex, at every time between), and its normal may turn any way between them.
                const LightTriangle& c = s.motion.light_triangles_close[i];
                n.bounds.expand(c.p0);
                n.bounds.expand(c.p0 + c.e1);
                n.bounds.expand(c.p0 + c.e2);
                n.cos_o = -1.f;
            }
            n.two_sided = al.double_sided;
            const float lum = 0.2126f * al.radiance.x + 0.7152f * al.radiance.y + 0.0722f * al.radiance.z;
            n.power = lum * lt.area * (al.double_sided ? 2.f : 1.f);
            return;
        }
        Aabb cb;
        for (uint32_t k = lo; k < hi; ++k) cb.expand(centroid[order[k]]);
        const glm::vec3 e = cb.extent();
        const int axis = e.x >= e.y && e.x >= e.z ? 0 : e.y >= e.z ? 1 : 2;
        const uint32_t mid = lo + (hi - lo) / 2;
        std::nth_element(order.begin() + lo, order.begin() + mid, order.begin() + hi,
                         [&](uint32_t a, uint32_t b) { return centroid[a][axis] < centroid[b][axis]; });
        build(lo, mid);
        const uint32_t second = uint32_t(nodes.size());
        build(mid, hi);
        const LightTreeNode& a = nodes[at + 1];
        const LightTreeNode& b = nodes[second];
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
        bool moving = false;
        for (uint32_t k = lo; k < hi && !moving; ++k) moving = moves(order[k]);
        if (len > 1e-3f * float(hi - lo) && !moving) {
            n.axis = sum / len;
            float c = 1.f;
            for (uint32_t k = lo; k < hi; ++k) c = std::min(c, glm::dot(n.axis, s.light_triangles[order[k]].n));
            n.cos_o = std::max(-1.f, c - 1e-4f);
        } else {
            n.axis = glm::vec3(0.f, 0.f, 1.f);
            n.cos_o = -1.f;
        }
        nodes[at] = n;
    }
};

// Folds the binary tree into four-wide nodes: lane by lane the grandchildren of binary node
// `at` (or a child itself where it is a leaf).
struct Folder {
    const std::vector<LightTreeNode>& bin;
    LightTree& t;

    uint32_t fold(uint32_t at, int level, uint64_t bits) {
        uint32_t lanes[4];
        int count = 0;
        const LightTreeNode& node = bin[at];
        if (node.leaf) lanes[count++] = at;  // a tree of one light triangle
        else
            for (uint32_t c : {at + 1, node.child}) {
                if (bin[c].leaf) lanes[count++] = c;
                else lanes[count++] = c + 1, lanes[count++] = bin[c].child;
            }
        const uint32_t me = uint32_t(t.nodes.size());
        t.nodes.emplace_back();
        LightTreeNode4 w{};
        for (int k = 0; k < count; ++k) {
            const LightTreeNode& l = bin[lanes[k]];
            for (int a = 0; a < 3; ++a) {
                w.lo[a][k] = l.bounds.lo[a];
                w.hi[a][k] = l.bounds.hi[a];
                w.centre[a][k] = l.centre[a];
                w.axis[a][k] = l.axis[a];
            }
            w.radius[k] = l.radius;
            w.radius2[k] = l.radius2;
            w.cos_o[k] = l.cos_o;
            w.sin_o[k] = l.sin_o;
            w.power[k] = l.power;
            w.two_sided[k] = l.two_sided ? 1.f : 0.f;
            const uint64_t path = bits | (uint64_t(k) << (2 * level));
            if (l.leaf) {
                w.leaf |= uint8_t(1u << k);
                w.child[k] = l.child;
                t.path[l.child] = path;
            } else {
                w.child[k] = fold(lanes[k], level + 1, path);
            }
        }
        t.nodes[me] = w;
        return me;
    }
};

}  // namespace

LightTree build_light_tree(const RenderScene& s) {
    LightTree t;
    const uint32_t n = uint32_t(s.light_triangles.size());
    if (n == 0) return t;
    t.path.assign(n, 0);
    std::vector<LightTreeNode> bin;
    bin.reserve(size_t(2) * n);
    Builder b{s, std::vector<uint32_t>(n), std::vector<glm::vec3>(n), bin};
    std::iota(b.order.begin(), b.order.end(), 0u);
    for (uint32_t i = 0; i < n; ++i) {
        const LightTriangle& lt = s.light_triangles[i];
        b.centroid[i] = lt.p0 + (lt.e1 + lt.e2) * (1.f / 3.f);
    }
    b.build(0, n);
    for (LightTreeNode& node : bin) {
        node.centre = node.bounds.centroid();
        node.radius2 = 0.25f * glm::dot(node.bounds.extent(), node.bounds.extent());
        node.radius = std::sqrt(node.radius2);
        node.sin_o = safe_sqrt(1.f - node.cos_o * node.cos_o);
    }
    t.nodes.reserve(bin.size() / 2 + 1);
    Folder{bin, t}.fold(0, 0, 0);
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

LightTreeNode lane_node(const LightTreeNode4& w, int k) {
    LightTreeNode l;
    for (int a = 0; a < 3; ++a) {
        l.bounds.lo[a] = w.lo[a][k];
        l.bounds.hi[a] = w.hi[a][k];
        l.centre[a] = w.centre[a][k];
        l.axis[a] = w.axis[a][k];
    }
    l.radius = w.radius[k];
    l.radius2 = w.radius2[k];
    l.cos_o = w.cos_o[k];
    l.sin_o = w.sin_o[k];
    l.power = w.power[k];
    l.two_sided = w.two_sided[k] != 0.f;
    l.leaf = (w.leaf >> k) & 1;
    l.child = w.child[k];
    return l;
}

namespace {

// Four floats in one SIMD register (GCC's vector extension: SSE on x86-64, plain code where
// there is none); comparisons give lane masks, `?:` selects lane by lane.
typedef float f4 __attribute__((vector_size(16)));
typedef int i4 __attribute__((vector_size(16)));

f4 load4(const float* x) { f4 v; __builtin_memcpy(&v, x, sizeof v); return v; }
f4 splat(float x) { return f4{x, x, x, x}; }
f4 sqrt4(f4 x) {
    x = x > 0.f ? x : 0.f;
#if defined(__SSE__)
    return (f4)_mm_sqrt_ps((__m128)x);
#else
    return f4{std::sqrt(x[0]), std::sqrt(x[1]), std::sqrt(x[2]), std::sqrt(x[3])};
#endif
}
f4 cos_sub_clamped4(f4 sin_a, f4 cos_a, f4 sin_b, f4 cos_b) { return cos_a > cos_b ? splat(1.f) : cos_a * cos_b + sin_a * sin_b; }
f4 sin_sub_clamped4(f4 sin_a, f4 cos_a, f4 sin_b, f4 cos_b) { return cos_a > cos_b ? splat(0.f) : sin_a * cos_b - cos_a * sin_b; }

}  // namespace

// light_importance, lane by lane: the same operations in the same order, so each lane gives
// the scalar function's result (LightTree.FourLanesAreTheScalarImportance).
void light_importance4(const LightTreeNode4& w, const glm::vec3& p, const glm::vec3& n, float span_out[4], float centre_out[4]) {
    const f4 tx = splat(p.x) - load4(w.centre[0]), ty = splat(p.y) - load4(w.centre[1]), tz = splat(p.z) - load4(w.centre[2]);
    const f4 r = load4(w.radius), r2 = load4(w.radius2);
    const f4 dc2 = tx * tx + ty * ty + tz * tz, dc = sqrt4(dc2);
    // The farthest corner along n: per axis the box's high side where n points up that axis.
    const f4 fx = n.x >= 0.f ? load4(w.hi[0]) : load4(w.lo[0]), fy = n.y >= 0.f ? load4(w.hi[1]) : load4(w.lo[1]),
             fz = n.z >= 0.f ? load4(w.hi[2]) : load4(w.lo[2]);
    const i4 behind = splat(n.x) * (fx - p.x) + splat(n.y) * (fy - p.y) + splat(n.z) * (fz - p.z) < splat(-1e-5f) * (dc + r);
    const i4 outside = dc2 > r2;
    const f4 sin_b = outside ? r / dc : splat(0.f);
    const f4 cos_b = outside ? sqrt4(1.f - sin_b * sin_b) : splat(-1.f);
    const i4 away = dc > 0.f;
    const f4 inv = away ? 1.f / dc : splat(0.f);
    const f4 wx = tx * inv, wy = ty * inv, wz = away ? tz * inv : splat(1.f);
    f4 cos_w = load4(w.axis[0]) * wx + load4(w.axis[1]) * wy + load4(w.axis[2]) * wz;
    cos_w = load4(w.two_sided) != 0.f ? (cos_w < 0.f ? -cos_w : cos_w) : cos_w;
    const f4 sin_w = sqrt4(1.f - cos_w * cos_w);
    const f4 cos_o = load4(w.cos_o), sin_o = load4(w.sin_o);
    const f4 cos_x = cos_sub_clamped4(sin_w, cos_w, sin_o, cos_o);
    const f4 sin_x = sin_sub_clamped4(sin_w, cos_w, sin_o, cos_o);
    const f4 cos_p = cos_sub_clamped4(sin_x, cos_x, sin_b, cos_b);
    const f4 cos_i = -(wx * n.x + wy * n.y + wz * n.z);
    const f4 sin_i = sqrt4(1.f - cos_i * cos_i);
    const f4 angular = load4(w.power) * cos_p * cos_sub_clamped4(sin_i, cos_i, sin_b, cos_b);
    const i4 lit = (behind == 0) & (cos_p > 0.f) & (angular > 0.f);
    const f4 nx = load4(w.lo[0]) > p.x ? load4(w.lo[0]) : (load4(w.hi[0]) < p.x ? load4(w.hi[0]) : splat(p.x));
    const f4 ny = load4(w.lo[1]) > p.y ? load4(w.lo[1]) : (load4(w.hi[1]) < p.y ? load4(w.hi[1]) : splat(p.y));
    const f4 nz = load4(w.lo[2]) > p.z ? load4(w.lo[2]) : (load4(w.hi[2]) < p.z ? load4(w.hi[2]) : splat(p.z));
    const f4 gx = splat(p.x) < load4(w.centre[0]) ? load4(w.hi[0]) : load4(w.lo[0]);
    const f4 gy = splat(p.y) < load4(w.centre[1]) ? load4(w.hi[1]) : load4(w.lo[1]);
    const f4 gz = splat(p.z) < load4(w.centre[2]) ? load4(w.hi[2]) : load4(w.lo[2]);
    const f4 ax = p.x - nx, ay = p.y - ny, az = p.z - nz, bx = p.x - gx, by = p.y - gy, bz = p.z - gz;
    const f4 near2 = ax * ax + ay * ay + az * az, far2 = bx * bx + by * by + bz * bz;
    const f4 sd = sqrt4(near2 * far2), span_d = sd > 0.01f * r2 ? sd : 0.01f * r2;
    const f4 centre_d = dc2 > 0.0625f * r2 ? dc2 : 0.0625f * r2;
    const f4 span = lit ? angular / span_d : splat(0.f), centre = lit ? angular / centre_d : splat(0.f);
    __builtin_memcpy(span_out, &span, sizeof span);
    __builtin_memcpy(centre_out, &centre, sizeof centre);
}

namespace {

// Each lane's probability at a wide node: the average of what the two distance guesses give.
bool lane_probabilities(const LightTreeNode4& w, const glm::vec3& p, const glm::vec3& n, float prob[4]) {
    float span[4], centre[4];
    light_importance4(w, p, n, span, centre);
    const float ss = (span[0] + span[1]) + (span[2] + span[3]), cs = (centre[0] + centre[1]) + (centre[2] + centre[3]);
    const bool by_span = ss > 0.f && std::isfinite(ss), by_centre = cs > 0.f && std::isfinite(cs);
    if (!by_span && !by_centre) return false;
    for (int k = 0; k < 4; ++k)
        prob[k] = by_span && by_centre ? 0.5f * (span[k] / ss + centre[k] / cs) : by_span ? span[k] / ss : centre[k] / cs;
    return true;
}

}  // namespace

bool sample_light_tree(const LightTree& t, const glm::vec3& p, const glm::vec3& n, float& u, uint32_t& light_triangle, float& pmf) {
    if (t.nodes.empty()) return false;
    uint32_t at = 0;
    pmf = 1.f;
    for (;;) {
        const LightTreeNode4& w = t.nodes[at];
        float prob[4];
        if (!lane_probabilities(w, p, n, prob)) return false;
        // The lane u falls in; rounding that leaves u past the last lane's end takes the last
        // lane with any probability.
        int k = -1;
        float before = 0.f;
        for (int j = 0; j < 4; ++j) {
            if (!(prob[j] > 0.f)) continue;
            k = j;
            if (u < before + prob[j]) break;
            if (j < 3) before += prob[j];
        }
        if (k < 0) return false;
        u = std::min(std::max(u - before, 0.f) / prob[k], 0x1.fffffep-1f);
        pmf *= prob[k];
        if ((w.leaf >> k) & 1) {
            light_triangle = w.child[k];
            return pmf > 0.f;
        }
        at = w.child[k];
    }
}

float light_tree_pmf(const LightTree& t, const glm::vec3& p, const glm::vec3& n, uint32_t tri) {
    if (t.nodes.empty() || tri >= t.path.size()) return 0.f;
    uint32_t at = 0;
    float pmf = 1.f;
    for (int level = 0;; ++level) {
        const LightTreeNode4& w = t.nodes[at];
        float prob[4];
        if (!lane_probabilities(w, p, n, prob)) return 0.f;
        const int k = int((t.path[tri] >> (2 * level)) & 3);
        pmf *= prob[k];
        if (!(pmf > 0.f)) return 0.f;
        if ((w.leaf >> k) & 1) return w.child[k] == tri ? pmf : 0.f;
        at = w.child[k];
    }
}

}  // namespace tessera
