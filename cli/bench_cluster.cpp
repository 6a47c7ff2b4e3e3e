// `tessera bench cluster`: what a render farm costs and gains on this machine, against a real
// redis-server (Debian's, started here with the AOF settings docs/scaling.md documents).
//   1. hand-offs: tile tasks through Redis with a render that does nothing — added a pass at a
//      time, read in batches, each stored by the real commit script (which acknowledges it) with
//      the bytes a tile carries — per second, for 1 and N clients, at 16×16, 32×32 and 64×64;
//   2. end to end: the same light job rendered by one process and by a farm of one node, both
//      on one thread; the difference per tile is the farm's overhead (queue, film transfer,
//      assembly);
//   3. scaling: CBbunny as one process with 2 threads against two render nodes with 1 thread each
//      (same image, checked bit for bit; wall time; efficiency);
//   4. a shot: a 120-frame turntable the same way (every frame checked bit for bit; how often
//      each node opened the scene; efficiency).
// Farm nodes here are RenderNode objects in this process, each with its own Redis connections
// and threads, so the bench needs no orchestration; the fault tests run them as processes.
#include "build_paths.h"
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "api/job_runner.h"
#include "cli/bench_common.h"
#include "cli/bench_turntable.h"
#include "engine/io/image_io.h"
#include "engine/render/film.h"
#include "server/store/cluster_keys.h"
#include "server/store/cluster_lua.h"
#include "cli/command_line.h"
#include "server/farm/farm_records.h"
#include "engine/render/film_codec.h"
#include "server/farm/tile_image_codec.h"
#include "server/store/job_results.h"
#include "server/farm/farm_queue.h"
#include "server/store/redis_process.h"
#include "server/farm/render_node.h"

namespace tessera::cli {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using nlohmann::json;
using server::Redis;
using server::RedisScript;

double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : v[v.size() / 2];
}

// Hand-offs per second of `clients` threads for `seconds`, each through the protocol a render
// node runs on tasks this short: tiles added a pass at a time by the add_tiles script, read 32
// at a time with XREADGROUP, each result stored by the commit script (which acknowledges and
// deletes its task in the same call) with `payload` as the tile's bytes.
double handoffs(const server::RedisUrl& url, const std::string& payload, int clients, double seconds) {
    const RedisScript commit{server::commit_tile_script()};
    const RedisScript add{server::lua::add_tiles + "add_tiles(KEYS[1], ARGV[1], ARGV[2], tonumber(ARGV[3]))"};
    const std::string job = "benchbenchbench0", stream = server::keys::tasks(0);
    {
        Redis r(url);
        r.command({"FLUSHALL"});
        std::vector<std::string> start = {"HSET", server::keys::job(job), "state", "running"};
        for (std::string& a : server::farm_run_start(1, size_t(1) << 40, 0)) start.push_back(std::move(a));
        r.command(start);
        r.command({"XGROUP", "CREATE", stream, server::keys::group, "0", "MKSTREAM"});
    }
    std::atomic<uint64_t> done{0};
    std::vector<std::thread> threads;
    for (int c = 0; c < clients; ++c)
        threads.emplace_back([&, c] {
            Redis r(url);
            const std::string consumer = "bench/" + std::to_string(c);
            std::vector<std::string> ids;
            const auto t0 = Clock::now();
            for (uint64_t i = 0; since(t0) < seconds;) {
                if (ids.empty()) {
                    const auto got = r.command({"XREADGROUP", "GROUP", server::keys::group, consumer, "COUNT", "32", "STREAMS", stream, ">"});
                    for (const auto& st : got.items)
                        for (const auto& e : st.items[1].items) ids.push_back(e.items[0].text);
                    if (ids.empty()) r.eval(add, {stream}, {job, "0", "256"});
                    std::reverse(ids.begin(), ids.end());
                    continue;
                }
                const std::string id = ids.back();
                ids.pop_back();
                // Every result under its own tile index, so each is stored (none is a duplicate).
                const uint64_t tile = uint64_t(c) * 1'000'000'000ull + i++;
                server::TileCommit c;
                c.job = job;
                c.task_id = id;
                c.node = consumer;
                c.tile = size_t(tile);
                c.payload = payload;
                c.seconds = 0.001;
                c.stats.samples = 1;
                c.stats.camera_rays = 1;
                r.eval(commit, {server::keys::job(job), server::keys::film(job), server::keys::node_tiles(job), server::keys::node_seconds(job), stream,
                                server::keys::sums(job)},
                       c.arguments());
                ++done;
                if (i % 256 == 0) r.command({"DEL", server::keys::film(job)});  // keeps Redis's memory bounded
            }
        });
    for (auto& t : threads) t.join();
    return double(done.load()) / seconds;
}

