#pragma once
// The options of a render node, shared by `tessera worker` and `tessera serve --redis --render`
// (each also read from TESSERA_<NAME>).
#include <CLI/CLI.hpp>

#include "server/farm/render_node.h"

namespace tessera::server {

inline void add_node_options(CLI::App& app, NodeConfig& node) {
    app.add_option("--node-name", node.name, "this render node's name in reports and metrics (default: host-pid)")
        ->envname("TESSERA_NODE_NAME")
        ->type_name("NAME");
    app.add_option("--visibility-ms", node.visibility_ms,
                   "a task whose node is silent this long is taken over by another node (nodes renew their claims "
                   "every quarter of it while they work)")
        ->envname("TESSERA_VISIBILITY_MS")
        ->check(CLI::Range(200, 3'600'000));
    app.add_option("--max-deliveries", node.max_deliveries, "a task delivered more often fails its job with that reason")
        ->envname("TESSERA_MAX_DELIVERIES")
        ->check(CLI::Range(1, 1000));
    app.add_option("--scene-cache-mb", node.scene_cache_mb, "memory for prepared (loaded and built) scenes kept between jobs and tiles, in MiB; "
                   "least recently used go first")
        ->envname("TESSERA_SCENE_CACHE_MB")
        ->check(CLI::Range(int64_t{1}, int64_t{1} << 24));
    app.add_option("--scene-cache-idle-s", node.scene_cache_idle_s,
                   "a prepared scene unused this long is dropped, so that an idle server gives its memory back")
        ->envname("TESSERA_SCENE_CACHE_IDLE_S")
        ->check(CLI::Range(0.0, 1e7));
}

}  // namespace tessera::server
