// `tessera bench server`: an in-process server on a free port, driven by client threads over
// loopback: status-poll and submit latency (p50/p99) and throughput, health-check latency under
// slow and many clients, and the server's overhead on a small job against rendering the same
// job directly.
#include "build_paths.h"
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

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
#include "cli/command_line.h"
#include "server/farm/farm_queue.h"
#include "server/http/http_api.h"
#include "cli/in_process_server.h"

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

std::vector<CacheLatency> scene_cache_latency(int triangles, int jobs) {
    std::vector<CacheLatency> rows;
    spdlog::set_level(spdlog::level::err);  // a log line per poll would measure the terminal
    InProcessServer server("cache");
    const int port = server.port;
    httplib::Client c("127.0.0.1", port);
    c.set_tcp_nodelay(true);
    c.set_read_timeout(600, 0);
    const json preview = {{"scene", "builtin:displaced_sphere?triangles=" + std::to_string(triangles)},
                          {"width", 64}, {"height", 48}, {"spp", 1}};
    std::printf("\nThe same 64×48 preview of builtin:displaced_sphere (%d triangles, 1 spp) submitted %d times to a fresh "
                "server, submit to succeeded:\n\n| job | scene cache | end to end (ms) | preparation in the job (ms) |\n|---|---|---:|---:|\n",
                triangles, jobs);
    for (int rep = 0; rep < jobs; ++rep) {
        const auto a = Clock::now();
        auto res = c.Post("/v1/jobs", preview.dump(), "application/json");
        if (!res || res->status != 202) {
            std::fprintf(stderr, "bench: submit failed\n");
            rows.clear();
            break;
        }
        const std::string jid = json::parse(res->body)["id"];
        std::string st;
        for (;;) {
            auto s = c.Get("/v1/jobs/" + jid);
            if (!s || s->status != 200) break;
            st = json::parse(s->body)["state"];
            if (st == "succeeded" || st == "failed") break;
            std::this_thread::sleep_for(std::chrono::microseconds(200));
        }
        const double ms = std::chrono::duration<double, std::milli>(Clock::now() - a).count();
        httplib::Result rep_res = c.Get("/v1/jobs/" + jid + "/report.json");
        if (st != "succeeded" || !rep_res || rep_res->status != 200) {
            // A figure from a failed job would be a figure of nothing: say so and print none.
            std::fprintf(stderr, "bench: job %s ended '%s' without a report\n", jid.c_str(), st.c_str());
            rows.clear();
            break;
        }
        const json report = json::parse(rep_res->body);
        const json& t = report["timings"];
        CacheLatency row{report["scene"]["cache"].value("hit", false), ms, 1e3 * (t.value("load_s", 0.0) + t.value("bvh_s", 0.0))};
        std::printf("| %d | %s | %.1f | %.2f |\n", rep + 1, row.hit ? "hit" : "miss", row.end_to_end_ms, row.preparation_ms);
        rows.push_back(row);
    }
    return rows;
}

