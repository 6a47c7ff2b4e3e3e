#pragma once
// An error for the HTTP client, rendered as application/problem+json (RFC 9457). Thrown by
// the service and the routes, caught once in http_api.cpp.
#include <stdexcept>
#include <string>

namespace tessera::server {

struct Problem : std::runtime_error {
    int status;
    std::string slug;      // becomes the type URI /problems/<slug>
    std::string title;
    std::string field;     // JSON pointer of the offending field, if any
    std::string location;  // scene file position, if any
    int retry_after = 0;   // seconds, for 429 and 503

    Problem(int status_, std::string slug_, std::string title_, const std::string& detail)
        : std::runtime_error(detail), status(status_), slug(std::move(slug_)), title(std::move(title_)) {}
    Problem& with_field(std::string f) { field = std::move(f); return *this; }
    Problem& with_location(std::string l) { location = std::move(l); return *this; }
    Problem& with_retry_after(int s) { retry_after = s; return *this; }
};

}  // namespace tessera::server
