#include "api/json_text.h"

#include <set>
#include <vector>

#include "engine/io/json_depth.h"

namespace tessera::api {

std::string json_text(const nlohmann::json& j, int indent) {
    return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string cut_text(std::string text, size_t max) {
    if (text.size() <= max) return text;
    size_t cut = max;
    while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;  // not inside a character
    const size_t all = text.size();
    text.resize(cut);
    return text + "… (" + std::to_string(all) + " bytes)";
}

std::string json_excerpt(const nlohmann::json& j, size_t max) { return cut_text(json_text(j), max); }

JsonTooDeep::JsonTooDeep(int max_depth_)
    : std::runtime_error("the JSON nests arrays and objects deeper than " + std::to_string(max_depth_) + " levels, the bound"),
      max_depth(max_depth_) {}

JsonDuplicateKey::JsonDuplicateKey(const std::string& key)
    : std::runtime_error("the key " + json_excerpt(nlohmann::json(key)) + " appears twice in one object; give each key once") {}

std::optional<nlohmann::json> parse_json(std::string_view text, int max_depth) {
    if (const int depth = json_nesting_depth(text, max_depth); depth > max_depth) throw JsonTooDeep(max_depth);
    // The keys of each object open at the moment, innermost last (the depth is bounded above).
    // Ordered sets: a hash set's unseeded hash lets a megabyte of colliding keys cost quadratic time.
    std::vector<std::set<std::string>> open;
    std::optional<std::string> twice;
    const nlohmann::json::parser_callback_t keys = [&](int, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
        using E = nlohmann::json::parse_event_t;
        if (event == E::object_start) open.emplace_back();
        else if (event == E::object_end && !open.empty()) open.pop_back();
        else if (event == E::key && !open.empty() && !open.back().insert(parsed.get<std::string>()).second && !twice)
            twice = parsed.get<std::string>();
        return true;
    };
    nlohmann::json j = nlohmann::json::parse(text, keys, false);
    if (j.is_discarded()) return std::nullopt;
    if (twice) throw JsonDuplicateKey(*twice);
    return j;
}

}  // namespace tessera::api
