#include "server/loggable.h"

#include <cstdio>

namespace tessera::server {

std::string loggable(std::string_view s, size_t max) {
    std::string out;
    size_t i = 0;
    for (; i < s.size() && out.size() < max; ++i) {
        const unsigned char c = static_cast<unsigned char>(s[i]);
        if (c >= 0x20 && c < 0x7f && c != '\\') {
            out += char(c);
        } else {
            char buf[5];
            std::snprintf(buf, sizeof buf, "\\x%02x", c);
            out += buf;
        }
    }
    if (i < s.size()) out += "...";  // only when something was left out
    return out;
}

}  // namespace tessera::server
