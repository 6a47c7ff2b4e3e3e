#pragma once
// The job store of one process: SQLite in WAL mode at <data-dir>/tessera.db. Every state change
// is a committed transaction before it is acknowledged, so a restart (even after kill -9) finds
// every accepted job. One connection behind a mutex. A database file deleted under the running
// server is written anew from the open connection before the next change, so what was accepted
// stays on disk.
#include <memory>

#include "server/store/job_store.h"

namespace tessera::server {

class SqliteJobStore final : public JobStore {
public:
    // Opens or creates the database; throws StoreError with SQLite's message. `max_bytes`
    // (0: none) bounds the file's size: past it, insert() fails as full, while the jobs
    // already accepted can still be recorded as they start and finish.
    explicit SqliteJobStore(const std::string& path, int64_t max_bytes = 0);
    ~SqliteJobStore() override;
    SqliteJobStore(const SqliteJobStore&) = delete;
    SqliteJobStore& operator=(const SqliteJobStore&) = delete;

    void insert(JobRecord& rec) override;
    std::optional<JobRecord> get(const std::string& id) const override;
    std::vector<JobRecord> list(std::optional<JobState> state, size_t offset, size_t limit) const override;
    size_t count(std::optional<JobState> state) const override;
    bool mark_running(const std::string& id, double started_at) override;
    bool finish(const std::string& id, JobState state, double finished_at, const std::string& error,
                const std::string& report_json) override;
    bool pause(const std::string& id) override;
    bool resume(const std::string& id) override;
    bool release(const std::string& id) override;
    bool requeue(const std::string& id) override;
    int requeue_all_running() override;
    std::vector<JobRecord> queued_in_order() const override;
    bool remove_final(const std::string& id) override;
    void set_max_bytes(int64_t max_bytes) override;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace tessera::server