struct Farm {
    server::FarmQueue service;
    std::vector<std::unique_ptr<server::RenderNode>> nodes;
    Farm(const server::ServiceConfig& cfg, int nodes_n, const server::RedisUrl& url) : service(cfg) {
        for (int i = 0; i < nodes_n; ++i) {
            server::NodeConfig nc;
            nc.redis = url;
            nc.data_dir = cfg.data_dir;
            nc.name = "bench-node-" + std::to_string(i + 1);
            nc.threads = 1;
            nodes.push_back(std::make_unique<server::RenderNode>(nc));
            nodes.back()->start();
        }
    }
    ~Farm() {
        for (auto& n : nodes) n->stop();
        service.shutdown();
    }
    // Seconds from submission to success, and the job's id.
    std::pair<double, std::string> run(const json& job) {
        const auto t0 = Clock::now();
        const std::string id = service.submit(job).id;
        for (;;) {
            const api::JobStatus s = service.status(id);
            if (s.state == api::JobState::succeeded) return {since(t0), id};
            if (api::is_final(s.state)) throw std::runtime_error("bench job " + id + " " + api::to_json(s).dump());
            // Polling takes the cores the nodes render on (a shot's status reads every frame's
            // state): every 2 ms for short jobs, at most 1% of the time so far for long ones.
            std::this_thread::sleep_for(std::chrono::duration<double>(std::clamp(0.01 * since(t0), 0.002, 0.1)));
        }
    }
};

server::ServiceConfig farm_config(const std::string& url, const fs::path& dir, const std::string& cs184) {
    server::ServiceConfig cfg;
    cfg.data_dir = dir.string();
    cfg.project_scenes = TESSERA_DEFAULT_SCENES_DIR;
    if (!cs184.empty()) cfg.scene_dirs = {cs184};
    cfg.redis_url = url;
    cfg.max_queued = 1'000'000;
    return cfg;
}

// One process: the job through the same runner the server's workers use.
double run_one(const json& body, const std::string& scene_path, int threads, const fs::path& dir) {
    const api::RenderJob job = api::parse_render_job(body, api::JobLimits::none());
    api::RunOptions opt;
    opt.scene_source = scene_path;
    opt.threads = threads;
    fs::create_directories(dir);
    const auto t0 = Clock::now();
    api::run_job(job, opt, api::RunOutputs::in_directory(dir.string()));
    return since(t0);
}

bool same_pixels(const std::string& a, const std::string& b) {
    const Image x = read_image(a), y = read_image(b);
    return x.rgb.size() == y.rgb.size() && std::memcmp(x.rgb.data(), y.rgb.data(), x.rgb.size() * sizeof(float)) == 0;
}

