#pragma once
// How deeply a JSON text nests its arrays and objects, read from the bytes before any parser
// builds a tree: a document nested 100,000 deep is refused for what it is, instead of
// exhausting the stack of whatever walks it recursively afterwards (a copy, a dump, tinygltf's
// extras).
#include <string_view>

namespace tessera {

// The greatest nesting of `text` (0 for a scalar), counted outside strings. Stops counting once
// it passes `stop_above` and returns that count: a caller only asks "more than N?". Malformed
// text is not judged here; the parser that follows does that.
int json_nesting_depth(std::string_view text, int stop_above);

}  // namespace tessera
