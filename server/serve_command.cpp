// `tessera serve`: the HTTP render server. Every flag also reads TESSERA_<FLAG> from the
// environment (TESSERA_PORT, TESSERA_DATA_DIR, ...); a flag given on the command line wins.
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <spdlog/spdlog.h>

#include "server/serve_command.h"
#include "server/http_api.h"
#include "server/job_service.h"

extern const char* const kTesseraOpenApiYaml;

namespace tessera::server {
namespace {

constexpr const char* kHelp = R"(usage: tessera serve [options]   (each option also as an environment variable TESSERA_<NAME>)
  --host ADDR           listen address (127.0.0.1)
  --port N              port; 0 picks a free one and logs it (8080)
  --data-dir DIR        job records, uploads and results (./data)
  --scenes DIR          a folder of scenes for the catalog (repeatable; TESSERA_SCENES is ':'-separated)
  --threads N           render threads per job (0: all cores)
  --max-jobs N          jobs rendered at the same time (1)
  --max-queued N        queued jobs before 429 (1000)
  --max-body BYTES      job request body (1048576)      --max-upload BYTES   scene upload (268435456)
  --max-pixels N        width × height (268435456)      --max-spp N          (65536)
  --max-depth N         (1000)                          --max-light-rays N   (1024)
  --max-triangles N     triangles in a scene (50000000)
  --log-level LEVEL     trace|debug|info|warn|error (info)
)";

struct Options {
    std::string host = "127.0.0.1";
    int port = 8080;
    std::string log_level = "info";
    ServiceConfig service;
    HttpLimits http;
};

long long number(const std::string& flag, const std::string& v, long long lo, long long hi) {
    char* end = nullptr;
    const long long n = std::strtoll(v.c_str(), &end, 10);
    if (v.empty() || *end != '\0' || n < lo || n > hi)
        throw std::invalid_argument(flag + " must be a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got '" + v + "'");
    return n;
}

// Applies one option (from a flag or the environment).
void apply(Options& o, const std::string& name, const std::string& v) {
    auto& lim = o.service.job_limits;
    if (name == "host") o.host = v;
    else if (name == "port") o.port = int(number("--port", v, 0, 65535));
    else if (name == "data-dir") o.service.data_dir = v;
    else if (name == "scenes") o.service.scene_dirs.push_back(v);
    else if (name == "threads") o.service.render_threads = int(number("--threads", v, 0, 1024));
    else if (name == "max-jobs") o.service.concurrent_jobs = int(number("--max-jobs", v, 1, 64));
    else if (name == "max-queued") o.service.max_queued = size_t(number("--max-queued", v, 1, 10'000'000));
    else if (name == "max-body") o.http.max_job_body = size_t(number("--max-body", v, 256, 1ll << 30));
    else if (name == "max-upload") o.http.max_upload = size_t(number("--max-upload", v, 1024, 1ll << 34));
    else if (name == "max-pixels") lim.max_pixels = number("--max-pixels", v, 1, 1ll << 32);
    else if (name == "max-spp") lim.max_spp = int(number("--max-spp", v, 1, 1 << 24));
    else if (name == "max-depth") lim.max_depth = int(number("--max-depth", v, 0, 100000));
    else if (name == "max-light-rays") lim.max_light_rays = int(number("--max-light-rays", v, 1, 1 << 20));
    else if (name == "max-triangles") {
        o.service.load_limits.max_triangles = uint64_t(number("--max-triangles", v, 1, 1ll << 40));
        o.service.load_limits.max_vertices = o.service.load_limits.max_triangles * 3;
    } else if (name == "log-level") o.log_level = v;
    else throw std::invalid_argument("unknown option --" + name + " (see tessera serve --help)");
}

const char* kNames[] = {"host", "port", "data-dir", "scenes", "threads", "max-jobs", "max-queued", "max-body",
                        "max-upload", "max-pixels", "max-spp", "max-depth", "max-light-rays", "max-triangles", "log-level"};

}  // namespace

int serve_command(int argc, char** argv) {
    Options o;
    o.service.project_scenes = TESSERA_DEFAULT_SCENES_DIR;
    try {
        for (const char* n : kNames) {
            std::string env = "TESSERA_";
            for (const char* c = n; *c; ++c) env += *c == '-' ? '_' : char(std::toupper(*c));
            const char* v = std::getenv(env.c_str());
            if (!v || !*v) continue;
            if (std::string(n) == "scenes") {
                std::string all = v;
                for (size_t start = 0; start <= all.size();) {
                    const size_t colon = all.find(':', start);
                    const std::string part = all.substr(start, colon == std::string::npos ? std::string::npos : colon - start);
                    if (!part.empty()) apply(o, n, part);
                    if (colon == std::string::npos) break;
                    start = colon + 1;
                }
            } else {
                apply(o, n, v);
            }
        }
        for (int i = 0; i < argc; ++i) {
            const std::string a = argv[i];
            if (a == "--help" || a == "-h") { std::fputs(kHelp, stdout); return 0; }
            if (a.rfind("--", 0) != 0 || i + 1 >= argc) throw std::invalid_argument("expected --option VALUE, got '" + a + "'");
            apply(o, a.substr(2), argv[++i]);
        }
    } catch (const std::invalid_argument& e) {
        std::fprintf(stderr, "tessera serve: %s\n", e.what());
        return 2;
    }
    const auto level = spdlog::level::from_str(o.log_level);
    if (level == spdlog::level::off && o.log_level != "off") {
        std::fprintf(stderr, "tessera serve: unknown log level '%s'\n", o.log_level.c_str());
        return 2;
    }
    spdlog::set_level(level);

    // SIGTERM and SIGINT are taken by one thread with sigwait, so shutdown runs as ordinary
    // code rather than in a signal handler. The mask must be set before any thread starts.
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGTERM);
    sigaddset(&signals, SIGINT);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);
    std::signal(SIGPIPE, SIG_IGN);

    const std::string openapi = (std::filesystem::path(o.service.data_dir) / "openapi.yaml").string();
    std::unique_ptr<JobService> service;
    std::unique_ptr<HttpApi> api;
    int port = 0;
    try {
        service = std::make_unique<JobService>(o.service);
        {
            std::ofstream out(openapi);
            out << kTesseraOpenApiYaml;
        }
        api = std::make_unique<HttpApi>(*service, o.http, openapi);
        port = api->bind(o.host, o.port);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "tessera serve: %s\n", e.what());
        return 1;
    }
    spdlog::info("listening on http://{}:{} (data in {}, {} render threads)", o.host, port, o.service.data_dir,
                 o.service.render_threads ? std::to_string(o.service.render_threads) : std::string("all"));

    std::thread signal_thread([&] {
        int sig = 0;
        sigwait(&signals, &sig);
        spdlog::info("signal {}: no new jobs; interrupting running ones (they will be re-queued)", sig);
        service->shutdown();
        api->stop();
    });
    api->serve();
    // serve() also returns if the listener fails; make sure the signal thread can finish.
    if (service->accepting()) {
        service->shutdown();
        pthread_kill(signal_thread.native_handle(), SIGTERM);
    }
    signal_thread.join();
    spdlog::info("stopped");
    return 0;
}

}  // namespace tessera::server
