#include "engine/render/seen_emitters.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "engine/material/material.h"
#include "engine/render/renderer.h"

namespace tessera {

namespace {

struct P2 {
    double x, y;
};

// Sutherland–Hodgman against one axis-aligned edge: keeps the side where sign·(coord − at) ≥ 0.
int clip(const P2* in, int n, P2* out, int axis, double at, double sign) {
    int m = 0;
    for (int i = 0; i < n; ++i) {
        const P2 a = in[i], b = in[(i + 1) % n];
        const double da = sign * ((axis ? a.y : a.x) - at), db = sign * ((axis ? b.y : b.x) - at);
        if (da >= 0) out[m++] = a;
        if ((da >= 0) != (db >= 0)) {
            const double t = da / (da - db);
            out[m++] = P2{a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)};
        }
    }
    return m;
}

// The area of triangle `t` (image pixel units) within the unit square at (px, py).
double area_in_pixel(const std::array<P2, 3>& t, int px, int py) {
    P2 a[8], b[8];
    int n = 3;
    std::copy(t.begin(), t.end(), a);
    n = clip(a, n, b, 0, px, 1.0);
    n = clip(b, n, a, 0, px + 1.0, -1.0);
    n = clip(a, n, b, 1, py, 1.0);
    n = clip(b, n, a, 1, py + 1.0, -1.0);
    double s = 0;
    for (int i = 0; i < n; ++i) s += a[i].x * a[(i + 1) % n].y - a[(i + 1) % n].x * a[i].y;
    return std::abs(s) * 0.5;
}

}  // namespace

SeenEmitters seen_emitters(const RenderScene& scene, const RenderSettings& settings, const Camera& camera, int x0, int y0, int w, int h) {
    SeenEmitters out;
    out.x0 = x0;
    out.y0 = y0;
    out.width = std::max(0, w);
    out.height = std::max(0, h);
    const auto& tris = scene.light_triangles;
    if (tris.empty() || tris.size() > kSeenEmittersMaxTriangles || out.width == 0 || out.height == 0) return out;
    if (settings.integrator != Integrator::path || !counts_bounce(settings, 0)) return out;
    if (camera.lens_radius > 0.f || scene.motion.camera || !scene.motion.light_triangles_close.empty()) return out;

    const size_t pixels = size_t(out.width) * size_t(out.height);
    // Per pixel its (lamp, coverage) entries, gathered lamp by lamp, then laid out per pixel.
    struct Entry {
        uint32_t pixel, lamp;
        double coverage;
    };
    std::vector<Entry> entries;
    // Each (pixel, lamp) pair is a control variate of its own, so a pixel may take some of the
    // lamps over it and leave the rest to the samples: at most kPerPixel, the first in the
    // scene's order, whatever rectangle is asked for (a farm's tile gets a process's pixels).
    constexpr uint8_t kPerPixel = 4;  // a quad's two triangles at its diagonal, and two lamps meeting
    std::vector<uint8_t> taken(pixels, 0);
    // And the work: the lamps' boxes on the whole image (not on the rectangle, so that every
    // rectangle stops at the same lamp) may cover 64 images in all; a hostile scene of many large
    // overlapping emitters stops there, and the lamps after are left to the samples.
    const double W = settings.width, H = settings.height;
    const double work_budget = 64.0 * W * H;
    double work = 0;
    for (const LightTriangle& lt : tris) {
        ++out.lamps_considered;
        if (lt.light >= scene.area_lights.size()) continue;
        const AreaLight& al = scene.area_lights[lt.light];
        if (al.material >= scene.materials.size()) continue;
        const Material& m = scene.materials[al.material];
        if (!m.emissive() || m.textures != kNoTextures) continue;
        const glm::vec3 p[3] = {lt.p0, lt.p0 + lt.e1, lt.p0 + lt.e2};
        // Facing: a one-sided lamp shows the camera its front or nothing.
        const glm::vec3 n = glm::cross(lt.e1, lt.e2);
        if (!m.double_sided && glm::dot(n, camera.position - lt.p0) <= 0.f) continue;
        std::array<P2, 3> s{};
        bool ok = true;
        double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
        for (int k = 0; k < 3 && ok; ++k) {
            const glm::dvec3 q = glm::dvec3(p[k]) - glm::dvec3(camera.position);
            const double z = glm::dot(q, glm::dvec3(camera.forward));
            // Wholly between the clip planes along every ray: the distance is at least the depth
            // (a vertex's is the least, as depth is linear) and at most the farthest vertex's.
            if (!(z >= double(camera.znear)) || !(glm::length(q) <= double(camera.zfar))) ok = false;
            const double u = 0.5 * (glm::dot(q, glm::dvec3(camera.right)) / (z * camera.tan_half_w) + 1.0);
            const double v = 0.5 * (glm::dot(q, glm::dvec3(camera.up)) / (z * camera.tan_half_h) + 1.0);
            s[size_t(k)] = P2{u * W, (1.0 - v) * H};  // image pixels: x right, y down, as the sample loop's
            // Far off the image (a vertex just past the near plane) the clipping would lose digits.
            if (!(std::abs(s[size_t(k)].x) < 1e6 * W) || !(std::abs(s[size_t(k)].y) < 1e6 * H)) ok = false;
            xmin = std::min(xmin, s[size_t(k)].x);
            xmax = std::max(xmax, s[size_t(k)].x);
            ymin = std::min(ymin, s[size_t(k)].y);
            ymax = std::max(ymax, s[size_t(k)].y);
        }
        if (!ok) continue;
        const double bw = std::min(W, std::floor(xmax) + 1) - std::max(0.0, std::floor(xmin)),
                     bh = std::min(H, std::floor(ymax) + 1) - std::max(0.0, std::floor(ymin));
        if (bw <= 0 || bh <= 0) continue;  // off the image
        work += bw * bh;
        if (work > work_budget) break;
        // Clamped in double first: a vertex just past the near plane projects far off the image.
        const double fx0 = std::max(double(x0), std::floor(xmin)), fx1 = std::min(double(x0 + out.width - 1), std::floor(xmax));
        const double fy0 = std::max(double(y0), std::floor(ymin)), fy1 = std::min(double(y0 + out.height - 1), std::floor(ymax));
        if (fx0 > fx1 || fy0 > fy1) continue;
        const int ax = int(fx0), bx = int(fx1), ay = int(fy0), by = int(fy1);
        const uint32_t id = uint32_t(out.lamps.size());
        bool any = false;
        for (int y = ay; y <= by; ++y)
            for (int x = ax; x <= bx; ++x) {
                const size_t q = size_t(y - y0) * size_t(out.width) + size_t(x - x0);
                if (taken[q] >= kPerPixel) continue;
                const double c = area_in_pixel(s, x, y);
                if (c <= 0.0) continue;
                entries.push_back({uint32_t(q), id, std::min(1.0, c)});
                ++taken[q];
                any = true;
            }
        if (any) out.lamps.push_back({lt.p0, lt.e1, lt.e2, m.emission});
    }
    if (entries.empty()) {
        out.lamps.clear();
        return out;
    }
    out.first.assign(pixels + 1, 0);
    for (const Entry& e : entries) ++out.first[e.pixel + 1];
    for (size_t q = 0; q < pixels; ++q) out.first[q + 1] += out.first[q];
    out.lamp_of.resize(entries.size());
    // Summed in double and rounded once: a pixel that two triangles of one lamp share gets the
    // lamp's radiance exactly, and a sample that hits one of them exactly none of a correction.
    std::vector<glm::dvec3> sum(pixels, glm::dvec3(0.0));
    std::vector<uint32_t> at(out.first.begin(), out.first.end() - 1);
    for (const Entry& e : entries) {
        out.lamp_of[at[e.pixel]++] = e.lamp;
        sum[e.pixel] += e.coverage * glm::dvec3(out.lamps[e.lamp].radiance);
    }
    out.mean.resize(pixels);
    for (size_t q = 0; q < pixels; ++q) out.mean[q] = glm::vec3(sum[q]);
    return out;
}

