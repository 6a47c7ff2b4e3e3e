#pragma once
// Iterative BVH traversal: both children's boxes are tested and the nearer is visited first;
// the farther is pushed with its entry distance and skipped if a closer hit was found since.
#include <cstdint>

#include "engine/accel/bvh.h"
#include "engine/geometry/ray.h"

namespace tessera {

struct TraversalCounters {
    uint64_t nodes_visited = 0;
    uint64_t prim_tests = 0;  // leaf entries tested: a primitive, or a block of four triangles
};

// `test(prim_id, ray)` returns true on a hit and then lowers ray.tmax to the hit distance.
// Pops into `node` the next stacked subtree a closest-hit ray may still meet before tmax
// (entries hold .node and the entry distance .t); false once the stack is empty.
template <class Entry>
inline bool pop_closer(const Entry* stack, int& sp, float tmax, uint32_t& node) {
    while (sp > 0) {
        const Entry& e = stack[--sp];
        if (e.t < tmax) { node = e.node; return true; }
    }
    return false;
}

template <class PrimTest>
bool bvh_closest_hit(const Bvh& bvh, Ray& ray, PrimTest&& test, TraversalCounters& counters) {
    if (bvh.nodes.empty()) return false;
    const RayInv ri = make_ray_inv(ray.o, ray.d);
    const BvhNode* nodes = bvh.nodes.data();
    const uint32_t* prims = bvh.prim_index.data();
    struct Entry { uint32_t node; float t; };
    Entry stack[kMaxBvhDepth];
    int sp = 0;
    bool hit = false;
    if (intersect_aabb(nodes[0].lo, nodes[0].hi, ri, ray.tmin, ray.tmax) == INFINITY) return false;
    uint32_t current = 0;
    uint64_t visited = 0, tests = 0;
    for (;;) {
        const BvhNode& n = nodes[current];
        ++visited;
        if (n.is_leaf()) {
            for (uint32_t i = n.offset, end = n.offset + n.count; i < end; ++i) {
                ++tests;
                hit |= test(prims[i], ray);
            }
        } else {
            const uint32_t l = current + 1, r = n.offset;
            float tl = intersect_aabb(nodes[l].lo, nodes[l].hi, ri, ray.tmin, ray.tmax);
            float tr = intersect_aabb(nodes[r].lo, nodes[r].hi, ri, ray.tmin, ray.tmax);
            if (tl != INFINITY && tr != INFINITY) {
                if (tl <= tr) { stack[sp++] = {r, tr}; current = l; }
                else { stack[sp++] = {l, tl}; current = r; }
                continue;
            }
            if (tl != INFINITY) { current = l; continue; }
            if (tr != INFINITY) { current = r; continue; }
        }
        if (!pop_closer(stack, sp, ray.tmax, current)) {
            counters.nodes_visited += visited;
            counters.prim_tests += tests;
            return hit;
        }
    }
}

// Any-hit traversal for shadow rays: stops at the first primitive that reports a hit. Child
// boxes are tested before they are pushed, as in bvh_closest_hit; order does not matter here.
template <class PrimTest>
bool bvh_any_hit(const Bvh& bvh, const Ray& ray, PrimTest&& test, TraversalCounters& counters) {
    if (bvh.nodes.empty()) return false;
    const RayInv ri = make_ray_inv(ray.o, ray.d);
    const BvhNode* nodes = bvh.nodes.data();
    const uint32_t* prims = bvh.prim_index.data();
    if (intersect_aabb(nodes[0].lo, nodes[0].hi, ri, ray.tmin, ray.tmax) == INFINITY) return false;
    uint32_t stack[kMaxBvhDepth];
    int sp = 0;
    uint32_t current = 0;
    uint64_t visited = 0, tests = 0;
    bool hit = false;
    for (;;) {
        const BvhNode& n = nodes[current];
        ++visited;
        if (n.is_leaf()) {
            for (uint32_t i = n.offset, end = n.offset + n.count; i < end; ++i) {
                ++tests;
                if (test(prims[i], ray)) { hit = true; break; }
            }
            if (hit || sp == 0) break;
            current = stack[--sp];
            continue;
        }
        const uint32_t l = current + 1, r = n.offset;
        const bool hl = intersect_aabb(nodes[l].lo, nodes[l].hi, ri, ray.tmin, ray.tmax) != INFINITY;
        const bool hr = intersect_aabb(nodes[r].lo, nodes[r].hi, ri, ray.tmin, ray.tmax) != INFINITY;
        if (hl && hr) { stack[sp++] = r; current = l; }
        else if (hl) current = l;
        else if (hr) current = r;
        else if (sp == 0) break;
        else current = stack[--sp];
    }
    counters.nodes_visited += visited;
    counters.prim_tests += tests;
    return hit;
}

}  // namespace tessera
