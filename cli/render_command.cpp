// `tessera render`: the CS184 PathTracer flags on top of the same job fields the server takes.
// The flags become a JSON job that goes through api::parse_job, so both paths validate alike.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "api/job_spec.h"
#include "engine/io/image_io.h"
#include "engine/io/scene_loader.h"
#include "engine/render/renderer.h"
#include "cli/commands.h"

namespace tessera::cli {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr const char* kHelp = R"(usage: tessera render [flags] SCENE
SCENE is a .dae (CS184 COLLADA), .gltf/.glb file, or builtin:cornell_box|cornell_spheres|furnace|displaced_sphere
CS184 flags:
  -t N          threads (default: all)
  -s N          samples per pixel (default 1)
  -l N          light rays per area light (default 1)
  -m N          max ray depth (default 1)
  -H            hemisphere sampling for direct lighting
  -f FILE       output image, .png or .exr (default out.png)
  -r W H        resolution (default 800 600)
  -a B T        adaptive sampling: batch size B, tolerance T
  -c FILE       a CS184 camera settings file (not supported: the scene's camera is used)
More:
  --job FILE    a JSON job (the server's fields); flags given here override it
  --bvh none|midpoint|median|sah   --max-leaf N   --triangle-test watertight|moller_trumbore
  --direct hemisphere|importance|mis   --rr P (Russian roulette continuation, 0 = off)
  --bounces accumulate|nth   --lighting all|direct|indirect   --integrator path|normals
  --light-selection all|power   --seed N   --tile N
  --tonemap srgb|cs184 (PNG encoding)
)";

struct BadFlag : std::runtime_error { using std::runtime_error::runtime_error; };

int64_t to_int(const std::string& flag, const char* s) {
    try {
        size_t used = 0;
        const long long v = std::stoll(s, &used);
        if (used != std::strlen(s)) throw BadFlag("");
        return v;
    } catch (const std::exception&) {
        throw BadFlag(flag + " needs a whole number, got '" + s + "'");
    }
}

double to_double(const std::string& flag, const char* s) {
    try {
        size_t used = 0;
        const double v = std::stod(s, &used);
        if (used != std::strlen(s)) throw BadFlag("");
        return v;
    } catch (const std::exception&) {
        throw BadFlag(flag + " needs a number, got '" + s + "'");
    }
}

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

}  // namespace

int render_command(int argc, char** argv) {
    json flags = json::object();
    std::string job_file, output = "out.png", scene;
    int threads = 0;
    ToneCurve curve = ToneCurve::srgb;
    try {
        auto need = [&](int i, int n, const std::string& f) {
            if (i + n >= argc) throw BadFlag(f + " needs " + std::to_string(n) + " value(s)");
        };
        for (int i = 0; i < argc; ++i) {
            const std::string a = argv[i];
            if (a == "--help" || a == "-h") { std::fputs(kHelp, stdout); return 0; }
            else if (a == "-t") { need(i, 1, a); threads = int(to_int(a, argv[++i])); if (threads < 0 || threads > 1024) throw BadFlag("-t must lie in [0, 1024]"); }
            else if (a == "-s") { need(i, 1, a); flags["spp"] = to_int(a, argv[++i]); }
            else if (a == "-l") { need(i, 1, a); flags["light_rays"] = to_int(a, argv[++i]); }
            else if (a == "-m") { need(i, 1, a); flags["max_depth"] = to_int(a, argv[++i]); }
            else if (a == "-H") flags["direct"] = "hemisphere";
            else if (a == "-f") { need(i, 1, a); output = argv[++i]; }
            else if (a == "-r") { need(i, 2, a); flags["width"] = to_int(a, argv[i + 1]); flags["height"] = to_int(a, argv[i + 2]); i += 2; }
            else if (a == "-a") { need(i, 2, a); flags["adaptive"] = {{"batch", to_int(a, argv[i + 1])}, {"tolerance", to_double(a, argv[i + 2])}}; i += 2; }
            else if (a == "-c") { need(i, 1, a); throw BadFlag("-c (CS184 camera files) is not supported; the scene's camera is used"); }
            else if (a == "--job") { need(i, 1, a); job_file = argv[++i]; }
            else if (a == "--bvh") { need(i, 1, a); flags["bvh"] = argv[++i]; }
            else if (a == "--max-leaf") { need(i, 1, a); flags["max_leaf_size"] = to_int(a, argv[++i]); }
            else if (a == "--triangle-test") { need(i, 1, a); flags["triangle_test"] = argv[++i]; }
            else if (a == "--direct") { need(i, 1, a); flags["direct"] = argv[++i]; }
            else if (a == "--rr") { need(i, 1, a); flags["russian_roulette"] = to_double(a, argv[++i]); }
            else if (a == "--bounces") { need(i, 1, a); flags["bounces"] = argv[++i]; }
            else if (a == "--lighting") { need(i, 1, a); flags["lighting"] = argv[++i]; }
            else if (a == "--light-selection") { need(i, 1, a); flags["light_selection"] = argv[++i]; }
            else if (a == "--integrator") { need(i, 1, a); flags["integrator"] = argv[++i]; }
            else if (a == "--seed") { need(i, 1, a); flags["seed"] = to_int(a, argv[++i]); }
            else if (a == "--tile") { need(i, 1, a); flags["tile_size"] = to_int(a, argv[++i]); }
            else if (a == "--tonemap") {
                need(i, 1, a);
                const std::string v = argv[++i];
                if (v == "srgb") curve = ToneCurve::srgb;
                else if (v == "cs184") curve = ToneCurve::cs184;
                else throw BadFlag("--tonemap must be srgb or cs184");
            } else if (!a.empty() && a[0] == '-') throw BadFlag("unknown flag " + a + " (see --help)");
            else if (scene.empty()) scene = a;
            else throw BadFlag("more than one scene given: '" + scene + "' and '" + a + "'");
        }
    } catch (const BadFlag& e) {
        std::fprintf(stderr, "tessera render: %s\n", e.what());
        return 2;
    }

    json body = json::object();
    if (!job_file.empty()) {
        std::ifstream in(job_file);
        if (!in) { std::fprintf(stderr, "tessera render: cannot open job file %s\n", job_file.c_str()); return 2; }
        try { body = json::parse(in); }
        catch (const json::parse_error& e) { std::fprintf(stderr, "tessera render: %s: %s\n", job_file.c_str(), e.what()); return 2; }
        if (!body.is_object()) { std::fprintf(stderr, "tessera render: %s: the job must be a JSON object\n", job_file.c_str()); return 2; }
    }
    for (const auto& [k, v] : flags.items()) body[k] = v;
    if (!scene.empty()) body["scene"] = scene;
    if (!body.contains("scene")) { std::fprintf(stderr, "tessera render: no scene given (see --help)\n"); return 2; }

    api::JobSpec job;
    try {
        job = api::parse_job(body);
    } catch (const api::InvalidJob& e) {
        std::fprintf(stderr, "tessera render: %s\n", e.what());
        return 2;
    }
    job.render.threads = threads;
    const std::string ext = std::filesystem::path(output).extension().string();
    if (ext != ".png" && ext != ".exr") {
        std::fprintf(stderr, "tessera render: -f %s: the output must end in .png or .exr\n", output.c_str());
        return 2;
    }

    const auto t_load = Clock::now();
    SceneDescription desc;
    try {
        desc = load_scene(job.scene);
    } catch (const SceneError& e) {
        std::fprintf(stderr, "tessera render: %s\n", e.what());
        return 1;
    }
    const double load_s = seconds_since(t_load);
    for (const auto& w : desc.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());

    const RenderScene rs = build_render_scene(desc, job.scene_options);
    for (const auto& w : rs.report.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    const RenderResult result = render(rs, job.render);
    for (const auto& w : rs.report.left_out) std::printf("left out: %s\n", w.c_str());
    for (const auto& w : result.left_out) std::printf("left out: %s\n", w.c_str());

    const auto t_write = Clock::now();
    const RenderStats& st = result.stats;
    Metadata meta = {{"tessera:scene", job.scene},
                     {"tessera:settings", api::to_json(job).dump()},
                     {"tessera:samples", std::to_string(st.samples)},
                     {"tessera:render_seconds", std::to_string(st.render_seconds)}};
    try {
        if (ext == ".png") write_png(output, result.image, curve, meta);
        else write_exr(output, result.image, meta);
        if (job.render.adaptive) {
            const std::filesystem::path p(output);
            const std::string rate = (p.parent_path() / (p.stem().string() + "_rate.png")).string();
            write_rate_png(rate, result.image, job.render.spp, meta);
            std::printf("sample-rate map: %s\n", rate.c_str());
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "tessera render: %s\n", e.what());
        return 1;
    }
    const double write_s = seconds_since(t_write);

    const double mrays = st.render_seconds > 0 ? double(st.rays()) / st.render_seconds * 1e-6 : 0.0;
    const double per_ray = st.rays() ? 1.0 / double(st.rays()) : 0.0;
    std::printf("scene: %s (%zu triangles, %zu spheres)\n", job.scene.c_str(), rs.triangle_count(), rs.spheres.size());
    std::printf("timings: load %.3f s, BVH build %.3f s (%s, %zu nodes, depth %d, SAH cost %.2f), render %.3f s (%d threads), write %.3f s\n",
                load_s, rs.report.seconds, to_string(job.scene_options.bvh.type), rs.tri_bvh_stats.node_count,
                rs.tri_bvh_stats.depth, rs.tri_bvh_stats.sah_cost, st.render_seconds, st.threads, write_s);
    if (rs.tri_bvh_stats.node_count) {
        const auto& hist = rs.tri_bvh_stats.leaf_size_histogram;
        std::printf("BVH leaves: %zu; by size:", rs.tri_bvh_stats.leaf_count);
        for (size_t k = 1; k < hist.size(); ++k)
            if (hist[k]) std::printf(" %zu%s:%zu", k, k + 1 == hist.size() ? "+" : "", hist[k]);
        std::printf("; %.1f MiB with the triangles\n", double(rs.triangle_accel_bytes()) / (1 << 20));
    }
    std::printf("rays: %llu (camera %llu, shadow %llu, bounce %llu), %.2f Mrays/s, %.1f nodes and %.1f primitive tests per ray\n",
                (unsigned long long)st.rays(), (unsigned long long)st.camera_rays, (unsigned long long)st.shadow_rays,
                (unsigned long long)st.bounce_rays, mrays, double(st.traversal.nodes_visited) * per_ray,
                double(st.traversal.prim_tests) * per_ray);
    const double npx = double(job.render.width) * job.render.height;
    if (!st.tile_seconds.empty()) {
        std::vector<double> t = st.tile_seconds;
        std::sort(t.begin(), t.end());
        std::printf("tiles: %zu of %d px, seconds per tile min %.4f, median %.4f, max %.4f\n", t.size(), job.render.tile_size,
                    t.front(), t[t.size() / 2], t.back());
    }
    double mean = 0;
    for (float v : result.image.rgb) mean += v;
    mean /= double(result.image.rgb.size());
    std::printf("samples: %llu (%.2f per pixel), non-finite samples dropped: %llu, mean linear radiance %.4f\n",
                (unsigned long long)st.samples, double(st.samples) / npx, (unsigned long long)st.nonfinite_samples, mean);
    std::printf("wrote %s\n", output.c_str());
    return 0;
}

}  // namespace tessera::cli
