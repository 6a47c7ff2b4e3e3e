#pragma once
// JSON as text, both ways, for everything a client or a file can put into it.
//
// nlohmann::json throws from dump() on a string that is not valid UTF-8, and a client controls
// many strings (a path, a job id, a scene's names, an error that quotes them): such a string
// must be answered, not thrown on. And a parsed tree is walked recursively afterwards (copies,
// dumps), so the nesting of a text is bounded before it is parsed.
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace tessera::api {

// dump() with invalid UTF-8 replaced by U+FFFD instead of thrown on.
std::string json_text(const nlohmann::json& j, int indent = -1);

// json_text() of a value an error quotes back to its client, cut to about `max` bytes (at a
// character's boundary, saying how long it was): a 1 MB field value refused made a 1 MB answer.
std::string json_excerpt(const nlohmann::json& j, size_t max = 80);
// Text cut to about `max` bytes the same way (an error's message and pointer).
std::string cut_text(std::string text, size_t max);

// The text parsed, or nothing when it is not JSON. Throws JsonTooDeep when it nests deeper than
// `max_depth` (checked on the bytes, before the parser builds anything).
struct JsonTooDeep : std::runtime_error {
    explicit JsonTooDeep(int max_depth);
    int max_depth;
};
// Throws JsonDuplicateKey where one object holds a key twice: a parser keeps the last, another
// (a proxy that checked the job) the first, and the two would read different jobs.
struct JsonDuplicateKey : std::runtime_error {
    explicit JsonDuplicateKey(const std::string& key);
};
std::optional<nlohmann::json> parse_json(std::string_view text, int max_depth);

}  // namespace tessera::api
