// `tessera serve`: the HTTP render server. Every flag also reads TESSERA_<FLAG> from the
// environment (TESSERA_PORT, TESSERA_DATA_DIR, ...); a flag given on the command line wins.
#include "build_paths.h"
#include <sys/resource.h>

#include <cctype>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "cli/serve_command.h"

#include "cli/command_line.h"
#include "engine/io/image_io.h"
#include "server/http/http_api.h"
#include "server/farm/farm_queue.h"
#include "server/memory_return.h"
#include "cli/node_options.h"

extern const char* const kTesseraOpenApiYaml;

namespace tessera::server {
namespace {

struct Options {
    std::string host = "127.0.0.1";
    int port = 8080;
    std::string log_level = "info";
    ServiceConfig service;
    HttpLimits http;
};

}  // namespace

int serve_command(int argc, char** argv) {
    Options o;
    o.service.project_scenes = TESSERA_DEFAULT_SCENES_DIR;
    auto& lim = o.service.job_limits;
    CLI::App app{"The HTTP render server. Each option can also be given as an environment variable TESSERA_<NAME> "
                 "(TESSERA_PORT, TESSERA_DATA_DIR, ...); a flag on the command line wins.", "serve"};
    // The last of a repeated option wins: a container's command line (compose `command:`)
    // is appended to the image's entry point and must be able to override it.
    app.option_defaults()->always_capture_default()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
    auto option = [&](const std::string& name, auto& value, const std::string& what) {
        std::string env = "TESSERA_";
        for (char c : name) env += c == '-' ? '_' : char(std::toupper(static_cast<unsigned char>(c)));
        return app.add_option("--" + name, value, what)->envname(env);
    };
    option("host", o.host, "listen address")->type_name("ADDR");
    option("port", o.port, "port; 0 picks a free one and logs it")->check(CLI::Range(0, 65535));
    option("data-dir", o.service.data_dir, "job records, uploads and results")->type_name("DIR");
    // Not through option(): TESSERA_SCENES holds several folders, and they add to the flags'
    // rather than give way to them (the container image passes --scenes itself).
    std::vector<std::string> scene_flags;
    app.add_option("--scenes", scene_flags, "a folder of scenes for the catalog (repeatable; TESSERA_SCENES: "
                                            "':'-separated folders, added before these)")
        ->type_name("DIR")
        ->default_str("")
        ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
    option("threads", o.service.render_threads, "render threads per job (0: all cores)")->check(CLI::Range(0, 1024));
    option("max-jobs", o.service.concurrent_jobs, "jobs rendered at the same time")->check(CLI::Range(1, 64));
    option("checkpoint-s", o.service.checkpoint_s,
           "a running job's film is written to its folder every this many seconds of rendering (0: only when it "
           "stops); after a crash or restart it continues from there")
        ->check(CLI::Range(0.0, 86400.0));
    option("notify-secret", o.service.notify.secret,
           "the key of the HMAC-SHA256 that signs jobs' notifications (X-Tessera-Signature); without it jobs asking for "
           "notifications are refused. Give it as TESSERA_NOTIFY_SECRET rather than on the command line, which others "
           "may read")
        ->type_name("KEY");
    option("notify-allow", o.service.notify.allow,
           "where notifications may be sent: host, *.domain or *, each with :port or :* (none: the URL's scheme's port, 80 or 443), comma-separated; "
           "an address of this server's own network (loopback, private, link-local) only by an entry naming the host itself")
        ->type_name("HOSTS")
        ->delimiter(',');
    option("notify-ca", o.service.notify.ca_file,
           "a file of CA certificates (PEM) that https receivers' certificates are checked against, instead of the "
           "system's (a private CA); a receiver whose certificate fails the check is not sent to")
        ->type_name("FILE")
        ->check(CLI::ExistingFile);
    option("notify-attempts", o.service.notify.max_attempts, "tries of a notification the receiver fails (5xx, 408, 429, no answer), "
                                                            "1 s apart doubling")
        ->check(CLI::Range(1, 20));
    option("max-queued", o.service.max_queued, "queued jobs before 429")->check(CLI::Range(1, 10'000'000));
    option("max-body", o.http.max_job_body, "bytes of a job request body")->type_name("BYTES")->check(CLI::Range(256LL, 1LL << 30));
    option("max-upload", o.http.max_upload, "bytes of a scene upload")->type_name("BYTES")->check(CLI::Range(1024LL, 1LL << 34));
    option("max-connections", o.http.connections.max_connections, "open HTTP connections; one more is answered 503 and closed")
        ->check(CLI::Range(4, 100000));
    option("header-timeout", o.http.connections.header_timeout_s,
           "seconds for a request's line and headers to arrive, from the connection's start or the end of the keep-alive wait")
        ->type_name("SECONDS")->check(CLI::Range(0.1, 3600.0));
    option("body-timeout", o.http.connections.body_timeout_s,
           "seconds for a request's body (and its handling), extended by what arrives at --min-rate; and for a "
           "response, plus its size at --min-rate")
        ->type_name("SECONDS")->check(CLI::Range(0.1, 3600.0));
    std::string token_file;
    option("token-file", token_file,
           "bearer tokens, one per line: every /v1 route (and /metrics) then needs 'Authorization: Bearer <token>'. "
           "TESSERA_TOKENS may hold tokens too (comma-separated); never pass a token as a flag")
        ->type_name("FILE");
    bool allow_anonymous = false;
    app.add_flag("--allow-anonymous", allow_anonymous,
                 "serve without tokens on an address other than loopback (anyone who reaches it may submit jobs)")
        ->envname("TESSERA_ALLOW_ANONYMOUS");
    app.add_flag("--metrics-open", o.http.metrics_open, "with tokens: serve /metrics without one (for a scraper)")
        ->envname("TESSERA_METRICS_OPEN");
    option("min-rate", o.http.connections.min_rate,
           "bytes per second a client must keep up on a long request body or response (the deadline grows by size / rate)")
        ->type_name("BYTES/S")->check(CLI::Range(1.0, 1e12));
    option("max-pixels", lim.max_pixels, "width × height of a job")->check(CLI::Range(1LL, 1LL << 32));
    option("max-spp", lim.max_spp, "samples per pixel of a job")->check(CLI::Range(1, 1 << 24));
    option("max-depth", lim.max_depth, "bounce depth of a job")->check(CLI::Range(0, 100000));
    option("max-light-rays", lim.max_light_rays, "light rays per hit of a job")->check(CLI::Range(1, 1 << 20));
    option("max-frames", lim.max_frames, "frames in one shot")->check(CLI::Range(1, 10'000'000));
    CLI::Option* max_triangles = option("max-triangles", o.service.load_limits.max_triangles, "triangles in a scene")
                                     ->check(CLI::Range(uint64_t{1}, uint64_t{1} << 40));
    // What a client's request or scene may cost, checked before the memory is spent
    // (docs/reliability.md lists each with what it refuses).
    uint64_t bodies_mb = o.http.max_bodies_in_flight >> 20;
    option("max-bodies-mb", bodies_mb,
           "MiB that all request bodies being read at once may take (each counts its Content-Length, or its route's "
           "bound when chunked); past it a request gets 503 before its body is read")
        ->check(CLI::Range(uint64_t{1}, uint64_t{1} << 24));
    uint64_t encoded_mb = o.http.max_encoded >> 20;
    option("max-encoded-mb", encoded_mb,
           "MiB that images encoded on request (a running job's pass, another exposure) may hold until their clients "
           "have read them; past it such a request gets 503 with Retry-After (result files are streamed from disk)")
        ->check(CLI::Range(uint64_t{1}, uint64_t{1} << 24));
    option("max-header-bytes", o.http.max_head_bytes, "bytes of a request's line and headers; past them 431")
        ->type_name("BYTES")->check(CLI::Range(1024LL, 1LL << 24));
    option("max-json-depth", o.http.max_json_depth,
           "nesting of arrays and objects in a job's JSON and in a glTF scene's JSON; deeper is refused with 400")
        ->check(CLI::Range(8, 10000));
    uint64_t texture_mb = o.service.load_limits.max_texture_bytes >> 20;
    option("max-texture-mb", texture_mb,
           "MiB of decoded texels in a scene, each image's decoding peak (2.5x its texels) included; checked from the "
           "image headers before decoding")
        ->check(CLI::Range(uint64_t{1}, uint64_t{1} << 20));
    option("max-texture-size", o.service.load_limits.max_texture_size, "texels on a side of one image")->check(CLI::Range(1, 1 << 16));
    option("max-instances", o.service.load_limits.max_instances, "mesh primitives placed by a scene's nodes")
        ->check(CLI::Range(uint64_t{1}, uint64_t{1} << 32));
    uint64_t scene_file_mb = o.service.load_limits.max_file_bytes >> 20;
    option("max-scene-file-mb", scene_file_mb, "MiB of one scene file or one of its buffer files")
        ->check(CLI::Range(uint64_t{1}, uint64_t{1} << 24));
    int64_t store_mb = 0;
    option("max-store-mb", store_mb, "size bound of the job store in MiB (0: none); past it new jobs get 507")
        ->check(CLI::Range(int64_t{0}, int64_t{1} << 30));
    option("log-level", o.log_level, "log level: trace|debug|info|warn|error")->type_name("LEVEL");
    option("redis", o.service.redis_url,
           "a render farm: job records, queue and tiles in Redis (redis://[user:password@]host:port/db); "
           "every API node answers for every job. Unset: one process with SQLite")
        ->type_name("URL");
    app.add_flag("--render", o.service.render_locally, "with --redis: also render tiles in this process (a render node)")
        ->envname("TESSERA_RENDER");
    add_node_options(app, o.service.node);
    if (const auto status = parse_args(app, argc, argv)) return *status;
    if (o.service.render_locally && o.service.redis_url.empty()) {
        std::fprintf(stderr, "tessera serve: --render needs --redis (without Redis the server renders anyway)\n");
        return 2;
    }
    if (!o.service.redis_url.empty()) {
        try {
            RedisUrl::parse(o.service.redis_url);
        } catch (const std::exception& e) {
            std::fprintf(stderr, "tessera serve: --redis: %s\n", e.what());
            return 2;
        }
    }
    try {
        std::vector<std::string> tokens;
        if (!token_file.empty()) tokens = BearerAuth::read_token_file(token_file);
        if (const char* env = std::getenv("TESSERA_TOKENS")) {
            const auto more = BearerAuth::parse_token_list(env);
            tokens.insert(tokens.end(), more.begin(), more.end());
        }
        o.http.auth = BearerAuth(std::move(tokens));
    } catch (const std::exception& e) {
        std::fprintf(stderr, "tessera serve: %s\n", e.what());
        return 2;
    }
    if (!o.http.auth.enabled() && !is_loopback_host(o.host) && !allow_anonymous) {
        std::fprintf(stderr,
                     "tessera serve: refusing to listen on %s without tokens: anyone who reaches it could submit jobs and "
                     "upload files. Give tokens (--token-file FILE or TESSERA_TOKENS), or say --allow-anonymous "
                     "(TESSERA_ALLOW_ANONYMOUS=1) if the network in front does the access control\n",
                     o.host.c_str());
        return 2;
    }
    o.service.max_store_bytes = store_mb << 20;
    if (max_triangles->count() > 0) o.service.load_limits.max_vertices = o.service.load_limits.max_triangles * 3;
    o.service.load_limits.max_texture_bytes = texture_mb << 20;
    o.http.max_bodies_in_flight = bodies_mb << 20;
    o.http.max_encoded = encoded_mb << 20;
    o.service.load_limits.max_file_bytes = scene_file_mb << 20;
    o.service.load_limits.max_json_depth = o.http.max_json_depth;
    if (const char* env = std::getenv("TESSERA_SCENES")) {
        const std::string all = env;
        for (size_t start = 0; start <= all.size();) {
            const size_t colon = all.find(':', start);
            const std::string part = all.substr(start, colon == std::string::npos ? std::string::npos : colon - start);
            if (!part.empty()) o.service.scene_dirs.push_back(part);
            if (colon == std::string::npos) break;
            start = colon + 1;
        }
    }
    o.service.scene_dirs.insert(o.service.scene_dirs.end(), scene_flags.begin(), scene_flags.end());
    const auto level = spdlog::level::from_str(o.log_level);
    if (level == spdlog::level::off && o.log_level != "off") {
        std::fprintf(stderr, "tessera serve: unknown log level '%s'\n", o.log_level.c_str());
        return 2;
    }
    spdlog::set_level(level);

    // A connection holds two descriptors (httplib's and the guard's), jobs and the store more:
    // the usual soft limit of 1,024 would run out first. Raised to the hard limit, and the
    // connection bound checked against it.
    if (rlimit nofile{}; getrlimit(RLIMIT_NOFILE, &nofile) == 0) {
        if (nofile.rlim_cur < nofile.rlim_max) {
            nofile.rlim_cur = nofile.rlim_max;
            setrlimit(RLIMIT_NOFILE, &nofile);
            getrlimit(RLIMIT_NOFILE, &nofile);
        }
        const rlim_t needed = rlim_t(o.http.connections.max_connections) * 2 + 256;
        if (nofile.rlim_cur != RLIM_INFINITY && nofile.rlim_cur < needed)
            spdlog::warn("{} open files allowed (ulimit -n): fewer than --max-connections {} needs ({}); connections past "
                         "that are refused", uint64_t(nofile.rlim_cur), o.http.connections.max_connections, uint64_t(needed));
    }
    sigset_t signals = block_stop_signals();
    tune_allocator();

    const std::string openapi = (std::filesystem::path(o.service.data_dir) / "openapi.yaml").string();
    std::unique_ptr<JobQueue> service;
    std::unique_ptr<HttpApi> api;
    int port = 0;
    try {
        load_image_io();  // a server that cannot write its results stops here, not at its first job
        service = open_job_queue(o.service);
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
    // Idle scenes dropped and free memory returned every few seconds: an idle server shrinks.
    MemoryReturn memory_return(5.0, [&service] { service->release_memory(); });
    if (o.http.auth.enabled())
        spdlog::info("access: {} bearer token{}; /healthz, /readyz{} open", o.http.auth.size(), o.http.auth.size() == 1 ? "" : "s",
                     o.http.metrics_open ? ", /metrics" : "");
    else if (!is_loopback_host(o.host))
        spdlog::warn("access: no tokens on {} (--allow-anonymous): anyone who reaches it may submit jobs and upload files", o.host);
    spdlog::info("listening on http://{}:{} (data in {}, {} render threads{})", o.host, port, o.service.data_dir,
                 o.service.render_threads ? std::to_string(o.service.render_threads) : std::string("all"),
                 o.service.redis_url.empty() ? std::string()
                                             : ", farm on " + RedisUrl::parse(o.service.redis_url).redacted() +
                                                   (o.service.render_locally ? ", rendering here too" : ", API only"));

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
