// `tessera bench prepare`: where a job's time to first pixel goes. For procedural meshes of
// 10k to 4M triangles and the 1.04M-triangle glTF sample: loading, then every stage of the
// scene preparation on 1 and 2 threads, ours beside Embree's medium build of the same mesh in
// the same run, with the peak memory each needs; then a cache miss and hits through a real
// in-process server. Each measurement runs in a child process of its own, so that it pays
// for its memory as a first job does and its peak is its own.
#include "build_paths.h"
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "engine/accel/embree_accel.h"
#include "engine/io/scene_loader.h"
#include "engine/scene/render_scene.h"
#include "cli/bench_common.h"
#include "cli/command_line.h"

namespace tessera::cli {

using server::parse_args;
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

// The kernel's count of this process's resident memory (kB field of /proc/self/status).
size_t status_kb(const char* field) {
    std::ifstream in("/proc/self/status");
    std::string line;
    const std::string key = std::string(field) + ":";
    while (std::getline(in, line))
        if (line.rfind(key, 0) == 0) return std::stoull(line.substr(key.size()));
    return 0;
}

// Load and prepare once, in this (child) process; the result as JSON.
json measure_here(const std::string& source, BvhType type, int threads) {
    const auto t0 = Clock::now();
    const SceneDescription desc = load_scene(source);
    const double load_s = std::chrono::duration<double>(Clock::now() - t0).count();
    // From here the peak counts the preparation alone: "5" resets the high-water mark.
    { std::ofstream("/proc/self/clear_refs") << "5"; }
    const size_t before_kb = status_kb("VmRSS");
    RenderSceneOptions o;
    o.bvh.type = type;
    o.bvh.build_threads = threads;
    const RenderScene scene = build_render_scene(desc, o);
    json stages = json::object();
    for (const BuildStage& st : scene.report.stages) stages[st.name] = st.seconds;
    return {{"load_s", load_s}, {"prepare_s", scene.report.seconds}, {"stages", stages},
            {"triangles", scene.triangle_count()}, {"peak_bytes", (status_kb("VmHWM") - std::min(before_kb, status_kb("VmHWM"))) * 1024},
            {"accel_bytes", scene.triangle_accel_bytes()}};
}

// measure_here in a fork, so that every measurement starts from the same fresh process.
json measure(const std::string& source, BvhType type, int threads) {
    int fds[2];
    if (::pipe(fds) != 0) throw std::runtime_error("pipe failed");
    std::fflush(stdout);
    const pid_t pid = ::fork();
    if (pid < 0) throw std::runtime_error("fork failed");
    if (pid == 0) {
        ::close(fds[0]);
        std::string out;
        try {
            out = measure_here(source, type, threads).dump();
        } catch (const std::exception& e) {
            out = json{{"error", e.what()}}.dump();
        }
        for (size_t at = 0; at < out.size();) {
            const ssize_t n = ::write(fds[1], out.data() + at, out.size() - at);
            if (n <= 0) break;
            at += size_t(n);
        }
        ::_exit(0);
    }
    ::close(fds[1]);
    std::string text;
    char buf[4096];
    for (ssize_t n; (n = ::read(fds[0], buf, sizeof buf)) > 0;) text.append(buf, size_t(n));
    ::close(fds[0]);
    int status = 0;
    ::waitpid(pid, &status, 0);
    if (text.empty()) throw std::runtime_error("the measuring process died (status " + std::to_string(status) + ")");
    json r = json::parse(text);
    if (r.contains("error")) throw std::runtime_error(r["error"].get<std::string>());
    return r;
}

// The repetition with the median preparation time (its stages and memory together).
json median_of(std::vector<json> runs) {
    std::sort(runs.begin(), runs.end(), [](const json& a, const json& b) { return a["prepare_s"] < b["prepare_s"]; });
    return runs[runs.size() / 2];
}

double stage(const json& r, const char* name) { return r["stages"].value(name, 0.0); }

std::string ms(double s) {
    char b[32];
    std::snprintf(b, sizeof b, s < 0.1 ? "%.1f" : "%.0f", s * 1e3);
    return b;
}

struct Scene {
    std::string label, source;
};

}  // namespace