void describe_seen_emitters(const RenderScene& scene, const RenderSettings& settings, std::vector<std::string>& built,
                            std::vector<std::string>& left_out) {
    const char* what = "lamps seen directly by their exact pixel coverage (a control variate)";
    if (scene.light_triangles.empty()) return;  // nothing to see: no line
    const Camera camera = camera_for(scene, settings);
    std::string why;
    if (!counts_bounce(settings, 0) || settings.integrator != Integrator::path) why = "emitters seen directly are not in the output";
    else if (camera.lens_radius > 0.f) why = "a thin lens";
    else if (scene.motion.camera || !scene.motion.light_triangles_close.empty()) why = "the camera or a lamp moves within the shutter";
    else if (scene.light_triangles.size() > kSeenEmittersMaxTriangles)
        why = std::to_string(scene.light_triangles.size()) + " light triangles, over " + std::to_string(kSeenEmittersMaxTriangles);
    if (!why.empty()) {
        left_out.push_back(std::string(what) + " (" + why + ")");
        return;
    }
    const SeenEmitters s = seen_emitters(scene, settings, camera, 0, 0, settings.width, settings.height);
    if (s.empty()) {
        left_out.push_back(std::string(what) + " (no untextured lamp faces the camera within the image)");
        return;
    }
    size_t pixels = 0;
    for (size_t q = 0; q + 1 < s.first.size(); ++q) pixels += s.first[q + 1] > s.first[q];
    built.push_back(std::string(what) + ": " + std::to_string(s.lamps.size()) + " lamp triangles over " + std::to_string(pixels) +
                    " pixels");
}

}  // namespace tessera
