// `tessera worker`: a render node of a farm. It takes tiles from Redis, renders them and stores
// them; it serves no HTTP (its metrics reach the API nodes' /metrics through Redis).
#include <csignal>
#include <cstdio>
#include <thread>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "engine/io/image_io.h"
#include "server/memory_return.h"
#include "cli/command_line.h"
#include "cli/node_options.h"
#include "cli/serve_command.h"

namespace tessera::server {

int worker_command(int argc, char** argv) {
    NodeConfig node;
    node.threads = int(std::max(1u, std::thread::hardware_concurrency()));
    std::string redis, log_level = "info";
    CLI::App app{"A render node of a farm: renders the tiles of jobs queued in Redis by `tessera serve --redis`. "
                 "Each option can also be given as TESSERA_<NAME>.", "worker"};
    app.option_defaults()->always_capture_default()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
    app.add_option("--redis", redis, "the farm's Redis: redis://[user:password@]host:port/db")
        ->envname("TESSERA_REDIS")
        ->type_name("URL")
        ->required();
    app.add_option("--data-dir", node.data_dir, "the results directory the API nodes read (a shared volume)")
        ->envname("TESSERA_DATA_DIR")
        ->type_name("DIR");
    app.add_option("--threads", node.threads, "tiles rendered at once (one per thread)")->envname("TESSERA_THREADS")->check(CLI::Range(1, 1024));
    CLI::Option* max_triangles = app.add_option("--max-triangles", node.load_limits.max_triangles, "triangles in a scene")
                                     ->envname("TESSERA_MAX_TRIANGLES")
                                     ->check(CLI::Range(uint64_t{1}, uint64_t{1} << 40));
    app.add_option("--checkpoint-s", node.checkpoint_s,
                   "a shot's frame in hand is checkpointed to the shared results folder this often, in seconds of rendering "
                   "(and when the node stops or the job is paused), so that it continues there; 0: only then")
        ->envname("TESSERA_CHECKPOINT_S")
        ->check(CLI::Range(0.0, 1e7));
    app.add_option("--log-level", log_level, "log level: trace|debug|info|warn|error")->envname("TESSERA_LOG_LEVEL")->type_name("LEVEL");
    add_node_options(app, node);
    if (const auto status = parse_args(app, argc, argv)) return *status;
    if (max_triangles->count() > 0) node.load_limits.max_vertices = node.load_limits.max_triangles * 3;
    try {
        node.redis = RedisUrl::parse(redis);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "tessera worker: --redis: %s\n", e.what());
        return 2;
    }
    const auto level = spdlog::level::from_str(log_level);
    if (level == spdlog::level::off && log_level != "off") {
        std::fprintf(stderr, "tessera worker: unknown log level '%s'\n", log_level.c_str());
        return 2;
    }
    spdlog::set_level(level);
    sigset_t signals = block_stop_signals();
    tune_allocator();
    try {
        load_image_io();  // a node that cannot read a job's reference image stops here
        // Fails early, with the redacted address, when Redis does not answer.
        Redis probe(node.redis);
        probe.command({"PING"});
    } catch (const std::exception& e) {
        std::fprintf(stderr, "tessera worker: %s\n", e.what());
        return 1;
    }
    RenderNode rn(node);
    rn.start();
    // Idle scenes dropped and free memory returned every few seconds: an idle node shrinks.
    MemoryReturn memory_return(5.0, [&rn] {
        rn.drop_idle_scenes();
        release_free_memory();
    });
    int sig = 0;
    sigwait(&signals, &sig);
    spdlog::info("signal {}: handing back the tasks in hand and stopping", sig);
    rn.stop();
    spdlog::info("stopped");
    return 0;
}

}  // namespace tessera::server