// 4. A shot (the turntable of `bench shot`) rendered by one process with 2 threads and by two
// render nodes with 1 thread each, the farm choosing its chunks as a user's job would: wall time
// from start to the shot's last file (contact sheet, preview), every frame compared bit for bit.
int bench_shot_scaling(const server::RedisUrl& url, const std::string& url_text, const fs::path& dir, int frames, uint64_t triangles,
                       int width, int height, int spp) {
    if (frames <= 0) return 0;
    std::printf("\n## 4. A %d-frame shot: two render nodes x 1 thread against one process x 2 threads\n\n", frames);
    const fs::path scene_dir = dir / "shot_scene";
    fs::create_directories(scene_dir);
    const std::string scene = write_turntable(scene_dir, triangles, frames / 24.0);
    std::printf("A turntable of a %llu-triangle mesh (`tessera bench shot`'s), %dx%d, %d spp, max_depth 3, frames 1-%d, the "
                "farm's chunks chosen by the farm; wall time from start to the shot's last file.\n\n",
                (unsigned long long)triangles, width, height, spp, frames);
    Redis r(url);
    r.command({"FLUSHALL"});
    server::ServiceConfig cfg = farm_config(url_text, dir / "shot_farm", "");
    cfg.scene_dirs = {scene_dir.string()};
    Farm farm(cfg, 2, url);
    std::string name;
    for (const auto& e : farm.service.catalog().entries())
        if (fs::path(e.path).filename() == "turntable.gltf") name = e.name;
    if (name.empty()) throw std::runtime_error("bench cluster: the shot's scene is not in the farm's catalog");
    const json job = {{"scene", name}, {"width", width}, {"height", height}, {"spp", spp}, {"max_depth", 3},
                      {"frames", {{"start", 1}, {"end", frames}}}};
    const double one = run_one(job, scene, 2, dir / "shot_one");
    const auto [farm_s, id] = farm.run(job);
    const fs::path results = server::job_results_dir(cfg.data_dir, id);
    int differ = 0;
    for (int n = 1; n <= frames; ++n) {
        const std::string f = "frames/" + std::to_string(n) + "/image.exr";
        if (!same_pixels((dir / "shot_one" / f).string(), (results / f).string())) ++differ;
    }
    const json report = json::parse(std::ifstream(results / "report.json"));
    // Where the time went: each frame's whole time and its render within it, summed.
    auto sums = [&](const fs::path& root) {
        double whole = 0, render = 0;
        for (int n = 1; n <= frames; ++n) {
            const json f = json::parse(std::ifstream(root / "frames" / std::to_string(n) / "report.json"));
            whole += f["timings"].value("total_s", 0.0);
            render += f["timings"].value("render_s", 0.0);
        }
        return std::make_pair(whole, render);
    };
    const auto [one_whole, one_render] = sums(dir / "shot_one");
    const auto [farm_whole, farm_render] = sums(results);
    std::printf("| run | wall s | frames' own time, summed (s) | their render, summed (s) |\n|---|---|---|---|\n"
                "| one process, 2 threads | %.3f | %.3f | %.3f |\n| two render nodes, 1 thread each | %.3f | %.3f | %.3f |\n",
                one, one_whole, one_render, farm_s, farm_whole, farm_render);
    std::printf("\nefficiency (one process / farm, same cores): %.3f\n", one / farm_s);
    std::printf("frames the same bit for bit: %d of %d\n", frames - differ, frames);
    for (const auto& node : farm.nodes)
        std::printf("%s: %llu frames, scene opened %llu time(s)\n", node->name().c_str(),
                    (unsigned long long)node->metrics().frames.load(), (unsigned long long)node->metrics().shot_opens.load());
    if (report.contains("shot") && report["shot"].contains("chunk"))
        std::printf("chunk chosen: %s frames\n", report["shot"]["chunk"].dump().c_str());
    return differ == 0 ? 0 : 1;
}

}  // namespace