int bench_server(int argc, char** argv) {
    int clients = 16;
    double seconds = 5;
    CLI::App app{"An in-process server driven by client threads over loopback: status-poll and submit latency and "
                 "throughput, and the server's overhead on a small job.", "bench server"};
    app.option_defaults()->always_capture_default();
    app.add_option("--clients", clients, "client threads")->check(CLI::Range(1, 512));
    int slow_clients = 32, crowd = 200;
    app.add_option("--slow-clients", slow_clients, "hostile phase: clients trickling a request head (0 with --crowd 0 skips it)")->check(CLI::Range(0, 1000));
    int crowd_pause_ms = 1000;
    int cache_triangles = 1'000'000, cache_jobs = 4;
    int event_jobs = 30;
    app.add_option("--cache-triangles", cache_triangles, "prepared-scene phase: triangles of the scene (0 skips the phase)")
        ->check(CLI::Range(0, 64'000'000));
    app.add_option("--cache-jobs", cache_jobs, "prepared-scene phase: jobs submitted")->check(CLI::Range(1, 1000));
    app.add_option("--event-jobs", event_jobs, "live-updates phase: jobs followed through GET /v1/events (0 skips the phase)")
        ->check(CLI::Range(0, 10000));
    app.add_option("--crowd", crowd, "hostile phase: keep-alive clients looping GET /healthz")->check(CLI::Range(0, 1000));
    app.add_option("--crowd-pause-ms", crowd_pause_ms, "hostile phase: each crowd client's idle time on its open connection between requests")
        ->check(CLI::Range(0, 60000));
    // A phase much shorter than a tenth of a second measures thread start-up, not requests.
    app.add_option("--seconds", seconds, "length of each phase")->type_name("S")->check(CLI::Range(0.1, 600.0));
    if (const auto status = parse_args(app, argc, argv)) return *status;
    // A log line per request would measure the terminal; the hostile phase's cut connections warn.
    spdlog::set_level(spdlog::level::err);
    const auto dir = std::filesystem::temp_directory_path() / ("tessera_bench_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    server::ServiceConfig cfg;
    cfg.data_dir = dir.string();
    cfg.project_scenes = TESSERA_DEFAULT_SCENES_DIR;
    cfg.max_queued = 1'000'000;
    const auto queue = server::open_job_queue(cfg);
    server::JobQueue& service = *queue;
    server::HttpLimits limits;
    limits.connections.header_timeout_s = 2;  // the hostile phase's slow clients are cut within its length
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
    // 3. Hostile load: clients that send a header line every 200 ms (cut by the header
    //    deadline, then back again), a crowd of keep-alive clients, and a prober that opens a
    //    fresh connection for each GET /healthz, as a monitoring system would.
    std::vector<double> probes;
    int probe_failures = 0, crowd_failures = 0;
    size_t crowd_requests = 0;
    if (slow_clients + crowd > 0) {
        std::atomic<bool> go{true};
        std::atomic<size_t> crowd_done{0};
        std::atomic<int> crowd_bad{0};
        std::vector<std::thread> ts;
        for (int k = 0; k < slow_clients; ++k)
            ts.emplace_back([&] {
                while (go) {
                    httplib::Client cc("127.0.0.1", port);
                    // httplib's client cannot trickle a head; a raw socket can.
                    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
                    sockaddr_in a{};
                    a.sin_family = AF_INET;
                    a.sin_port = htons(uint16_t(port));
                    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
                    if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0) {
                        std::string line = "GET /healthz HTTP/1.1\r\n";
                        while (go && ::send(fd, line.data(), line.size(), MSG_NOSIGNAL) > 0) {
                            std::this_thread::sleep_for(std::chrono::milliseconds(200));
                            line = "X-Slow: 1\r\n";
                        }
                    }
                    ::close(fd);
                }
            });
        for (int k = 0; k < crowd; ++k)
            ts.emplace_back([&] {
                httplib::Client cc("127.0.0.1", port);
                cc.set_keep_alive(true);
                cc.set_read_timeout(30, 0);
                while (go) {
                    auto res = cc.Get("/healthz");
                    if (res && res->status == 200) ++crowd_done; else ++crowd_bad;
                    for (int ms = 0; go && ms < crowd_pause_ms; ms += 50) std::this_thread::sleep_for(std::chrono::milliseconds(50));
                }
            });
        std::this_thread::sleep_for(std::chrono::milliseconds(500));  // the crowd connected
        const auto until = Clock::now() + std::chrono::duration<double>(seconds);
        while (Clock::now() < until) {
            httplib::Client cc("127.0.0.1", port);
            cc.set_read_timeout(5, 0);
            const auto a = Clock::now();
            auto res = cc.Get("/healthz");
            if (res && res->status == 200) probes.push_back(std::chrono::duration<double, std::milli>(Clock::now() - a).count());
            else ++probe_failures;
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        go = false;
        for (auto& t : ts) t.join();
        crowd_requests = crowd_done;
        crowd_failures = crowd_bad;
    }
    service.shutdown();  // cancel-free stop: the queued submissions stay queued and are dropped with the directory

    std::printf("Server on 127.0.0.1, %d client threads (keep-alive), %.0f s each phase, this machine's 2 cores shared by "
                "clients and server\n\n", clients, seconds);
    std::printf("| request | requests | throughput (/s) | p50 (ms) | p99 (ms) |\n|---|---:|---:|---:|---:|\n");
    std::printf("| GET /v1/jobs/{id} | %zu | %.0f | %.3f | %.3f |\n", polls.size(), double(polls.size()) / poll_wall, pct(polls, 0.5), pct(polls, 0.99));
    std::printf("| POST /v1/jobs | %zu | %.0f | %.3f | %.3f |\n", subs.size(), double(subs.size()) / sub_wall, pct(subs, 0.5), pct(subs, 0.99));
    if (slow_clients + crowd > 0) {
        std::printf("\nHostile load for %.0f s: %d clients sending a header line every 200 ms (reconnecting when cut), %d keep-alive "
                    "clients each sending GET /healthz then idling %d ms on the connection (%zu answered, %d failed), and a prober opening a fresh connection for each GET /healthz:\n\n",
                    seconds, slow_clients, crowd, crowd_pause_ms, crowd_requests, crowd_failures);
        std::printf("| prober | probes | failed | p50 (ms) | p99 (ms) | max (ms) |\n|---|---:|---:|---:|---:|---:|\n");
        std::printf("| GET /healthz | %zu | %d | %.3f | %.3f | %.3f |\n", probes.size(), probe_failures, pct(probes, 0.5), pct(probes, 0.99),
                    probes.empty() ? 0.0 : *std::max_element(probes.begin(), probes.end()));
    }
    api.stop();
    serving.join();
    std::filesystem::remove_all(dir);

    // 3. Overhead on a small job: submit → succeeded through a fresh server, against loading,
    //    building, rendering and writing the same job directly.
    const auto dir2 = dir.string() + "_overhead";
    std::filesystem::remove_all(dir2);
    cfg.data_dir = dir2;
    const auto queue2 = server::open_job_queue(cfg);
    server::JobQueue& service2 = *queue2;
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

    // 4. Prepared scenes kept between jobs.
    if (cache_triangles > 0 && scene_cache_latency(cache_triangles, cache_jobs).empty()) return 1;
    // 5. Live updates.
    if (event_jobs > 0 && !live_update_costs(event_jobs)) return 1;
    return 0;
}

}  // namespace tessera::cli
