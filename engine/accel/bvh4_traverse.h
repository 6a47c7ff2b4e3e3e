#pragma once
// Traversal of the 4-wide BVH: one slab test for four boxes (SSE, with a scalar fallback),
// children visited nearest first, subtrees beyond the closest hit skipped. The slab
// arithmetic is the same as intersect_aabb's, lane by lane, including its NaN rule.
#include <cstdint>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include "engine/accel/bvh4.h"
#include "engine/accel/bvh_traverse.h"

namespace tessera {

namespace bvh4_detail {

struct Lanes { float enter[4]; int mask; };

// The ray as the 4-wide slab test wants it, built directly in registers: copying a RayInv
// (with its packed flags) into it caused store-forwarding stalls in the profile.
struct Bvh4Ray {
    int near_row[3], far_row[3];
#if defined(__SSE2__)
    __m128 o[3], inv[3];
#else
    RayInv ri;
#endif
};

inline Bvh4Ray make_bvh4_ray(const Ray& ray) {
    Bvh4Ray r;
#if defined(__SSE2__)
    const __m128 dv = _mm_set_ps(1.f, ray.d.z, ray.d.y, ray.d.x);
    const __m128 zero = _mm_cmpeq_ps(dv, _mm_setzero_ps());
    const __m128 inv = _mm_or_ps(_mm_and_ps(zero, _mm_set1_ps(INFINITY)), _mm_andnot_ps(zero, _mm_div_ps(_mm_set1_ps(1.f), dv)));
    const int neg = _mm_movemask_ps(inv);  // sign bits: +∞ for zero components counts as positive
    r.inv[0] = _mm_shuffle_ps(inv, inv, _MM_SHUFFLE(0, 0, 0, 0));
    r.inv[1] = _mm_shuffle_ps(inv, inv, _MM_SHUFFLE(1, 1, 1, 1));
    r.inv[2] = _mm_shuffle_ps(inv, inv, _MM_SHUFFLE(2, 2, 2, 2));
    r.o[0] = _mm_set1_ps(ray.o.x);
    r.o[1] = _mm_set1_ps(ray.o.y);
    r.o[2] = _mm_set1_ps(ray.o.z);
#else
    r.ri = make_ray_inv(ray.o, ray.d);
    const int neg = int(r.ri.near_x) | int(r.ri.near_y) << 1 | int(r.ri.near_z) << 2;
#endif
    for (int a = 0; a < 3; ++a) {
        const bool n = neg & (1 << a);
        r.near_row[a] = n ? a + 3 : a;
        r.far_row[a] = n ? a : a + 3;
    }
    return r;
}

inline void slab4(const Bvh4Node& n, const Bvh4Ray& r, float tmin, float tmax, Lanes& out) {
    constexpr float widen = 1.f + 2.f * gamma(3);
#if defined(__SSE2__)
    const __m128 ox = r.o[0], oy = r.o[1], oz = r.o[2];
    const __m128 ix = r.inv[0], iy = r.inv[1], iz = r.inv[2];
    const __m128 nx = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.bounds[r.near_row[0]]), ox), ix);
    const __m128 ny = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.bounds[r.near_row[1]]), oy), iy);
    const __m128 nz = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.bounds[r.near_row[2]]), oz), iz);
    const __m128 fx = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.bounds[r.far_row[0]]), ox), ix);
    const __m128 fy = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.bounds[r.far_row[1]]), oy), iy);
    const __m128 fz = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.bounds[r.far_row[2]]), oz), iz);
    // maxps/minps return the second operand when either is NaN: the running value comes
    // second, so a NaN slab distance is ignored, as in max_nan_loses.
    __m128 enter = _mm_max_ps(nx, _mm_set1_ps(tmin));
    enter = _mm_max_ps(ny, enter);
    enter = _mm_max_ps(nz, enter);
    __m128 leave = _mm_min_ps(fx, _mm_set1_ps(tmax));
    leave = _mm_min_ps(fy, leave);
    leave = _mm_min_ps(fz, leave);
    out.mask = _mm_movemask_ps(_mm_cmple_ps(enter, _mm_mul_ps(leave, _mm_set1_ps(widen))));
    _mm_storeu_ps(out.enter, enter);
#else
    out.mask = 0;
    for (int c = 0; c < 4; ++c) {
        float enter = tmin, leave = tmax;
        for (int a = 0; a < 3; ++a) {
            const float o = r.ri.o[a], inv = r.ri.inv_d[a];  // scalar fallback
            enter = max_nan_loses((n.bounds[r.near_row[a]][c] - o) * inv, enter);
            leave = min_nan_loses((n.bounds[r.far_row[a]][c] - o) * inv, leave);
        }
        out.enter[c] = enter;
        if (enter <= leave * widen) out.mask |= 1 << c;
    }
