#include "engine/camera/camera.h"

#include <gtest/gtest.h>

#include "engine/sampling/rng.h"
#include "engine/sampling/warp.h"

namespace tessera {
namespace {

Camera lens_camera(float radius, float distance) {
    CameraDesc d;
    d.position = {1.f, 2.f, 3.f};
    d.look_at = {1.f, 2.f, -2.f};  // 5 units ahead
    d.vfov_deg = 40.f;
    Camera c = make_camera(d, 64, 48);
    set_thin_lens(c, d, radius, distance);
    return c;
}

// Every ray of a pixel through a thin lens meets the pinhole ray in the plane in focus, and
// leaves from a point of the lens.
TEST(Camera, ThinLensFocusesItsPlane) {
    const Camera c = lens_camera(0.2f, 3.f);
    Pcg32 rng(1, 2);
    for (int i = 0; i < 1000; ++i) {
        const float u = rng.next_float(), v = rng.next_float();
        const Ray pin = generate_ray(c, u, v);
        const glm::vec2 l = sample_concentric_disk(rng.next_float(), rng.next_float());
        const Ray r = generate_ray(c, u, v, l);
        EXPECT_LE(glm::length(r.o - c.position), 0.2f + 1e-5f);
        EXPECT_NEAR(glm::dot(r.o - c.position, c.forward), 0.f, 1e-5f);  // on the lens plane
        const glm::vec3 a = pin.o + pin.d * (3.f / glm::dot(pin.d, c.forward));
        const glm::vec3 b = r.o + r.d * ((3.f - glm::dot(r.o - c.position, c.forward)) / glm::dot(r.d, c.forward));
        EXPECT_NEAR(glm::length(a - b), 0.f, 1e-4f);
        EXPECT_NEAR(glm::length(r.d), 1.f, 1e-5f);
    }
}

// Distance 0 focuses on the look-at point; radius 0 is the pinhole.
TEST(Camera, ThinLensDefaults) {
    EXPECT_NEAR(lens_camera(0.1f, 0.f).focal_distance, 5.f, 1e-5f);
    const Camera pin = lens_camera(0.f, 0.f);
    const Ray a = generate_ray(pin, 0.3f, 0.6f), b = generate_ray(pin, 0.3f, 0.6f, {0.7f, -0.2f});
    EXPECT_NEAR(glm::length(a.o - b.o), 0.f, 1e-6f);
    EXPECT_NEAR(glm::length(a.d - b.d), 0.f, 1e-5f);
}

}  // namespace
}  // namespace tessera
