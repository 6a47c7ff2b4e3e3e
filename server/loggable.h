#pragma once
// Text from outside (a request's path, a scene file's bytes quoted in an error) as it may go
// into a log line: printable ASCII, everything else escaped.
#include <cstddef>
#include <string>
#include <string_view>

namespace tessera::server {

// Control characters, bytes that are not printable ASCII and backslashes written as \xNN (so
// a path cannot forge a line, a NUL or a terminal escape, and the line stays valid UTF-8); cut
// after the first whole escape that reaches `max` characters (so at most max + 3), then "..." when
// anything was left out.
std::string loggable(std::string_view s, size_t max);

}  // namespace tessera::server
