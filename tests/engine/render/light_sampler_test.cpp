#include "engine/render/light_sampler.h"
#include "engine/scene/intersect.h"

#include <gtest/gtest.h>

#include "engine/geometry/triangle.h"
#include "tests/test_scale.h"

namespace tessera {
namespace {

// A rectangle a × b at height d above the origin, made of two triangles (one light).
RenderScene rectangle_light(float a, float b, float d) {
    SceneDescription s;
    MaterialDesc m;
    m.kind = MaterialKind::emission;
    m.emission = glm::vec3(1.f);
    s.materials.push_back(m);
    MeshDesc q;
    q.positions = {{-a / 2, d, -b / 2}, {a / 2, d, -b / 2}, {a / 2, d, b / 2}, {-a / 2, d, b / 2}};
    q.indices = {0, 1, 2, 0, 2, 3};  // normal −y, toward the origin
    q.material = 0;
    s.meshes.push_back(q);
    return build_render_scene(s, {});
}

// E[1/pdf] over light samples is the solid angle the light subtends; for a rectangle seen
// from its axis that is 4·asin(ab / √((a² + 4d²)(b² + 4d²))).
TEST(LightSampler, InversePdfMeanIsTheSolidAngle) {
    const float a = 0.8f, b = 0.6f, d = 0.7f;
    const RenderScene s = rectangle_light(a, b, d);
    ASSERT_EQ(s.area_lights.size(), 1u);
    const double exact = 4.0 * std::asin(a * b / std::sqrt((a * a + 4 * d * d) * (b * b + 4 * d * d)));
    Pcg32 rng(1, 1);
    const int n = 400000 / test::kWorkScale;
    double sum = 0, sum2 = 0;
    for (int i = 0; i < n; ++i) {
        LightSample ls;
        ASSERT_TRUE(sample_area_light(s, s.area_lights[0], glm::vec3(0.f), rng, ls));
        const double v = 1.0 / ls.pdf_w;
        sum += v;
        sum2 += v * v;
    }
    const double mean = sum / n, se = std::sqrt((sum2 / n - mean * mean) / n);
    EXPECT_NEAR(mean, exact, 5 * se + 1e-9) << "se " << se;
}

// The same with Sobol points, whose one 2-D draw both picks the triangle and places the point
// on it: E[1/pdf] over pixels (independent scrambles) is still the solid angle, and a pixel's
// 64 points cover the light far more evenly than 64 independent ones (the spread of the
// per-pixel means is what stratification removes).
TEST(LightSampler, SobolPointsKeepTheSolidAngleAndStratifyTheLight) {
    const float a = 0.8f, b = 0.6f, d = 0.7f;
    const RenderScene s = rectangle_light(a, b, d);
    const double exact = 4.0 * std::asin(a * b / std::sqrt((a * a + 4 * d * d) * (b * b + 4 * d * d)));
    const int pixels = 4000 / test::kWorkScale, spp = 64;
    double spread[2] = {0, 0};
    for (SamplerKind k : {SamplerKind::sobol, SamplerKind::independent}) {
        double sum = 0, sum2 = 0;
        for (int px = 0; px < pixels; ++px) {
            double pixel = 0;
            for (int i = 0; i < spp; ++i) {
                Sampler rng(k, 5, uint64_t(px), uint64_t(i));
                LightSample ls;
                ASSERT_TRUE(sample_area_light(s, s.area_lights[0], glm::vec3(0.f), rng, ls));
                pixel += 1.0 / ls.pdf_w / spp;
            }
            sum += pixel;
            sum2 += pixel * pixel;
        }
        const double mean = sum / pixels, sd = std::sqrt(std::max(0.0, sum2 / pixels - mean * mean));
        EXPECT_NEAR(mean, exact, 5 * sd / std::sqrt(double(pixels)) + 1e-9) << "sobol " << (k == SamplerKind::sobol);
        spread[k == SamplerKind::sobol ? 0 : 1] = sd;
    }
    EXPECT_LT(spread[0], 0.25 * spread[1]) << "Sobol " << spread[0] << ", independent " << spread[1];
}

// The pdf, evaluated at directions that reach the light, integrates to one over the sphere
// (estimated with uniform directions: E[4π·pdf] = 1).
TEST(LightSampler, PdfIntegratesToOne) {
    const RenderScene s = rectangle_light(0.8f, 0.6f, 0.7f);
    Pcg32 rng(2, 2);
    const int n = 2000000 / test::kWorkScale;
    double sum = 0, sum2 = 0;
    for (int i = 0; i < n; ++i) {
        const float z = 1.f - 2.f * rng.next_float(), phi = 2.f * kPi * rng.next_float();
        const float r = std::sqrt(std::max(0.f, 1.f - z * z));
        const glm::vec3 w(r * std::cos(phi), z, r * std::sin(phi));
        double v = 0;
        for (uint32_t slot = 0; slot < 4 * s.tri_blocks.size(); ++slot) {
            const TriangleVerts t = triangle4_verts(s.tri_blocks[slot / 4], int(slot % 4));
            TriangleHit h;
            const Ray ray{glm::vec3(0.f), 0.f, w, INFINITY};
            if (intersect_triangle_watertight(ray, make_watertight_ray(w), t.p0, t.p1, t.p2, h)) {
                const glm::vec3 ng = glm::normalize(glm::cross(t.p1 - t.p0, t.p2 - t.p0));
                v = 4.0 * M_PI * area_light_pdf(s.area_lights[0], ng, w, h.t);
                break;
            }
        }
        sum += v;
        sum2 += v * v;
    }
    const double mean = sum / n, se = std::sqrt((sum2 / n - mean * mean) / n);
    EXPECT_NEAR(mean, 1.0, 5 * se) << "se " << se;
}

// Triangles of one light are picked in proportion to their area.
TEST(LightSampler, PicksTrianglesByArea) {
    SceneDescription s;
    MaterialDesc m;
    m.kind = MaterialKind::emission;
    m.emission = glm::vec3(1.f);
    s.materials.push_back(m);
    MeshDesc q;  // triangles of area 0.5 and 3, both at y = 1
    q.positions = {{0, 1, 0}, {1, 1, 0}, {0, 1, 1}, {2, 1, 0}, {5, 1, 0}, {2, 1, 2}};
    q.indices = {0, 1, 2, 3, 4, 5};
    q.material = 0;
    s.meshes.push_back(q);
    const RenderScene rs = build_render_scene(s, {});
    Pcg32 rng(3, 3);
    const int n = 200000;
    int large = 0;
    for (int i = 0; i < n; ++i) {
        LightSample ls{};
        sample_area_light(rs, rs.area_lights[0], glm::vec3(0.5f, 0.f, 0.5f), rng, ls);
        large += ls.point.x >= 2.f;
    }
    // p = 3/3.5; se = √(p(1−p)/n) ≈ 0.00078.
    EXPECT_NEAR(double(large) / n, 3.0 / 3.5, 0.004);
}

}  // namespace
}  // namespace tessera
