#pragma once
// The options of a render node, shared by `tessera worker` and `tessera serve --redis --render`
// (each also read from TESSERA_<NAME>).
#include <algorithm>

#include <CLI/CLI.hpp>

#include "api/job.h"

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
    app.add_option_function<std::string>(
           "--tags",
           [&node](const std::string& text) {
               std::vector<std::string> tags;
               for (size_t at = 0; at <= text.size();) {
                   const size_t comma = std::min(text.find(',', at), text.size());
                   const std::string tag = text.substr(at, comma - at);
                   if (!tag.empty() && !api::valid_node_tag(tag))
                       throw CLI::ValidationError("--tags", "'" + tag + "' is not a tag (1 to 32 of a-z 0-9 _ . -, starting with a letter or digit)");
                   if (!tag.empty()) tags.push_back(tag);
                   at = comma + 1;
               }
               std::sort(tags.begin(), tags.end());
               tags.erase(std::unique(tags.begin(), tags.end()), tags.end());
               node.tags = std::move(tags);
           },
           "what this node offers to jobs' `requires`, comma-separated (e.g. bigmem,avx512): it takes a job's tasks only "
           "when it has every tag the job requires")
        ->envname("TESSERA_TAGS")
        ->type_name("TAGS");
}

}  // namespace tessera::server
