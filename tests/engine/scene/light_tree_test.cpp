#include "engine/scene/light_tree.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "engine/render/light_sampler.h"
#include "engine/sampling/rng.h"
#include "engine/scene/procedural.h"
#include "engine/scene/render_scene.h"
#include "tests/test_scale.h"

namespace tessera {
namespace {

glm::vec3 random_direction(Pcg32& r) {
    const float z = 1.f - 2.f * r.next_float(), phi = 6.2831853f * r.next_float(), s = std::sqrt(std::max(0.f, 1.f - z * z));
    return {s * std::cos(phi), z, s * std::sin(phi)};
}

// The tree's probabilities over all light triangles sum to one where every light is in front
// of the surface (points on the floor facing up), and to at most one elsewhere: a walk can end
// where both children lie behind the surface although their parent's box did not (a sample
// spent on nothing, as one sent to a light behind the surface would be; never a bias).
TEST(LightTree, PmfSumsToOne) {
    const RenderScene s = build_render_scene(scattered_lights(200), {});
    ASSERT_EQ(s.light_triangles.size(), 400u);
    // 399 binary nodes above 400 leaves, folded two levels at a time.
    ASSERT_GE(s.light_tree.nodes.size(), 399u / 3);
    ASSERT_LE(s.light_tree.nodes.size(), 399u);
    Pcg32 r(3, 4);
    double lost = 0;
    for (int k = 0; k < 50; ++k) {
        const glm::vec3 floor(-0.95f + 1.9f * r.next_float(), 0.02f, -0.95f + 1.9f * r.next_float());
        const glm::vec3 p(-0.95f + 1.9f * r.next_float(), 0.02f + 1.45f * r.next_float(), -0.95f + 1.9f * r.next_float());
        const glm::vec3 n = random_direction(r);
        double on_floor = 0, anywhere = 0;
        for (uint32_t i = 0; i < s.light_triangles.size(); ++i) {
            on_floor += light_tree_pmf(s.light_tree, floor, glm::vec3(0.f, 1.f, 0.f), i);
            anywhere += light_tree_pmf(s.light_tree, p, n, i);
        }
        EXPECT_NEAR(on_floor, 1.0, 1e-4) << "point " << k;
        EXPECT_LE(anywhere, 1.0 + 1e-4) << "point " << k;
        lost += (1 - anywhere) / 50;
    }
    // Half the lights lie behind a random plane through the box; little of that is lost.
    EXPECT_LT(lost, 0.15);
}

// Sampling picks each triangle as often as its pmf says (every triangle within 5 standard
// errors of its expected count), reports that pmf, and fails as often as the pmfs fall short
// of one.
TEST(LightTree, SamplingFollowsThePmf) {
    const RenderScene s = build_render_scene(scattered_lights(100), {});
    const glm::vec3 p(0.1f, 0.7f, -0.2f), n = glm::normalize(glm::vec3(0.3f, 1.f, 0.2f));
    const size_t m = s.light_triangles.size();
    std::vector<double> pmf(m), count(m, 0.0);
    double total = 0;
    for (uint32_t i = 0; i < m; ++i) total += pmf[i] = light_tree_pmf(s.light_tree, p, n, i);
    Pcg32 r(5, 6);
    const int draws = 400000 / test::kWorkScale;
    double failed = 0;
    for (int k = 0; k < draws; ++k) {
        float u = r.next_float(), q = 0.f;
        uint32_t lt = 0;
        if (!sample_light_tree(s.light_tree, p, n, u, lt, q)) {
            ++failed;
            continue;
        }
        ASSERT_NEAR(q, pmf[lt], 1e-5 * pmf[lt] + 1e-9);
        ASSERT_GE(u, 0.f);
        ASSERT_LT(u, 1.f);
        count[lt] += 1;
    }
    for (size_t i = 0; i < m; ++i) {
        const double expect = pmf[i] * draws, sd = std::sqrt(std::max(expect * (1 - pmf[i]), 1.0));
        EXPECT_NEAR(count[i], expect, 5 * sd + 1) << "triangle " << i;
    }
    const double expect_failed = (1 - total) * draws;
    EXPECT_NEAR(failed, expect_failed, 5 * std::sqrt(std::max(expect_failed, 1.0)) + 1);
}

// The bounds are conservative: wherever a point on a light triangle sends light to p (its face
// toward p, p's surface toward it), the tree gives that triangle a nonzero probability. A zero
// there would be a bias no test of means could see at these counts.
TEST(LightTree, NeverRulesOutALightThatReaches) {
    const RenderScene s = build_render_scene(scattered_lights(300), {});
    Pcg32 r(9, 9);
    int reaching = 0;
    for (int k = 0; k < 40; ++k) {
        const glm::vec3 p(-0.95f + 1.9f * r.next_float(), 0.02f + 1.45f * r.next_float(), -0.95f + 1.9f * r.next_float());
        const glm::vec3 n = random_direction(r);
        for (uint32_t i = 0; i < s.light_triangles.size(); ++i) {
            for (int j = 0; j < 4; ++j) {
                LightSample ls;
                const glm::vec2 uv(r.next_float(), r.next_float());
                if (!sample_light_triangle(s, i, uv, p, glm::vec3(0.f), ls)) continue;
                if (glm::dot(n, ls.wi) <= 0.f) continue;
                ++reaching;
                ASSERT_GT(light_tree_pmf(s.light_tree, p, n, i), 0.f) << "point " << k << " triangle " << i;
            }
        }
    }
    EXPECT_GT(reaching, 10000);
}

// The four-wide walk evaluates four lanes at once; each lane gives what the scalar importance
// gives for that lane as a node of its own, at points inside, beside and far from the lights,
// with every kind of normal.
TEST(LightTree, FourLanesAreTheScalarImportance) {
    const RenderScene s = build_render_scene(scattered_lights(300), {});
    Pcg32 r(7, 1);
    int compared = 0;
    for (int k = 0; k < 200; ++k) {
        const float scale = k % 3 == 0 ? 10.f : 1.f;
        const glm::vec3 p = scale * glm::vec3(-1.2f + 2.4f * r.next_float(), -0.2f + 1.9f * r.next_float(), -1.2f + 2.4f * r.next_float());
        const glm::vec3 n = random_direction(r);
        for (const LightTreeNode4& w : s.light_tree.nodes) {
            float span[4], centre[4];
            light_importance4(w, p, n, span, centre);
            for (int lane = 0; lane < 4; ++lane) {
                const LightImportance one = light_importance(lane_node(w, lane), p, n);
                EXPECT_FLOAT_EQ(span[lane], one.span) << "point " << k << " lane " << lane;
                EXPECT_FLOAT_EQ(centre[lane], one.centre) << "point " << k << " lane " << lane;
                compared += one.any();
            }
        }
    }
    EXPECT_GT(compared, 10000);
}

// The receiver is one-sided, like the direct-light estimate: from under the ceiling's lamps a
// surface facing down can be reached by none of them, one facing up by all, one facing sideways
// by none of those well behind it.
TEST(LightTree, LightsBehindTheSurfaceGetNothing) {
    const RenderScene s = build_render_scene(many_lights(32), {});
    const glm::vec3 p(0.f, 0.5f, 0.f);
    float u = 0.5f, pmf = 0.f;
    uint32_t lt = 0;
    EXPECT_FALSE(sample_light_tree(s.light_tree, p, glm::vec3(0.f, -1.f, 0.f), u, lt, pmf));
    double up = 0, side = 0;
    size_t on_side = 0;
    for (uint32_t i = 0; i < s.light_triangles.size(); ++i) {
        const LightTriangle& t = s.light_triangles[i];
        EXPECT_EQ(light_tree_pmf(s.light_tree, p, glm::vec3(0.f, -1.f, 0.f), i), 0.f);
        up += light_tree_pmf(s.light_tree, p, glm::vec3(0.f, 1.f, 0.f), i);
        const float q = light_tree_pmf(s.light_tree, p, glm::vec3(1.f, 0.f, 0.f), i);
        side += q;
        const float x_max = std::max({t.p0.x, t.p0.x + t.e1.x, t.p0.x + t.e2.x});
        // Wholly behind by more than a lamp's size (a leaf bounds its triangle by a sphere).
        if (x_max < p.x - 0.2f) {
            EXPECT_EQ(q, 0.f) << "triangle " << i << " lies wholly behind";
        }
        if (x_max > p.x) ++on_side;
    }
    EXPECT_NEAR(up, 1.0, 1e-4);
    EXPECT_LE(side, 1.0 + 1e-4);
    EXPECT_GT(side, 0.5);
    EXPECT_GT(on_side, 0u);
    EXPECT_LT(on_side, s.light_triangles.size());
}

}  // namespace
}  // namespace tessera
