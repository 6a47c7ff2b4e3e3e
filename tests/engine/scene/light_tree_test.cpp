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

// The tree's probabilities over all light triangles sum to one wherever any light can reach.
TEST(LightTree, PmfSumsToOne) {
    const RenderScene s = build_render_scene(scattered_lights(200), {});
    ASSERT_EQ(s.light_triangles.size(), 400u);
    ASSERT_EQ(s.light_tree.nodes.size(), 799u);
    Pcg32 r(3, 4);
    for (int k = 0; k < 50; ++k) {
        const glm::vec3 p(-0.95f + 1.9f * r.next_float(), 0.02f + 1.45f * r.next_float(), -0.95f + 1.9f * r.next_float());
        const glm::vec3 n = random_direction(r);
        double sum = 0;
        for (uint32_t i = 0; i < s.light_triangles.size(); ++i) sum += light_tree_pmf(s.light_tree, p, n, i);
        EXPECT_NEAR(sum, 1.0, 1e-4) << "point " << k;
    }
}

// Sampling picks each triangle as often as its pmf says (every triangle within 5 standard
// errors of its expected count), and reports that pmf.
TEST(LightTree, SamplingFollowsThePmf) {
    const RenderScene s = build_render_scene(scattered_lights(100), {});
    const glm::vec3 p(0.1f, 0.7f, -0.2f), n = glm::normalize(glm::vec3(0.3f, 1.f, 0.2f));
    const size_t m = s.light_triangles.size();
    std::vector<double> pmf(m), count(m, 0.0);
    for (uint32_t i = 0; i < m; ++i) pmf[i] = light_tree_pmf(s.light_tree, p, n, i);
    Pcg32 r(5, 6);
    const int draws = 400000 / test::kWorkScale;
    for (int k = 0; k < draws; ++k) {
        float u = r.next_float(), q = 0.f;
        uint32_t lt = 0;
        ASSERT_TRUE(sample_light_tree(s.light_tree, p, n, u, lt, q));
        ASSERT_NEAR(q, pmf[lt], 1e-5 * pmf[lt] + 1e-9);
        ASSERT_GE(u, 0.f);
        ASSERT_LT(u, 1.f);
        count[lt] += 1;
    }
    for (size_t i = 0; i < m; ++i) {
        const double expect = pmf[i] * draws, sd = std::sqrt(std::max(expect * (1 - pmf[i]), 1.0));
        EXPECT_NEAR(count[i], expect, 5 * sd + 1) << "triangle " << i;
    }
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

}  // namespace
}  // namespace tessera