int bench_prepare(int argc, char** argv) {
    std::vector<int> sizes = {10'000, 100'000, 1'000'000, 4'000'000};
    std::vector<int> thread_counts = {1, 2};
    int reps = 3, cache_triangles = 1'000'000, cache_jobs = 4;
    std::string gltf = default_gltf_pbr_dir() + "/MetalRoughSpheresNoTextures.gltf";
    CLI::App app{"Scene preparation: every stage on 1 and 2 threads beside Embree's medium build, peak memory, and "
                 "cache miss and hit latency through the server.", "bench prepare"};
    app.option_defaults()->always_capture_default();
    app.add_option("--triangles", sizes, "sizes of builtin:displaced_sphere")->check(CLI::Range(1, 50'000'000))->delimiter(',');
    app.add_option("--threads", thread_counts, "thread counts")->check(CLI::Range(1, 1024))->delimiter(',');
    app.add_option("--gltf", gltf, "a glTF file measured too (skipped when absent; empty: none)");
    app.add_option("--reps", reps, "repetitions of each measurement (the median is shown)")->check(CLI::Range(1, 100));
    app.add_option("--cache-triangles", cache_triangles, "server phase: triangles of the preview's scene (0 skips the phase)")
        ->check(CLI::Range(0, 64'000'000));
    app.add_option("--cache-jobs", cache_jobs, "server phase: jobs submitted")->check(CLI::Range(1, 1000));
    std::string json_out;
    app.add_option("--json", json_out, "also write every median measurement, with all its stages, to this file");
    if (const auto status = parse_args(app, argc, argv)) return *status;

    std::vector<Scene> scenes;
    for (int n : sizes) scenes.push_back({"displaced_sphere " + std::to_string(n), "builtin:displaced_sphere?triangles=" + std::to_string(n)});
    if (!gltf.empty()) {
        if (std::filesystem::exists(gltf)) scenes.push_back({std::filesystem::path(gltf).filename().string(), gltf});
        else std::printf("(%s is absent: the glTF row is skipped; set TESSERA_GLTF_PBR_DIR or --gltf)\n", gltf.c_str());
    }
    const bool embree = embree_available();
    const char* tunables = std::getenv("GLIBC_TUNABLES");
    std::printf("malloc: %s\n", tunables && std::strstr(tunables, "glibc.malloc.hugetlb=1")
                                     ? "transparent huge pages (GLIBC_TUNABLES=glibc.malloc.hugetlb=1, as scripts/run.sh and the image set it)"
                                     : "glibc's default (4 KiB pages outside the engine's own arrays)");
    std::printf("Scene preparation, median of %d runs, each in a fresh process (ms; peak: memory the preparation adds at "
                "its highest, MiB).\n'ours' is the whole preparation; 'Embree' is Embree's medium build alone (its "
                "buffers filled and committed), measured in the same run.\n\n",
                reps);
    std::printf("| scene | triangles | threads | load | gather | SAH build | collapse | pack | ours | Embree build | ours / Embree "
                "| outside the BVH per 1M triangles | peak ours | peak Embree | bytes per triangle |\n"
                "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    json all = json::array();
    for (const Scene& sc : scenes) {
        for (int t : thread_counts) {
            std::vector<json> ours_runs, embree_runs;
            for (int r = 0; r < reps; ++r) {
                ours_runs.push_back(measure(sc.source, BvhType::sah, t));
                if (embree) embree_runs.push_back(measure(sc.source, BvhType::embree, t));
            }
            const json ours = median_of(ours_runs);
            const double ours_s = ours["prepare_s"];
            const double tri = ours["triangles"];
            const double bvh_s = stage(ours, "bvh build");
            std::string e_build = "-", ratio = "-", e_peak = "-";
            double embree_build_s = 0;
            if (embree) {
                std::sort(embree_runs.begin(), embree_runs.end(),
                          [](const json& a, const json& b) { return stage(a, "embree build") < stage(b, "embree build"); });
                const json& e = embree_runs[embree_runs.size() / 2];
                embree_build_s = stage(e, "embree build");
                e_build = ms(embree_build_s);
                char b[32];
                std::snprintf(b, sizeof b, "%.2f", ours_s / embree_build_s);
                ratio = b;
                std::snprintf(b, sizeof b, "%.0f", double(e["peak_bytes"]) / (1 << 20));
                e_peak = b;
            }
            std::printf("| %s | %.0f | %d | %s | %s | %s | %s | %s | **%s** | %s | %s | %s | %.0f | %s | %.1f |\n", sc.label.c_str(), tri, t,
                        ms(ours["load_s"]).c_str(), ms(stage(ours, "gather")).c_str(), ms(bvh_s).c_str(),
                        ms(stage(ours, "collapse")).c_str(), ms(stage(ours, "pack blocks")).c_str(), ms(ours_s).c_str(),
                        e_build.c_str(), ratio.c_str(), ms((ours_s - bvh_s) * 1e6 / std::max(1.0, tri)).c_str(),
                        double(ours["peak_bytes"]) / (1 << 20), e_peak.c_str(), double(ours["accel_bytes"]) / std::max(1.0, tri));
            std::fflush(stdout);
            all.push_back({{"scene", sc.label}, {"threads", t}, {"ours", ours}, {"embree_build_s", embree_build_s}});
        }
    }
    if (!json_out.empty()) std::ofstream(json_out) << all.dump(2) << "\n";
    if (cache_triangles > 0 && scene_cache_latency(cache_triangles, cache_jobs).empty()) return 1;
    return 0;
}

}  // namespace tessera::cli
