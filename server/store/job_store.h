#pragma once
// The job store's contract: the record of a job and the interface both stores implement.
#include <cstdint>
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

// The store refused: `full` when the disk, the database's size limit or Redis's memory is full
// (space may come back), otherwise it is unusable for now (read-only file, Redis unreachable). Callers answer 507 or
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

// Every accepted job, durable before it is acknowledged, with its state, queue order and
// outcome. Two implementations pass one contract suite (tests/server/store/job_store_contract_test.cpp):
// SQLite for one process (sqlite_job_store.h) and Redis for many nodes (redis_job_store.h).
// Every failure is a StoreError. Thread-safe.
class JobStore {
public:
    virtual ~JobStore() = default;

    // Assigns rec.seq (monotonic across restarts) and stores the record as given (a queued one
    // joins the queue).
    virtual void insert(JobRecord& rec) = 0;
    virtual std::optional<JobRecord> get(const std::string& id) const = 0;
    // Newest first (seq descending); optional state filter; at most 1000.
    virtual std::vector<JobRecord> list(std::optional<JobState> state, size_t offset, size_t limit) const = 0;
    virtual size_t count(std::optional<JobState> state) const = 0;
    // queued → running (sets started_at, attempts += 1); false if the job was not queued.
    virtual bool mark_running(const std::string& id, double started_at) = 0;
    // queued or running → paused (its film is kept); false if it was neither.
    virtual bool pause(const std::string& id) = 0;
    // paused → queued, in its place (priority, then submission order); false if it was not paused.
    virtual bool resume(const std::string& id) = 0;
    // waiting → queued (every job it runs after has succeeded); false if it was not waiting.
    virtual bool release(const std::string& id) = 0;
    // Any non-final state → final state with finished_at, error and report; false if already final.
    virtual bool finish(const std::string& id, JobState state, double finished_at, const std::string& error,
                        const std::string& report_json) = 0;
    // running → queued (a job interrupted by shutdown); false if it was not running.
    virtual bool requeue(const std::string& id) = 0;
    // Every running job goes back to queued (a single process died mid-render); returns how many.
    virtual int requeue_all_running() = 0;
    // Queued jobs in run order: priority descending, then seq ascending.
    virtual std::vector<JobRecord> queued_in_order() const = 0;
    // Deletes a record (only final ones); false if missing or not final.
    virtual bool remove_final(const std::string& id) = 0;
    // Changes the size bound (0: none): past it, insert() fails as full.
    virtual void set_max_bytes(int64_t max_bytes) = 0;
};

}  // namespace tessera::server