int bench_cluster(int argc, char** argv) {
    double seconds = 2;
    int clients = 2, reps = 2, spp = 64, depth = 5, width = 480, height = 360;
    std::string scene = "sky/CBbunny", cs184 = default_cs184_dir();
    bool skip_scaling = false, shot_only = false;
    int shot_frames = 120, shot_width = 320, shot_height = 180, shot_spp = 16;
    uint64_t shot_triangles = 100'000;
    std::string fsync = "everysec";
    CLI::App app{"A render farm on this machine: tile hand-offs through one Redis, the end-to-end overhead per tile, and "
                 "two render nodes against one process with the same cores.", "bench cluster"};
    app.option_defaults()->always_capture_default();
    app.add_option("--seconds", seconds, "length of each hand-off measurement")->check(CLI::Range(0.2, 600.0));
    app.add_option("--clients", clients, "client threads for the hand-off throughput")->check(CLI::Range(1, 256));
    app.add_option("--reps", reps, "runs of each side of the scaling comparison (alternating; medians)")->check(CLI::Range(1, 50));
    app.add_option("--scene", scene, "the CS184 scene of the scaling comparison (path under --cs184, no extension)");
    app.add_option("--spp", spp, "its samples per pixel")->check(CLI::Range(1, 1 << 16));
    app.add_option("--depth", depth, "its max depth")->check(CLI::Range(0, 100));
    app.add_option("--width", width)->check(CLI::Range(8, 8192));
    app.add_option("--height", height)->check(CLI::Range(8, 8192));
    app.add_option("--cs184", cs184, "the CS184 scene folder")->type_name("DIR");
    app.add_flag("--no-scaling", skip_scaling, "only the hand-off and overhead tables");
    app.add_flag("--shot-only", shot_only, "only the shot (section 4)");
    app.add_option("--shot-frames", shot_frames, "frames of the shot (0: no shot)")->check(CLI::Range(0, 10000));
    app.add_option("--shot-triangles", shot_triangles, "triangles of the shot's turning mesh")->check(CLI::Range(8, 20000000));
    app.add_option("--shot-width", shot_width)->check(CLI::Range(8, 4096));
    app.add_option("--shot-height", shot_height)->check(CLI::Range(8, 4096));
    app.add_option("--shot-spp", shot_spp)->check(CLI::Range(1, 4096));
    app.add_option("--appendfsync", fsync, "Redis's AOF fsync policy for this run (off: no AOF), to price durability")
        ->check(CLI::IsMember({"everysec", "always", "no", "off"}));
    if (const auto status = server::parse_args(app, argc, argv)) return *status;
    spdlog::set_level(spdlog::level::warn);

    server::RedisServer redis(fsync);
    if (!redis.available()) {
        std::fprintf(stderr, "bench cluster: redis-server is not installed (apt-get install redis-server)\n");
        return 1;
    }
    if (!redis.start()) {
        std::fprintf(stderr, "bench cluster: redis-server did not start\n");
        return 1;
    }
    const server::RedisUrl url = redis.url();
    const std::string url_text = "redis://127.0.0.1:" + std::to_string(redis.port()) + "/0";
    const fs::path dir = fs::temp_directory_path() / ("tessera_bench_cluster_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    unsigned cores = std::thread::hardware_concurrency();
    std::printf("# tessera bench cluster (%u hardware threads; redis-server %s)\n\n", cores,
                fsync == "off" ? "without AOF" : ("with appendonly yes, appendfsync " + fsync).c_str());

    auto shot = [&] {
        const int rc = bench_shot_scaling(url, url_text, dir, shot_frames, shot_triangles, shot_width, shot_height, shot_spp);
        fs::remove_all(dir);
        return rc;
    };
    if (shot_only) return shot();
    std::printf("## 1. Tile hand-offs through one Redis (render does nothing)\n\n");
    std::printf("Tiles added a pass at a time, read 32 at a time (XREADGROUP), each stored by the commit script, which\n"
                "acknowledges and deletes its task in the same call; %.1f s each. A job that stops on spp ships each tile's\n"
                "resolved pixels (16 bytes a pixel); a pass-by-pass job ships its film (52 bytes a pixel with the error\n"
                "estimate on, the server's default).\n\n", seconds);
    std::printf("| tile | payload | bytes | 1 client: hand-offs/s | ms per hand-off | %d clients: hand-offs/s |\n|---|---|---|---|---|---|\n", clients);
    for (int tile : {16, 32, 64}) {
        const Film film = Film::tile(0, 0, tile, tile, true, false);
        std::vector<std::pair<const char*, std::string>> payloads = {{"resolved pixels", server::encode_tile_image(film)},
                                                                       {"film", encode_film(film)}};
        if (tile == 16) payloads.insert(payloads.begin(), {"none (the queue alone)", std::string()});
        for (const auto& [what, payload] : payloads) {
            const double one = handoffs(url, payload, 1, seconds);
            const double many = handoffs(url, payload, clients, seconds);
            std::printf("| %s | %s | %zu | %.0f | %.3f | %.0f |\n", payload.empty() ? "-" : (std::to_string(tile) + "x" + std::to_string(tile)).c_str(),
                        what, payload.size(), one, 1000.0 / one, many);
            std::fflush(stdout);
        }
    }

    std::printf("\n## 2. End-to-end overhead per tile (one thread each side)\n\n");
    std::printf("builtin:cornell_box 1024x1024, 1 spp, max_depth 0: a light render, so the farm's own costs show. One process\n"
                "(the job runner) against a farm of one render node (submission to success). Medians of 3.\n\n");
    std::printf("| tile | tiles | one process s | farm s | overhead per tile ms |\n|---|---|---|---|---|\n");
    {
        Redis r(url);
        r.command({"FLUSHALL"});
        Farm farm(farm_config(url_text, dir / "e2e", ""), 1, url);
        for (int tile : {16, 32, 64}) {
            const json job = {{"scene", "builtin:cornell_box"}, {"width", 1024}, {"height", 1024}, {"spp", 1}, {"max_depth", 0}, {"tile_size", tile}};
            std::vector<double> one, f;
            for (int i = 0; i < 3; ++i) {
                one.push_back(run_one(job, "builtin:cornell_box", 1, dir / "one"));
                f.push_back(farm.run(job).first);
            }
            const int tiles = ((1024 + tile - 1) / tile) * ((1024 + tile - 1) / tile);
            std::printf("| %dx%d | %d | %.3f | %.3f | %.3f |\n", tile, tile, tiles, median(one), median(f),
                        (median(f) - median(one)) / tiles * 1000.0);
            std::fflush(stdout);
        }
    }

    if (skip_scaling) {
        fs::remove_all(dir);
        return 0;
    }
    const fs::path scene_path = fs::path(cs184) / (scene + ".dae");
    std::printf("\n## 3. Two render nodes x 1 thread against one process x 2 threads\n\n");
    if (!fs::exists(scene_path)) {
        std::printf("skipped: %s is absent (set TESSERA_CS184_DIR or --cs184)\n", scene_path.c_str());
        return shot();
    }
    std::printf("%s %dx%d, %d spp, max_depth %d, tiles 32x32; wall time from start to written results; %d runs each, "
                "alternating; medians.\n\n", scene.c_str(), width, height, spp, depth, reps);
    Redis r(url);
    r.command({"FLUSHALL"});
    Farm farm(farm_config(url_text, dir / "farm", cs184), 2, url);
    std::string name;
    for (const auto& e : farm.service.catalog().entries())
        if (fs::path(e.path).filename() == scene_path.filename()) name = e.name;
    const json job = {{"scene", name}, {"width", width}, {"height", height}, {"spp", spp}, {"max_depth", depth}};
    json local = job;
    local["scene"] = scene_path.string();
    std::vector<double> one, f;
    std::string farm_id;
    for (int i = 0; i < reps; ++i) {
        one.push_back(run_one(job, scene_path.string(), 2, dir / "one2"));
        auto [t, id] = farm.run(job);
        f.push_back(t);
        farm_id = id;
    }
    const fs::path farm_results = server::job_results_dir((dir / "farm").string(), farm_id);
    const bool same = same_pixels((dir / "one2" / "image.exr").string(), (farm_results / "image.exr").string());
    const json report = json::parse(std::ifstream(farm_results / "report.json"));
    std::printf("| run | wall s (median) | runs |\n|---|---|---|\n");
    std::printf("| one process, 2 threads | %.3f | %s |\n", median(one), [&] { std::string s; for (double x : one) s += std::to_string(x).substr(0, 6) + " "; return s; }().c_str());
    std::printf("| two render nodes, 1 thread each | %.3f | %s |\n", median(f), [&] { std::string s; for (double x : f) s += std::to_string(x).substr(0, 6) + " "; return s; }().c_str());
    std::printf("\nefficiency (one process / farm, same cores): %.3f\n", median(one) / median(f));
    std::printf("same image bit for bit: %s\n", same ? "yes" : "NO");
    if (report.contains("nodes"))
        for (const auto& n : report["nodes"])
            std::printf("node %s: %d tiles (%.0f%%), %.2f s in tiles\n", n["node"].get<std::string>().c_str(), n["tiles"].get<int>(),
                        n["share"].get<double>() * 100.0, n["seconds"].get<double>());
    return shot() == 0 && same ? 0 : 1;
}

}  // namespace tessera::cli
