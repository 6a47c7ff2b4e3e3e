#pragma once
// The web page's files (web/ in the source tree), compiled into the binary.
#include <cstddef>

namespace tessera::server {

struct WebAsset {
    const char* name;  // the file's name in web/; null ends the table
    const unsigned char* data;
    size_t size;
};

// Every file, ended by an entry with a null name.
const WebAsset* web_assets();

}  // namespace tessera::server
