// `tessera bench server`: an in-process server on a free port, driven by client threads over
// loopback: status-poll and submit latency (p50/p99) and throughput, and the server's overhead
// on a small job against rendering the same job directly.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <httplib.h>
#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "engine/io/image_io.h"
#include "engine/io/scene_loader.h"
#include "engine/render/renderer.h"
#include "cli/bench_common.h"
#include "server/command_line.h"
#include "server/http_api.h"

namespace tessera::cli {

using server::parse_args;
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

double pct(std::vector<double> v, double p) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, size_t(p * double(v.size())))];
}

}  // namespace

int bench_server(int argc, char** argv) {
    int clients = 16;
    double seconds = 5;
    CLI::App app{"An in-process server driven by client threads over loopback: status-poll and submit latency and "
                 "throughput, and the server's overhead on a small job.", "bench server"};
    app.option_defaults()->always_capture_default();
    app.add_option("--clients", clients, "client threads")->check(CLI::Range(1, 512));
    // A phase much shorter than a tenth of a second measures thread start-up, not requests.
    app.add_option("--seconds", seconds, "length of each phase")->type_name("S")->check(CLI::Range(0.1, 600.0));
    if (const auto status = parse_args(app, argc, argv)) return *status;
    spdlog::set_level(spdlog::level::warn);  // a log line per request would measure the terminal
    const auto dir = std::filesystem::temp_directory_path() / ("tessera_bench_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    server::ServiceConfig cfg;
    cfg.data_dir = dir.string();
    cfg.project_scenes = TESSERA_DEFAULT_SCENES_DIR;
    cfg.max_queued = 1'000'000;
    server::JobService service(cfg);
    server::HttpLimits limits;
    limits.http_threads = clients + 4;
    server::HttpApi api(service, limits, (dir / "none.yaml").string());
    const int port = api.bind("127.0.0.1", 0);
    std::thread serving([&] { api.serve(); });
    httplib::Client c("127.0.0.1", port);
    const json small = {{"scene", "cornell_box"}, {"width", 64}, {"height", 48}, {"spp", 4}, {"max_depth", 2}};
    auto r = c.Post("/v1/jobs", small.dump(), "application/json");
    if (!r || r->status != 202) { std::fprintf(stderr, "bench: submit failed\n"); return 1; }
    const std::string id = json::parse(r->body)["id"];

    // 1. Status polls: every client polls the same job as fast as it can.
    auto run_clients = [&](auto&& request) {
        std::vector<std::vector<double>> lat(static_cast<size_t>(clients));
        std::atomic<bool> go{true};
        std::vector<std::thread> ts;
        const auto t0 = Clock::now();
        for (int k = 0; k < clients; ++k)
            ts.emplace_back([&, k] {
                httplib::Client cc("127.0.0.1", port);
                cc.set_keep_alive(true);
                cc.set_tcp_nodelay(true);
                while (go) {
                    const auto a = Clock::now();
                    if (!request(cc)) break;
                    lat[size_t(k)].push_back(std::chrono::duration<double, std::milli>(Clock::now() - a).count());
                }
            });
        std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
        go = false;
        for (auto& t : ts) t.join();
        const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
        std::vector<double> all;
        for (auto& l : lat) all.insert(all.end(), l.begin(), l.end());
        return std::tuple{all, wall};
    };
    auto [polls, poll_wall] = run_clients([&](httplib::Client& cc) {
        auto res = cc.Get("/v1/jobs/" + id);
        return res && res->status == 200;
    });
    // 2. Submissions (each one is a durable SQLite commit) of jobs that are canceled at once
    //    afterwards, so the renders do not compete with the measurement.
    auto [subs, sub_wall] = run_clients([&](httplib::Client& cc) {
        json j = small;
        j["priority"] = -1000;
        auto res = cc.Post("/v1/jobs", j.dump(), "application/json");
        return res && res->status == 202;
    });
    service.shutdown();  // cancel-free stop: the queued submissions stay queued and are dropped with the directory

    std::printf("Server on 127.0.0.1, %d client threads (keep-alive), %.0f s each phase, this machine's 2 cores shared by "
                "clients and server\n\n", clients, seconds);
    std::printf("| request | requests | throughput (/s) | p50 (ms) | p99 (ms) |\n|---|---:|---:|---:|---:|\n");
    std::printf("| GET /v1/jobs/{id} | %zu | %.0f | %.3f | %.3f |\n", polls.size(), double(polls.size()) / poll_wall, pct(polls, 0.5), pct(polls, 0.99));
    std::printf("| POST /v1/jobs | %zu | %.0f | %.3f | %.3f |\n", subs.size(), double(subs.size()) / sub_wall, pct(subs, 0.5), pct(subs, 0.99));
    api.stop();
    serving.join();
    std::filesystem::remove_all(dir);

    // 3. Overhead on a small job: submit → succeeded through a fresh server, against loading,
    //    building, rendering and writing the same job directly.
    const auto dir2 = dir.string() + "_overhead";
    std::filesystem::remove_all(dir2);
    cfg.data_dir = dir2;
    server::JobService service2(cfg);
    server::HttpApi api2(service2, server::HttpLimits{}, "none.yaml");
    const int port2 = api2.bind("127.0.0.1", 0);
    std::thread serving2([&] { api2.serve(); });
    httplib::Client c2("127.0.0.1", port2);
    c2.set_tcp_nodelay(true);
    std::vector<double> via_server, direct;
    for (int rep = 0; rep < 10; ++rep) {
        const auto a = Clock::now();
        auto res = c2.Post("/v1/jobs", small.dump(), "application/json");
        const std::string jid = json::parse(res->body)["id"];
        for (;;) {
            auto s = c2.Get("/v1/jobs/" + jid);
            const std::string st = json::parse(s->body)["state"];
            if (st == "succeeded" || st == "failed") break;
            std::this_thread::sleep_for(std::chrono::microseconds(200));
        }
        via_server.push_back(std::chrono::duration<double, std::milli>(Clock::now() - a).count());
        const auto b = Clock::now();
        const SceneDescription d = load_scene(std::string(TESSERA_DEFAULT_SCENES_DIR) + "/cornell_box.gltf");
        RenderSettings st;
        st.width = 64;
        st.height = 48;
        st.spp = 4;
        st.max_depth = 2;
        const RenderResult rr = render(build_render_scene(d, {}), st);
        write_png(dir2 + "/direct.png", rr.image);
        write_exr(dir2 + "/direct.exr", rr.image);
        write_rate_png(dir2 + "/direct_rate.png", rr.image, st.spp);
        direct.push_back(std::chrono::duration<double, std::milli>(Clock::now() - b).count());
    }
    api2.stop();
    serving2.join();
    service2.shutdown();
    std::filesystem::remove_all(dir2);
    std::printf("\nSmall job (cornell_box 64×48, 4 spp, depth 2; PNG + EXR + rate map), 10 repetitions:\n");
    std::printf("- through the server, submit to succeeded (polling every 0.2 ms): median %.2f ms\n", pct(via_server, 0.5));
    std::printf("- the same work done directly: median %.2f ms\n", pct(direct, 0.5));
    std::printf("- server overhead per job: %.2f ms\n", pct(via_server, 0.5) - pct(direct, 0.5));
    return 0;
}

}  // namespace tessera::cli
