#include "server/farm/farm_nodes.h"

#include <algorithm>

namespace tessera::server {

std::vector<FarmNode> parse_farm_nodes(const std::vector<std::pair<std::string, std::string>>& hash) {
    std::vector<FarmNode> out;
    for (const auto& [name, text] : hash) {
        const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
        if (!j.is_object()) continue;
        FarmNode n;
        n.name = name;
        auto num = [&](const char* k) { return j.contains(k) && j[k].is_number() ? j[k].get<double>() : 0.0; };
        n.last_seen = num("last_seen");
        n.beat_s = num("beat_s");
        n.threads = int(num("threads"));
        n.busy = num("busy");
        n.failed_tasks = (long long)num("failed_tasks");
        n.blocklisted_jobs = (long long)num("blocklisted_jobs");
        if (j.contains("tags") && j["tags"].is_array())
            for (const auto& t : j["tags"])
                if (t.is_string()) n.tags.push_back(t.get<std::string>());
        std::sort(n.tags.begin(), n.tags.end());
        n.heartbeat = j;
        out.push_back(std::move(n));
    }
    std::sort(out.begin(), out.end(), [](const FarmNode& a, const FarmNode& b) { return a.name < b.name; });
    return out;
}

bool has_tags(const FarmNode& n, const std::vector<std::string>& required) {
    return std::includes(n.tags.begin(), n.tags.end(), required.begin(), required.end());
}

nlohmann::json to_json(const FarmNode& n, double now_s) {
    return {{"name", n.name},
            {"live", is_live(n, now_s)},
            {"last_seen", n.last_seen},
            {"threads", n.threads},
            {"busy", n.busy},
            {"tags", n.tags},
            {"tiles", n.heartbeat.value("tiles", 0)},
            {"failed_tasks", n.failed_tasks},
            {"blocklisted_jobs", n.blocklisted_jobs},
            {"failing", is_failing(n)}};
}

}  // namespace tessera::server