#endif
}

struct alignas(16) Entry {
    uint32_t child;
    uint32_t count;  // 0: inner node
    float t;
    uint32_t pad;    // 16 bytes: one move per push and pop
};

inline constexpr int kStack = 3 * kMaxBvhDepth + 4;

// A tree that is one leaf: its one leaf is tested.
template <class R, class LeafTest>
bool test_root_leaf(const Bvh4& bvh, R& ray, LeafTest& test, TraversalCounters& counters) {
    counters.nodes_visited += 1;
    counters.prim_tests += bvh.root_leaf_count;
    return test(0u, bvh.root_leaf_count, ray);
}

}  // namespace bvh4_detail

// `test(first, count, ray)` tests the leaf whose entry in the tree is (first, count) (what that
// names is the caller's: primitives, or blocks of them), lowers ray.tmax to its closest hit and
// says whether there was one; for an occlusion query it says whether anything was hit. The
// nearest hit child is visited next without a stack round trip; the others are pushed
// farthest first with their entry distance, and skipped on pop once a closer hit is known.
template <class LeafTest>
bool bvh4_closest_hit(const Bvh4& bvh, Ray& ray, LeafTest&& test, TraversalCounters& counters) {
    using namespace bvh4_detail;
    if (bvh.root_leaf_count) return test_root_leaf(bvh, ray, test, counters);
    if (bvh.nodes.empty()) return false;
    bool hit = false;
    uint64_t visited = 0, tests = 0;
    const Bvh4Ray r = make_bvh4_ray(ray);
    Entry stack[kStack];
    int sp = 0;
    Entry cur{0, 0, ray.tmin, 0};
    for (;;) {
        if (cur.count) {
            tests += cur.count;
            hit |= test(cur.child, cur.count, ray);
        } else {
            const Bvh4Node& n = bvh.nodes[cur.child];
            ++visited;
            Lanes lanes;
            slab4(n, r, ray.tmin, ray.tmax, lanes);
            if (lanes.mask) {
                // Sort the hit children by entry distance, nearest last.
                Entry hits[4];
                int nh = 0;
                for (int c = 0; c < 4; ++c) {
                    if (!(lanes.mask & (1 << c))) continue;
                    const Entry h{n.child[c], n.count[c], lanes.enter[c], 0};
                    int k = nh++;
                    while (k > 0 && hits[k - 1].t < h.t) { hits[k] = hits[k - 1]; --k; }
                    hits[k] = h;
                }
                for (int k = 0; k < nh - 1; ++k) stack[sp++] = hits[k];
                cur = hits[nh - 1];
                continue;
            }
        }
        // Pop the next subtree that may still hold a closer hit.
        for (;;) {
            if (sp == 0) {
                counters.nodes_visited += visited;
                counters.prim_tests += tests;
                return hit;
            }
            cur = stack[--sp];
            if (cur.t < ray.tmax) break;
        }
    }
}

template <class LeafTest>
bool bvh4_any_hit(const Bvh4& bvh, const Ray& ray, LeafTest&& test, TraversalCounters& counters) {
    using namespace bvh4_detail;
    if (bvh.root_leaf_count) return test_root_leaf(bvh, ray, test, counters);
    if (bvh.nodes.empty()) return false;
    uint64_t visited = 0, tests = 0;
    const Bvh4Ray r = make_bvh4_ray(ray);
    Entry stack[kStack];
    int sp = 0;
    stack[sp++] = {0, 0, ray.tmin, 0};
    bool hit = false;
    while (sp > 0 && !hit) {
        const Entry e = stack[--sp];
        if (e.count) {
            tests += e.count;
            hit = test(e.child, e.count, ray);
            continue;
        }
        const Bvh4Node& n = bvh.nodes[e.child];
        ++visited;
        Lanes lanes;
        slab4(n, r, ray.tmin, ray.tmax, lanes);
        // Leaves first: a shadow ray is most likely stopped by geometry it has reached.
        for (int c = 0; c < 4; ++c)
            if ((lanes.mask & (1 << c)) && n.count[c] == 0) stack[sp++] = {n.child[c], 0, lanes.enter[c], 0};
        for (int c = 0; c < 4; ++c)
            if ((lanes.mask & (1 << c)) && n.count[c] != 0) stack[sp++] = {n.child[c], n.count[c], lanes.enter[c], 0};
    }
    counters.nodes_visited += visited;
    counters.prim_tests += tests;
    return hit;
}

}  // namespace tessera
