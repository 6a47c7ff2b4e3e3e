#pragma once
// A light hierarchy (Conty Estevez & Kulla 2018, as pbrt-v4's BVHLightSampler): a binary tree
// over every emitting triangle (walked four lanes at a time, LightTreeNode4), each node bounding its triangles' positions, normals (a cone)
// and power. A shading point walks it from the root, choosing each child in proportion to an
// importance that estimates what the child's lights can send it (power, distance, orientation;
// the average of two distance guesses' probabilities, as Cycles averages two bounds'),
// so with many lights the samples go where the light comes from; the probability of any
// triangle is the product of the choices on its path, which MIS evaluates the same way.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "engine/geometry/aabb.h"

namespace tessera {

struct RenderScene;

struct LightTreeNode {
    Aabb bounds;
    // The bounds' centre and bounding sphere, kept with the node: a walk evaluates two nodes a
    // level, and this is most of its time.
    glm::vec3 centre{0.f};
    float radius = 0.f, radius2 = 0.f;
    glm::vec3 axis{0.f, 0.f, 1.f};  // normals lie within acos(cos_o) of it
    float cos_o = 1.f, sin_o = 0.f;
    float power = 0.f;              // luminance × area, doubled for two-sided emitters
    bool two_sided = false;
    uint32_t child = 0;             // inner: the second child (the first is the next node); leaf: the light triangle
    bool leaf = false;
};

// Four nodes side by side, lane by lane (the binary tree with every other level folded in: a
// node's grandchildren, or its child where that is a leaf), so a walk evaluates four
// importances at once in SIMD lanes and takes half as many steps. Unused lanes have no power.
struct LightTreeNode4 {
    alignas(16) float lo[3][4], hi[3][4], centre[3][4], axis[3][4];
    alignas(16) float radius[4], radius2[4], cos_o[4], sin_o[4], power[4], two_sided[4];
    uint32_t child[4];  // an inner lane: its LightTreeNode4; a leaf lane: its light triangle
    uint8_t leaf = 0;   // a bit per lane
};

struct LightTree {
    std::vector<LightTreeNode4> nodes;  // depth first; the root is nodes[0]
    // Per light triangle: its path from the root, two bits per level (the lane).
    std::vector<uint64_t> path;
    bool empty() const { return nodes.empty(); }
};

// Over s.light_triangles (and their area lights); empty when there are none. The binary tree's
// median splits bound its depth by log₂ n + 1, so a path fits 32 four-wide levels.
LightTree build_light_tree(const RenderScene& s);

// What a node's lights can send to point p on a surface with normal n (pbrt-v4's
// LightBounds::Importance), with two guesses at the node's distance: `span` from the nearest and
// farthest points of its box, `centre` from its centre. Both 0 only where none of its lights can
// reach p from above n (the side the direct-light estimate counts).
struct LightImportance {
    float span = 0.f, centre = 0.f;
    bool any() const { return span > 0.f || centre > 0.f; }
};
LightImportance light_importance(const LightTreeNode& node, const glm::vec3& p, const glm::vec3& n);
// The same for the four lanes of a wide node, at once (lanes without power get none).
void light_importance4(const LightTreeNode4& node, const glm::vec3& p, const glm::vec3& n, float span[4], float centre[4]);
// Lane k of a wide node as a node of its own (the scalar light_importance's input).
LightTreeNode lane_node(const LightTreeNode4& node, int k);

// Picks a light triangle for p with probability `pmf`; u in [0, 1) is consumed and returned
// rescaled (so a stratified u stays stratified for what it samples next). False if no light
// can reach p.
bool sample_light_tree(const LightTree& t, const glm::vec3& p, const glm::vec3& n, float& u, uint32_t& light_triangle, float& pmf);

// The probability sample_light_tree gives light triangle `tri` at p.
float light_tree_pmf(const LightTree& t, const glm::vec3& p, const glm::vec3& n, uint32_t tri);

}  // namespace tessera
