#include "server/farm/farm_records.h"

#include <cstdio>
#include <map>

#include <nlohmann/json.hpp>

#include "api/json_text.h"
#include "server/store/cluster_keys.h"
#include "server/store/cluster_lua.h"

// (In ErrorSums' namespace, where the JSON library looks for them.)
namespace tessera {
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(ErrorSums, spp, est, rel, mse, mae, pixels, est_pixels, half_buffer, reference, deep_outer,
                                   deep, deep_log_split, deep_pixels, shallow_outer, shallow, shallow_log_split, shallow_pixels)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(TargetSums, target, seconds, sums)
}  // namespace tessera

namespace tessera::server {

namespace {

// The run's own fields; the counters follow them.
const char* const kRunFields[] = {"state", "pass", "target", "tiles_total", "tiles_done", "started_ms", "timed_out", "max_sample"};
constexpr size_t kRunFieldCount = sizeof kRunFields / sizeof kRunFields[0];

}  // namespace

const std::vector<std::string>& farm_run_fields() {
    static const std::vector<std::string> fields = [] {
        std::vector<std::string> f(kRunFields, kRunFields + kRunFieldCount);
        RenderStats none;
        for_each_counter([&](const char* name, uint64_t) { f.push_back(name); }, none);
        return f;
    }();
    return fields;
}

FarmRun decode_farm_run(const RedisValue& v) {
    const std::vector<std::string>& names = farm_run_fields();
    std::map<std::string, const RedisValue*> by_name;
    for (size_t i = 0; i < names.size() && i < v.items.size(); ++i)
        if (!v.items[i].is_nil()) by_name[names[i]] = &v.items[i];
    auto get = [&](const std::string& name) -> const RedisValue* {
        const auto it = by_name.find(name);
        return it == by_name.end() ? nullptr : it->second;
    };
    FarmRun run;
    if (const auto* x = get("state")) run.state = x->text;
    for (auto [name, field] : {std::pair{"pass", &run.pass}, {"target", &run.target}, {"tiles_total", &run.tiles_total},
                               {"tiles_done", &run.tiles_done}, {"started_ms", &run.started_ms}})
        if (const auto* x = get(name)) *field = x->as_int();
    if (const auto* x = get("timed_out")) run.timed_out = x->as_int() == 1;
    if (const auto* x = get("max_sample")) run.stats.max_sample = std::stof(x->text);
    for_each_counter([&](const char* name, uint64_t& c) {
        if (const auto* x = get(name)) c = uint64_t(x->as_int());
    }, run.stats);
    return run;
}

std::vector<std::string> farm_run_start(long long target, size_t tiles, long long started_ms) {
    std::vector<std::string> a = {"pass", "0", "target", std::to_string(target), "tiles_total", std::to_string(tiles),
                                  "tiles_done", "0", "started_ms", std::to_string(started_ms), "timed_out", "0", "max_sample", "0"};
    RenderStats none;
    for_each_counter([&](const char* name, uint64_t) { a.insert(a.end(), {name, "0"}); }, none);
    return a;
}

std::vector<std::pair<std::string, std::string>> TileCommit::fields() const {
    std::vector<std::pair<std::string, std::string>> f = {
        {"job", job}, {"task", task_id}, {"group", keys::group}, {"node", node}, {"tile", std::to_string(tile)},
        {"pass", std::to_string(pass)}, {"film", payload}, {"seconds", redis_number(seconds)}, {"timed_out", timed_out ? "1" : "0"},
        {"max_sample", redis_number(stats.max_sample)}, {"sums", sums}};
    for_each_counter([&](const char* name, uint64_t c) { f.emplace_back(std::string("n:") + name, std::to_string(c)); }, stats);
    return f;
}

std::vector<std::string> TileCommit::arguments() const {
    std::vector<std::string> a;
    for (auto& [name, value] : fields()) a.push_back(std::move(value));
    return a;
}

const std::string& commit_tile_script() {
    static const std::string script = [] {
        std::string fields = "local a = {", counters = "local function add_counters(k)\n";
        size_t i = 0;
        for (const auto& [name, value] : TileCommit{}.fields()) {
            const std::string arg = "ARGV[" + std::to_string(++i) + "]";
            if (name.rfind("n:", 0) == 0) counters += "  redis.call('HINCRBY', k, '" + name.substr(2) + "', " + arg + ")\n";
            else fields += name + " = " + arg + ", ";
        }
        return fields + "}\n" + counters + "end\n" + lua::commit_tile_body;
    }();
    return script;
}

std::string whole_tile_sums_text(const std::vector<TargetSums>& sums) { return api::json_text(nlohmann::json(sums)); }

std::vector<TargetSums> whole_tile_sums_from_text(const std::string& text) {
    return nlohmann::json::parse(text).get<std::vector<TargetSums>>();
}

}  // namespace tessera::server
