#pragma once
// The records a render farm keeps in Redis beside the job store's, each declared once: a render
// job's run (fields of its job hash), a tile's commit (the arguments of its script), a
// whole tile's error sums. Scripts take and return them by field name, never by position.
#include <string>
#include <vector>

#include "engine/render/passes.h"
#include "engine/render/renderer.h"
#include "server/store/redis_client.h"

namespace tessera::server {

// A render job's run: its pass, the pass's target and tiles, and the statistics of every tile
// committed (the counters summed, max_sample the largest).
struct FarmRun {
    std::string state;
    long long pass = -1, target = 0, tiles_total = 0, tiles_done = 0, started_ms = 0;
    bool timed_out = false;
    RenderStats stats;
};

// The job hash fields of a run, to read with HMGET: the state and run fields, then the counters.
const std::vector<std::string>& farm_run_fields();
// `values`: HMGET's answer for farm_run_fields(), in that order. Missing fields keep defaults.
FarmRun decode_farm_run(const RedisValue& values);
// The field, value pairs a run starts with (the begin script's HSET): pass 0 at `target`.
std::vector<std::string> farm_run_start(long long target, size_t tiles, long long started_ms);

// What a node stores when it finishes a tile task. Its fields are listed once (fields()): the
// script's arguments are their values, and the script reads them by the names the same list
// gives (commit_tile_script), so neither side counts positions.
struct TileCommit {
    std::string job, task_id, node;
    size_t tile = 0;
    int pass = 0;
    std::string payload;    // the tile's film (pass by pass) or resolved pixels (whole tile)
    double seconds = 0;     // rendering it on this node
    bool timed_out = false;
    RenderStats stats;
    std::string sums;       // a whole tile's sums per target (whole_tile_sums_text), or empty
    // Name and value of every field, the render counters last under "n:<counter>".
    std::vector<std::pair<std::string, std::string>> fields() const;
    std::vector<std::string> arguments() const;  // the values of fields(), for the script's ARGV
};
// lua::commit_tile_body behind a prologue made from TileCommit::fields(): `a.<field>` is the
// argument of that name, add_counters(key) adds each counter to the run's field of its name.
const std::string& commit_tile_script();

// A whole tile's sums per target as the sums hash keeps them (JSON), and back. Reading fails
// naming a missing field (a node of another version), never silently.
std::string whole_tile_sums_text(const std::vector<TargetSums>& sums);
std::vector<TargetSums> whole_tile_sums_from_text(const std::string& text);

}  // namespace tessera::server
