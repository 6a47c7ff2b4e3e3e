// `tessera render`: the CS184 PathTracer flags on top of the same job fields the server takes.
// The flags become a JSON job that goes through api::parse_render_job, and the job runs
// through api::run_job, the server's path: the same job gives the same image either way.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "api/job_runner.h"
#include "api/shot_runner.h"
#include "cli/command_line.h"
#include "cli/commands.h"
#include "cli/job_flags.h"

namespace tessera::cli {

using server::parse_args;
namespace {

using nlohmann::json;

int fail(int status, const std::string& why) {
    std::fprintf(stderr, "tessera render: %s\n", why.c_str());
    return status;
}

// The timings, tree, rays and samples of a finished render, as the CS184 app prints them.
void print_report(const api::RenderReport& r, const std::string& output) {
    const api::RenderJob& job = r.job;
    const RenderStats& st = r.stats;
    for (const auto& w : r.scene_build.built) std::printf("built: %s\n", w.c_str());
    for (const auto& w : r.scene_build.left_out) std::printf("left out: %s\n", w.c_str());
    for (const auto& w : r.render_built) std::printf("built: %s\n", w.c_str());
    for (const auto& w : r.render_left_out) std::printf("left out: %s\n", w.c_str());
    const double mrays = st.render_seconds > 0 ? double(st.rays()) / st.render_seconds * 1e-6 : 0.0;
    const double per_ray = st.rays() ? 1.0 / double(st.rays()) : 0.0;
    std::printf("scene: %s (%zu triangles, %zu spheres)\n", job.scene.c_str(), r.triangles, r.spheres);
    std::printf("timings: load %.3f s, BVH build %.3f s (%s, %zu nodes, depth %d, SAH cost %.2f), render %.3f s (%d threads), write %.3f s\n",
                r.timings.load_s, r.scene_build.seconds, to_string(job.scene_options.bvh.type), r.bvh.node_count,
                r.bvh.depth, r.bvh.sah_cost, st.render_seconds, st.threads, r.timings.write_s);
    if (!r.scene_build.stages.empty()) {
        std::printf("preparation:");
        for (const auto& stage : r.scene_build.stages) std::printf(" %s %.3f s;", stage.name.c_str(), stage.seconds);
        std::printf("\n");
    }
    if (r.bvh.node_count) {
        const auto& hist = r.bvh.leaf_size_histogram;
        std::printf("BVH leaves: %zu; by size:", r.bvh.leaf_count);
        for (size_t k = 1; k < hist.size(); ++k)
            if (hist[k]) std::printf(" %zu%s:%zu", k, k + 1 == hist.size() ? "+" : "", hist[k]);
        std::printf("; %.1f MiB with the triangles\n", double(r.accel_bytes) / (1 << 20));
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
    std::printf("samples: %llu (%.2f per pixel), non-finite samples dropped: %llu, mean linear radiance %.4f\n",
                (unsigned long long)st.samples, double(st.samples) / npx, (unsigned long long)st.nonfinite_samples,
                r.mean_radiance);
    std::printf("wrote %s\n", output.c_str());
}

// Beside the image NAME.ext: NAME_passes.exr (the job's passes), NAME_denoised.ext.
void add_extras(const api::RenderJob& job, const std::filesystem::path& p, api::RunOutputs& o) {
    const std::filesystem::path stem = p.parent_path() / p.stem();
    if (job.render.aovs) o.passes_exr = stem.string() + "_passes.exr";
    if (job.render.denoise) (p.extension() == ".png" ? o.denoised_png : o.denoised_exr) = stem.string() + "_denoised" + p.extension().string();
}

// A shot: each frame to the -f pattern (out_####.exr: the frame number in place of the '#'s),
// then a contact sheet beside them.
int render_shot(const api::RenderJob& job, const api::RunOptions& options, const std::string& pattern, ToneCurve tone) {
    const std::string ext = std::filesystem::path(pattern).extension().string();
    api::RunOutputs outputs;
    outputs.tone = tone;
    outputs.frame = [&](int frame) {
        api::RunOutputs o;
        const std::string path = api::frame_path(pattern, frame);
        (ext == ".png" ? o.png : o.exr) = path;
        const std::filesystem::path p(path);
        if (job.render.adaptive) o.rate_png = (p.parent_path() / (p.stem().string() + "_rate.png")).string();
        add_extras(job, p, o);
        return o;
    };
    std::string sheet = api::frame_path(pattern, 0);
    {
        const std::filesystem::path p(pattern);
        std::string stem = p.stem().string();
        const size_t hash = stem.find('#');
        stem = hash == std::string::npos ? stem + "_contact" : stem.substr(0, hash) + "contact" + stem.substr(stem.find_last_of('#') + 1);
        sheet = (p.parent_path() / (stem + ".png")).string();
    }
    outputs.contact_sheet_png = sheet;
    api::RunCallbacks cb;
    cb.frame = [&](const api::FrameDone& f) {
        const auto& stats = f.entry["stats"];
        std::printf("frame %d (%zu of %zu): %.3f s, %.1f samples per pixel -> %s\n", f.frame, f.index + 1, job.frames->count(),
                    f.seconds, stats.value("spp_mean", 0.0), api::frame_path(pattern, f.frame).c_str());
        std::fflush(stdout);
    };
    api::JobOutcome outcome;
    try {
        outcome = api::run_job(job, options, outputs, cb);
    } catch (const std::exception& e) {
        return fail(1, e.what());
    }
    const auto& shot = outcome.report["shot"];
    for (const auto& w : shot.value("warnings", nlohmann::json::array())) std::fprintf(stderr, "warning: %s\n", w.get<std::string>().c_str());
    std::printf("shot: %zu frames in %.3f s (mean %.3f s a frame); contact sheet %s\n", job.frames->count(),
                shot["timings"]["total_s"].get<double>(), shot["timings"]["mean_frame_s"].get<double>(), sheet.c_str());
    return 0;
}

}  // namespace

int render_command(int argc, char** argv) {
    CLI::App app{"Render a scene to PNG or EXR with the CS184 PathTracer's flags, or any job field.", "render"};
    app.footer(
        "SCENE is a .dae (CS184 COLLADA), .gltf/.glb file, or builtin:cornell_box|cornell_spheres|furnace|many_lights|"
        "displaced_sphere[?triangles=N].\nFlags given here override the fields of --job FILE. Exit status: 0 done, "
        "2 bad flag or job field, 1 bad scene file or unwritable output.");
    std::string scene, output = "out.png", job_file, camera_file, tonemap = "srgb";
    int threads = 0;
    bool hemisphere = false;
    std::vector<std::string> resolution, adaptive;
    const std::string cs184 = "CS184 PathTracer flags";
    app.add_option("SCENE", scene, "The scene to render")->type_name("SCENE");
    app.add_option("-t", threads, "Render threads (0: all cores)")->check(CLI::Range(0, 1024))->group(cs184)->take_last();
    // -s, -l and -m are the table's job fields (below, with their long names).
    app.add_flag("-H", hemisphere, "Hemisphere sampling for direct lighting (direct = hemisphere)")->group(cs184);
    app.add_option("-f", output, "Output image, .png (sRGB) or .exr (linear float RGB + samples) (default out.png)")
        ->take_last()
        ->type_name("FILE")
        ->group(cs184);
    const api::RenderJob defaults = api::default_render_job();
    app.add_option("-r", resolution,
                   "Resolution: width and height (default " + std::to_string(defaults.render.width) + " " +
                       std::to_string(defaults.render.height) + ")")
        ->expected(2)
        ->type_name("W H")
        ->group(cs184);
    app.add_option("-a", adaptive, "Adaptive sampling: batch B, tolerance T (stop when 1.96·σ/√n ≤ T·μ); writes NAME_rate.png")
        ->expected(2)
        ->type_name("B T")
        ->group(cs184);
    app.add_option("-c", camera_file, "A CS184 camera settings file (not supported: the scene's camera is used)")
        ->type_name("FILE")
        ->group(cs184);
    app.add_option("--job", job_file, "A JSON job (the server's fields); flags given here override it")->type_name("FILE");
    app.add_option("--tonemap", tonemap, "PNG encoding: the sRGB curve, or the CS184 app's")
        ->check(CLI::IsMember({"srgb", "cs184"}))
        ->type_name("srgb|cs184");
    JobFlags flags;
    flags.add_to(app, "Job fields");
    if (auto status = parse_args(app, argc, argv)) return *status;
    if (!camera_file.empty()) return fail(2, "-c (CS184 camera files) is not supported; the scene's camera is used");

    json body = json::object();
    if (!job_file.empty()) {
        std::ifstream in(job_file);
        if (!in) return fail(2, "cannot open job file " + job_file);
        try {
            body = json::parse(in);
        } catch (const json::parse_error& e) {
            return fail(2, job_file + ": " + e.what());
        }
        if (!body.is_object()) return fail(2, job_file + ": the job must be a JSON object");
    }
    try {
        // The CS184 composites, in terms of the table's fields.
        auto whole = [](const std::string& flag, const std::string& v) {
            size_t used = 0;
            long long n = 0;
            try {
                n = std::stoll(v, &used);
            } catch (const std::exception&) {
                used = 0;
            }
            if (used == 0 || used != v.size()) throw std::invalid_argument(flag + " needs a whole number, got '" + v + "'");
            return n;
        };
        if (!resolution.empty()) {
            body["width"] = whole("-r", resolution[0]);
            body["height"] = whole("-r", resolution[1]);
        }
        if (!adaptive.empty()) {
            size_t used = 0;
            double tolerance = 0;
            try {
                tolerance = std::stod(adaptive[1], &used);
            } catch (const std::exception&) {
                used = 0;
            }
            if (used == 0 || used != adaptive[1].size())
                throw std::invalid_argument("-a needs a number as tolerance, got '" + adaptive[1] + "'");
            body["adaptive"] = {{"batch", whole("-a", adaptive[0])}, {"tolerance", tolerance}};
        }
        if (hemisphere) body["direct"] = "hemisphere";
        const json given = flags.given();  // bound first: items() of a temporary would dangle
        for (const auto& [k, v] : given.items()) body[k] = v;
    } catch (const std::invalid_argument& e) {
        return fail(2, e.what());
    }
    if (!scene.empty()) body["scene"] = scene;
    if (!body.contains("scene")) return fail(2, "no scene given (see --help)");

    api::RenderJob job;
    try {
        job = api::parse_render_job(body);
    } catch (const api::InvalidJob& e) {
        return fail(2, e.what());
    }
    if (!job.reference.empty())
        std::fprintf(stderr, "warning: reference %s names a server job; the CLI renders without it\n", job.reference.c_str());
    job.reference.clear();
    const std::filesystem::path out_path(output);
    const std::string ext = out_path.extension().string();
    if (ext != ".png" && ext != ".exr") return fail(2, "-f " + output + ": the output must end in .png or .exr");

    api::RunOptions options;
    options.scene_source = job.scene;
    options.environment_file = job.environment;  // the CLI's -e names a file
    options.threads = threads;
    options.record_convergence = false;  // one pass, as the CS184 app renders
    const ToneCurve tone = tonemap == "cs184" ? ToneCurve::cs184 : ToneCurve::srgb;
    if (job.frames) return render_shot(job, options, output, tone);
    api::RunOutputs outputs;
    (ext == ".png" ? outputs.png : outputs.exr) = output;
    outputs.tone = tone;
    if (job.render.adaptive) outputs.rate_png = (out_path.parent_path() / (out_path.stem().string() + "_rate.png")).string();
    add_extras(job, out_path, outputs);
    api::JobOutcome outcome;
    try {
        outcome = api::run_job(job, options, outputs);
    } catch (const std::exception& e) {
        return fail(1, e.what());
    }
    for (const auto& w : outcome.render->scene_build.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    if (!outputs.rate_png.empty()) std::printf("sample-rate map: %s\n", outputs.rate_png.c_str());
    if (!outputs.passes_exr.empty()) std::printf("passes: %s\n", outputs.passes_exr.c_str());
    for (const auto& p : outcome.render->curve.points)
        if (&p == &outcome.render->curve.points.back() && p.denoised_est_rel_mse >= 0)
            std::printf("denoised: %s (estimated relMSE %.4g, noisy %.4g; denoising took %.3f s)\n",
                        (outputs.denoised_png.empty() ? outputs.denoised_exr : outputs.denoised_png).c_str(), p.denoised_est_rel_mse,
                        p.est_rel_mse, p.denoise_seconds);
    print_report(*outcome.render, output);
    return 0;
}

}  // namespace tessera::cli
