#pragma once
// Why the queue refused a request, as a typed value: what went wrong (the kind), a stable code
// and a sentence for people. The HTTP layer alone turns it into a status and a problem+json body
// (server/http/problem.h); the queue knows no status codes.
#include <optional>
#include <stdexcept>
#include <string>

#include "server/store/job_store.h"

namespace tessera::server {

enum class QueueErrorKind {
    invalid,      // the request itself is wrong (a field, a parameter, an upload's name)
    not_found,    // no such job, scene or environment map
    conflict,     // the job is not in a state that allows it (not finished yet)
    gone,         // its results were there and are not any more
    broken_file,  // an uploaded scene file that does not load
    queue_full,   // too many queued jobs: retry later
    store_full,   // the store or the disk is full: retry when space is freed
    unavailable,  // shutting down, or a store or file that cannot be read now: retry later
};

struct QueueError : std::runtime_error {
    QueueErrorKind kind;
    std::string code;   // stable, for programs: "unknown-scene", "queue-full", ...
    std::string title;  // the kind of problem in a few words, for people
    std::optional<std::string> field;  // JSON pointer (or query parameter) at fault, if any
    std::string location;              // a scene file's position, if any
    int retry_after_s = 0;             // when a retry may succeed (queue_full, store_full, unavailable)
    // The server's own account of it, for its log, never sent: a store's error names its file,
    // its Redis or its bound.
    std::string cause;

    QueueError(QueueErrorKind kind_, std::string code_, std::string title_, const std::string& detail)
        : std::runtime_error(detail), kind(kind_), code(std::move(code_)), title(std::move(title_)) {}
    QueueError& with_field(std::string f) { field = std::move(f); return *this; }
    QueueError& with_location(std::string l) { location = std::move(l); return *this; }
    QueueError& with_retry_after(int s) { retry_after_s = s; return *this; }
    QueueError& with_cause(std::string c) { cause = std::move(c); return *this; }
};

// The store's refusal as the queue reports it: full (a disk, or the size bound) or unavailable.
inline QueueError store_refusal(const StoreError& e) {
    if (e.full)
        return QueueError(QueueErrorKind::store_full, "insufficient-storage", "The job store is full",
                          "the job store has no room for more; retry when space is freed")
            .with_retry_after(30)
            .with_cause(e.what());
    return QueueError(QueueErrorKind::unavailable, "store-unavailable", "The job store is unavailable",
                      "the job store cannot be read or written now; retry shortly")
        .with_retry_after(10)
        .with_cause(e.what());
}

// A pause asked of a job that waits for others (`after`): it has nothing to pause yet.
inline QueueError waiting_job(const std::string& id) {
    return QueueError(QueueErrorKind::conflict, "job-waiting", "Job waiting",
                      "job " + id + " waits for the jobs it runs after; cancel it, or pause it once it is queued");
}

// A pause, resume or other change asked of a job that has finished.
inline QueueError job_finished(const std::string& id, const std::string& state, const char* what) {
    return QueueError(QueueErrorKind::conflict, "job-finished", "Job finished",
                      "job " + id + " has " + state + "; only a queued, running or paused job can be " + what);
}

}  // namespace tessera::server
