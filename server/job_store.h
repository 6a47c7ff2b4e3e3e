#pragma once
// Durable job records: SQLite in WAL mode at <data-dir>/tessera.db. Every state change is a
// committed transaction before it is acknowledged, so a restart (even after kill -9) finds
// every accepted job. Thread-safe: one connection behind a mutex. Every failure is a
// StoreError; a database file deleted under the running server is written anew from the open
// connection before the next change, so what was accepted stays on disk.
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "api/job_status.h"

namespace tessera::server {

using api::JobState;
using api::is_final;
using api::parse_job_state;
using api::to_string;

// SQLite refused: `full` when the disk or the database's size limit is full (space may come
// back), otherwise the file is unusable for now (read-only, I/O error). Callers answer 507 or
// 503 and keep serving; nothing here is fatal to the process.
struct StoreError : std::runtime_error {
    bool full;
    StoreError(const std::string& what, bool full_) : std::runtime_error(what), full(full_) {}
};

struct JobRecord {
    std::string id;           // 16 lowercase hex characters
    JobState state = JobState::queued;
    std::string spec_json;    // the effective job settings (api::to_json)
    int priority = 0;         // higher runs first
    int64_t seq = 0;          // submission order, assigned by insert()
    double created_at = 0;    // unix seconds; 0 = not yet
    double started_at = 0;
    double finished_at = 0;
    std::string error;        // set when failed
    std::string report_json;  // set when finished: the status summary (api::status_summary), "" otherwise
    int attempts = 0;         // times the job was started (a restart re-queues running jobs)
};

class JobStore {
public:
    // Opens or creates the database; throws StoreError with SQLite's message. `max_bytes`
    // (0: none) bounds the file's size: past it, insert() fails as full, while the jobs
    // already accepted can still be recorded as they start and finish.
    explicit JobStore(const std::string& path, int64_t max_bytes = 0);
    ~JobStore();
    JobStore(const JobStore&) = delete;
    JobStore& operator=(const JobStore&) = delete;

    // Assigns rec.seq (monotonic across restarts) and stores the record.
    void insert(JobRecord& rec);
    std::optional<JobRecord> get(const std::string& id) const;
    // Newest first (seq descending); optional state filter.
    std::vector<JobRecord> list(std::optional<JobState> state, size_t offset, size_t limit) const;
    size_t count(std::optional<JobState> state) const;
    // queued → running (sets started_at, attempts += 1); false if the job was not queued.
    bool mark_running(const std::string& id, double started_at);
    // Any non-final state → final state with finished_at, error and report; false if already final.
    bool finish(const std::string& id, JobState state, double finished_at, const std::string& error,
                const std::string& report_json);
    // running → queued (a job interrupted by shutdown); false if it was not running.
    bool requeue(const std::string& id);
    // At start-up: every running job goes back to queued (the process died mid-render);
    // returns how many.
    int requeue_all_running();
    // Queued jobs in run order: priority descending, then seq ascending.
    std::vector<JobRecord> queued_in_order() const;
    // Deletes a record (only final ones); false if missing or not final.
    bool remove_final(const std::string& id);

    // Changes the size bound (0: none) of an open store.
    void set_max_bytes(int64_t max_bytes);

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace tessera::server
