// The live updates' costs, for `tessera bench server`: how long a job's changes take to reach a
// client of GET /v1/events, what keeping each pass's image costs a render (the same job run
// with and without it, paired), and what a running job's image costs per request.
#include "build_paths.h"
#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <httplib.h>
#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "api/job_runner.h"
#include "cli/bench_common.h"
#include "engine/io/image_io.h"
#include "engine/render/film.h"
#include "cli/in_process_server.h"

namespace tessera::cli {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

double unix_now() {
    return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

double median(std::vector<double> v) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

double quantile(std::vector<double> v, double q) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, size_t(q * double(v.size())))];
}

// Each event's type, its job's status and when (unix seconds) the client had it.
struct Received {
    std::string type;
    json job;
    double at;
};

}  // namespace

bool live_update_costs(int jobs) {
    spdlog::set_level(spdlog::level::err);
    InProcessServer server("events");
    const int port = server.port;

    // A subscriber that stamps every event as it arrives.
    std::mutex mu;
    std::condition_variable cv;
    std::vector<Received> got;
    bool open = false;
    std::atomic<bool> stop{false};
    std::thread reader([&] {
        httplib::Client c("127.0.0.1", port);
        c.set_read_timeout(60, 0);
        std::string pending;
        c.Get("/v1/events", [&](const char* data, size_t n) {
            const double at = unix_now();
            pending.append(data, n);
            std::lock_guard<std::mutex> lock(mu);
            open = true;
            size_t end;
            while ((end = pending.find("\n\n")) != std::string::npos) {
                const std::string block = pending.substr(0, end);
                pending.erase(0, end + 2);
                const size_t e = block.find("event: "), d = block.find("data: ");
                if (e == std::string::npos || d == std::string::npos) continue;
                const std::string type = block.substr(e + 7, block.find('\n', e) - e - 7);
                const json j = json::parse(block.substr(d + 6), nullptr, false);
                if (j.is_object() && j.contains("job")) got.push_back({type, j["job"], at});
            }
            cv.notify_all();
            return !stop.load();
        });
    });
    {
        std::unique_lock<std::mutex> lock(mu);
        cv.wait_for(lock, std::chrono::seconds(10), [&] { return open; });
    }
    httplib::Client c("127.0.0.1", port);
    c.set_tcp_nodelay(true);
    const json small = {{"scene", "cornell_box"}, {"width", 64}, {"height", 48}, {"spp", 16}, {"max_depth", 2}};
    std::vector<double> created_ms, running_ms, finished_ms;
    bool ok = true;
    for (int i = 0; i < jobs && ok; ++i) {
        const double sent = unix_now();
        auto r = c.Post("/v1/jobs", small.dump(), "application/json");
        if (!r || r->status != 202) { ok = false; break; }
        const std::string id = json::parse(r->body)["id"];
        std::unique_lock<std::mutex> lock(mu);
        auto find = [&](const std::string& type, const std::string& state) -> const Received* {
            for (const auto& e : got)
                if (e.type == type && e.job["id"] == id && e.job["state"] == state) return &e;
            return nullptr;
        };
        if (!cv.wait_for(lock, std::chrono::seconds(30), [&] { return find("state", "succeeded") != nullptr; })) { ok = false; break; }
        // From the change as the server recorded it (or the request's sending) to the client.
        if (const auto* e = find("created", "queued")) created_ms.push_back((e->at - sent) * 1e3);
        if (const auto* e = find("state", "running")) running_ms.push_back((e->at - e->job["started_at"].get<double>()) * 1e3);
        const auto* done = find("state", "succeeded");
        finished_ms.push_back((done->at - done->job["finished_at"].get<double>()) * 1e3);
    }
    stop = true;
    // The reader returns at its next event or keep-alive; stopping the server ends the stream.
    server.stop();
    reader.join();
    if (!ok) {
        std::fprintf(stderr, "bench: a job or its events did not arrive\n");
        return false;
    }
    std::printf("\nLive updates: one client of GET /v1/events while %d small jobs (cornell_box 64×48, 16 spp) run one after "
                "another; from the change (the POST sent, the job's started_at, its finished_at) to the event at the client:\n\n",
                jobs);
    std::printf("| event | events | p50 (ms) | p99 (ms) |\n|---|---:|---:|---:|\n");
    std::printf("| created (from sending the POST) | %zu | %.3f | %.3f |\n", created_ms.size(), median(created_ms), quantile(created_ms, 0.99));
    std::printf("| state running | %zu | %.3f | %.3f |\n", running_ms.size(), median(running_ms), quantile(running_ms, 0.99));
    std::printf("| state succeeded | %zu | %.3f | %.3f |\n", finished_ms.size(), median(finished_ms), quantile(finished_ms, 0.99));

    // What keeping each pass costs a render: the same job through the runner with and without
    // a pass callback, alternating, 5 pairs.
    const auto job = api::parse_render_job({{"scene", "cornell_spheres"}, {"width", 320}, {"height", 240}, {"spp", 64}, {"max_depth", 3}});
    api::RunOptions opt;
    opt.scene_source = std::string(TESSERA_DEFAULT_SCENES_DIR) + "/cornell_spheres.gltf";
    std::vector<double> with, without;
    int passes = 0;
    for (int rep = 0; rep < 5; ++rep)
        for (const bool keep : {false, true}) {
            api::RunCallbacks cb;
            std::shared_ptr<const Image> latest;
            int n = 0;
            if (keep) cb.pass = [&](const api::PassSnapshot& s) { latest = s.image; ++n; };
            const auto t0 = Clock::now();
            api::run_job(job, opt, api::RunOutputs{}, cb);
            (keep ? with : without).push_back(std::chrono::duration<double>(Clock::now() - t0).count());
            if (keep) passes = n;
        }
    // And per request: a running job's image encoded from the kept pass, at 800×600.
    Film film(800, 600, true, false);
    for (size_t i = 0; i < film.count.size(); ++i) film.count[i] = 4;
    std::vector<double> resolve_ms, png_ms, exr_ms;
    Image img;
    for (int rep = 0; rep < 9; ++rep) {
        auto t0 = Clock::now();
        film.resolve_into(img);  // as the runner does from its second pass on
        resolve_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
        t0 = Clock::now();
        const auto png = png_bytes(img, 1.f);
        png_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
        t0 = Clock::now();
        const auto exr = exr_bytes(img);
        exr_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    }
    std::printf("\nKeeping each pass's image (cornell_spheres 320×240, 64 spp, depth 3: %d passes), 5 alternating pairs through the "
                "job runner: median %.3f s with, %.3f s without (ratio %.3f; runs %.3f–%.3f s with, %.3f–%.3f s without).\n",
                passes, median(with), median(without), median(with) / median(without), *std::min_element(with.begin(), with.end()),
                *std::max_element(with.begin(), with.end()), *std::min_element(without.begin(), without.end()),
                *std::max_element(without.begin(), without.end()));
    std::printf("At 800×600: keeping a pass (resolving the film into the image kept from two passes before) %.2f ms; a running job's image.png %.1f ms, image.exr %.1f ms "
                "per request (medians of 9).\n", median(resolve_ms), median(png_ms), median(exr_ms));
    return true;
}

}  // namespace tessera::cli
