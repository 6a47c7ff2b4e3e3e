#pragma once
// An error for the HTTP client, rendered as application/problem+json (RFC 9457). Thrown by
// the routes, caught once in http_api.cpp; the queue's typed refusals become problems here and
// nowhere else.
#include <optional>
#include <stdexcept>
#include <string>

#include "server/queue/queue_error.h"
#include "server/store/job_store.h"

namespace tessera::server {

struct Problem : std::runtime_error {
    int status;
    std::string slug;      // becomes the type URI /problems/<slug>
    std::string title;
    std::optional<std::string> field;  // JSON pointer of the offending field ("" for the whole body), if any
    std::string location;  // scene file position, if any
    int retry_after = 0;   // seconds, for 429 and 503
    std::string error_id;  // a 500's id, also in the server's log line

    Problem(int status_, std::string slug_, std::string title_, const std::string& detail)
        : std::runtime_error(detail), status(status_), slug(std::move(slug_)), title(std::move(title_)) {}
    Problem& with_field(std::string f) { field = std::move(f); return *this; }
    Problem& with_location(std::string l) { location = std::move(l); return *this; }
    Problem& with_retry_after(int s) { retry_after = s; return *this; }
    Problem& with_error_id(std::string id) { error_id = std::move(id); return *this; }
};

// The status each kind of refusal answers with.
int http_status(QueueErrorKind kind);

Problem problem(const QueueError& e);

// What a client sees when the store refuses: 507 while it is full (a disk, or the size bound),
// 503 while it is unusable; both say when to retry.
inline Problem store_problem(const StoreError& e) { return problem(store_refusal(e)); }

}  // namespace tessera::server
