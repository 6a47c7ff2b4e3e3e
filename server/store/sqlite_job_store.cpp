#include "server/store/sqlite_job_store.h"

#include <sqlite3.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <unordered_map>
#include <utility>

namespace tessera::server {

namespace {

constexpr int kSchemaVersion = 2;  // 2: the states paused and waiting
constexpr size_t kMaxListLimit = 1000;

// The CHECK keeps a hand-edited or buggy row from reaching parse_job_state as garbage.
constexpr const char* kSchema = R"(
CREATE TABLE IF NOT EXISTS jobs (
    id          TEXT    PRIMARY KEY NOT NULL,
    state       TEXT    NOT NULL CHECK (state IN ('queued','waiting','running','paused','succeeded','failed','canceled')),
    spec_json   TEXT    NOT NULL DEFAULT '',
    priority    INTEGER NOT NULL DEFAULT 0,
    seq         INTEGER NOT NULL,
    created_at  REAL    NOT NULL DEFAULT 0,
    started_at  REAL    NOT NULL DEFAULT 0,
    finished_at REAL    NOT NULL DEFAULT 0,
    error       TEXT    NOT NULL DEFAULT '',
    report_json TEXT    NOT NULL DEFAULT '',
    attempts    INTEGER NOT NULL DEFAULT 0
);
CREATE INDEX IF NOT EXISTS jobs_queue_order ON jobs (state, priority DESC, seq ASC);
CREATE UNIQUE INDEX IF NOT EXISTS jobs_seq ON jobs (seq);
)";

// Version 1's table refuses the new states in its CHECK, which SQLite cannot alter: the rows
// move to a table of the new schema (inside the schema's transaction: all or nothing).
constexpr const char* kMigrateFrom1 = R"(
ALTER TABLE jobs RENAME TO jobs_v1;
DROP INDEX IF EXISTS jobs_queue_order;
DROP INDEX IF EXISTS jobs_seq;
)";
constexpr const char* kCopyFrom1 = R"(
INSERT INTO jobs (id, state, spec_json, priority, seq, created_at, started_at, finished_at, error, report_json, attempts)
    SELECT id, state, spec_json, priority, seq, created_at, started_at, finished_at, error, report_json, attempts FROM jobs_v1;
DROP TABLE jobs_v1;
)";

[[noreturn]] void fail(sqlite3* db, const std::string& op) {
    const bool full = db && (sqlite3_errcode(db) == SQLITE_FULL || sqlite3_extended_errcode(db) == SQLITE_IOERR_WRITE);
    throw StoreError("job store: " + op + ": " + (db ? sqlite3_errmsg(db) : "out of memory"), full);
}

void exec(sqlite3* db, const char* sql, const char* op) {
    if (sqlite3_exec(db, sql, nullptr, nullptr, nullptr) != SQLITE_OK) fail(db, op);
}

// A cached statement in use: binds by position, and on scope exit resets it so it neither holds
// a read snapshot (which would stall WAL checkpoints) nor keeps pointers to the caller's strings.
class Stmt {
public:
    Stmt(sqlite3* db, sqlite3_stmt* st, const char* op) : db_(db), st_(st), op_(op) {}
    ~Stmt() {
        sqlite3_reset(st_);
        sqlite3_clear_bindings(st_);
    }
    Stmt(const Stmt&) = delete;
    Stmt& operator=(const Stmt&) = delete;

    Stmt& bind(int i, const std::string& v) {
        return check(sqlite3_bind_text64(st_, i, v.data(), v.size(), SQLITE_TRANSIENT, SQLITE_UTF8));
    }
    Stmt& bind(int i, const char* v) { return check(sqlite3_bind_text(st_, i, v, -1, SQLITE_STATIC)); }
    Stmt& bind(int i, int64_t v) { return check(sqlite3_bind_int64(st_, i, v)); }
    Stmt& bind(int i, double v) { return check(sqlite3_bind_double(st_, i, v)); }
    // Binds ?1, ?2, ... in order.
    template <class... A>
    Stmt& bind_all(const A&... a) {
        [[maybe_unused]] int i = 0;
        (bind(++i, a), ...);
        return *this;
    }

    // True while a row is available.
    bool step() {
        const int rc = sqlite3_step(st_);
        if (rc != SQLITE_ROW && rc != SQLITE_DONE) fail(db_, op_);
        return rc == SQLITE_ROW;
    }
    // Runs a mutation to completion; returns the rows it changed.
    int run() {
        while (step()) {
        }
        return sqlite3_changes(db_);
    }
    sqlite3_stmt* get() const { return st_; }

private:
    Stmt& check(int rc) {
        if (rc != SQLITE_OK) fail(db_, op_);
        return *this;
    }
    sqlite3* db_;
    sqlite3_stmt* st_;
    const char* op_;
};

// BEGIN IMMEDIATE takes the write lock up front, so a read-then-write (insert's max(seq)) cannot
// be overtaken by another writer between the two statements.
class Transaction {
public:
    Transaction(sqlite3* db, const char* op) : db_(db), op_(op) { exec(db_, "BEGIN IMMEDIATE", op_); }
    ~Transaction() {
        // SQLite may already have rolled back on its own (e.g. SQLITE_FULL); only undo if still open.
        if (!done_ && !sqlite3_get_autocommit(db_)) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    }
    Transaction(const Transaction&) = delete;
    Transaction& operator=(const Transaction&) = delete;
    void commit() {
        exec(db_, "COMMIT", op_);
        done_ = true;
    }

private:
    sqlite3* db_;
    const char* op_;
    bool done_ = false;
};

std::string column_text(sqlite3_stmt* st, int i) {
    const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(st, i));
    return p ? std::string(p, static_cast<size_t>(sqlite3_column_bytes(st, i))) : std::string();
}

JobRecord read_row(sqlite3_stmt* st) {
    JobRecord r;
    r.id = column_text(st, 0);
    const std::string state = column_text(st, 1);
    if (!parse_job_state(state, r.state))
        throw StoreError("job store: job " + r.id + " has unknown state '" + state + "'", false);
    r.spec_json = column_text(st, 2);
    r.priority = sqlite3_column_int(st, 3);
    r.seq = sqlite3_column_int64(st, 4);
    r.created_at = sqlite3_column_double(st, 5);
    r.started_at = sqlite3_column_double(st, 6);
    r.finished_at = sqlite3_column_double(st, 7);
    r.error = column_text(st, 8);
    r.report_json = column_text(st, 9);
    r.attempts = sqlite3_column_int(st, 10);
    return r;
}

int64_t to_i64(size_t v) {
    return v > static_cast<size_t>(std::numeric_limits<int64_t>::max()) ? std::numeric_limits<int64_t>::max()
                                                                         : static_cast<int64_t>(v);
}

}  // namespace

struct SqliteJobStore::Impl {
    sqlite3* db = nullptr;
    std::string path;
    int64_t max_bytes = 0;
    dev_t dev = 0;
    ino_t ino = 0;
    std::mutex mu;
    // Keyed by the SQL text; every statement is a constant, so the cache stays small.
    std::unordered_map<std::string, sqlite3_stmt*> cache;

    Stmt prepare(const std::string& sql, const char* op) {
        auto it = cache.find(sql);
        if (it == cache.end()) {
            sqlite3_stmt* st = nullptr;
            if (sqlite3_prepare_v3(db, sql.c_str(), -1, SQLITE_PREPARE_PERSISTENT, &st, nullptr) != SQLITE_OK)
                fail(db, op);
            it = cache.emplace(sql, st).first;
        }
        return Stmt(db, it->second, op);
    }

    // One mutation statement (autocommit, so it is its own transaction); returns rows changed.
    template <class... A>
    int change(const char* op, const char* sql, const A&... a) {
        return prepare(sql, op).bind_all(a...).run();
    }

    // SELECT <every column, in read_row's order> FROM jobs <rest>.
    template <class... A>
    std::vector<JobRecord> rows(const char* op, const char* rest, const A&... a) {
        Stmt s = prepare(std::string("SELECT id, state, spec_json, priority, seq, created_at, started_at, finished_at, "
                                     "error, report_json, attempts FROM jobs ") + rest, op);
        s.bind_all(a...);
        std::vector<JobRecord> out;
        while (s.step()) out.push_back(read_row(s.get()));
        return out;
    }

    int user_version() {
        Stmt s = prepare("PRAGMA user_version", "read schema version");
        return s.step() ? sqlite3_column_int(s.get(), 0) : 0;
    }

    void refuse_newer(int version, const std::string& path) {
        if (version > kSchemaVersion)
            throw StoreError("job store: " + path + " has schema version " + std::to_string(version) +
                                     ", newer than this server supports (" + std::to_string(kSchemaVersion) +
                                     "); refusing to open it", false);
    }

    void open() {
        const int rc = sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
                                       nullptr);
        try {
            if (rc != SQLITE_OK) fail(db, "open " + path);
            exec(db, "PRAGMA busy_timeout=5000", "set busy_timeout");
            // Checked before switching to WAL so a newer server's file is left exactly as it was.
            refuse_newer(user_version(), path);
            {
                Stmt s = prepare("PRAGMA journal_mode=WAL", "set journal_mode");
                const std::string mode = s.step() ? column_text(s.get(), 0) : "";
                // In-memory databases cannot use WAL and report "memory"; they are not durable anyway.
                if (mode != "wal" && mode != "memory")
                    throw StoreError("job store: " + path + ": could not enable WAL (journal_mode=" + mode + ")", false);
            }
            // WAL + synchronous=NORMAL: a commit is in the WAL file (the OS page cache) before it
            // returns, so it survives the process dying at any point, kill -9 included. Only an OS
            // crash or power loss can drop the last few commits; that trade buys no fsync per commit.
            exec(db, "PRAGMA synchronous=NORMAL", "set synchronous");
            exec(db, "PRAGMA foreign_keys=ON", "set foreign_keys");

            Transaction tx(db, "create schema");
            const int version = user_version();  // again: another process may have upgraded meanwhile
            refuse_newer(version, path);
            if (version == 1) exec(db, kMigrateFrom1, "migrate schema 1");
            exec(db, kSchema, "create schema");
            if (version == 1) exec(db, kCopyFrom1, "migrate schema 1");
            if (version < kSchemaVersion)
                exec(db, ("PRAGMA user_version=" + std::to_string(kSchemaVersion)).c_str(), "set schema version");
            tx.commit();
            // After the schema: a version 1 file's migration copies its table once, which the
            // bound (set for the jobs, not for that copy) must not refuse.
            apply_max_bytes();
            remember_file();
        } catch (...) {
            close();
            throw;
        }
    }

    // The bound is kept where a job is accepted (insert, below); SQLite's own max_page_count
    // sits a margin above it, so that the jobs accepted under the bound can always be recorded
    // as they start and finish: a store that refused those would pin every worker. The margin
    // is per connection; with no bound, SQLite's own maximum (about 2^32 pages) applies.
    void apply_max_bytes() {
        int64_t pages = 4294967294;
        if (max_bytes > 0) {
            const int64_t margin = std::max<int64_t>(max_bytes / 8, int64_t{4} << 20);
            pages = std::max<int64_t>(1, (max_bytes + margin) / page_size());
        }
        exec(db, ("PRAGMA max_page_count=" + std::to_string(pages)).c_str(), "set max_page_count");
    }

    int64_t page_size() {
        Stmt s = prepare("PRAGMA page_size", "read page size");
        return s.step() ? std::max<int64_t>(1, sqlite3_column_int64(s.get(), 0)) : 4096;
    }

    // Refuses a new job once the file has reached the bound.
    void check_bound() {
        if (max_bytes <= 0) return;
        int64_t pages = 0;
        {
            Stmt s = prepare("PRAGMA page_count", "read page count");
            if (s.step()) pages = sqlite3_column_int64(s.get(), 0);
        }
        const int64_t bytes = pages * page_size();
        if (bytes >= max_bytes)
            throw StoreError("job store: " + std::to_string(bytes >> 10) + " KiB, at its bound of " +
                                 std::to_string(max_bytes >> 10) + " KiB (--max-store-mb)",
                             true);
    }

    void remember_file() {
        struct stat st{};
        if (::stat(path.c_str(), &st) == 0) {
            dev = st.st_dev;
            ino = st.st_ino;
        }
    }

    // A connection lost to a failed re-open (below) is opened again on the next call; the
    // records are safe in the file, only the store is unusable until it opens.
    void ensure_open() {
        if (!db) open();
    }

    // Before a change: if the file at `path` is no longer the one this connection writes (it
    // was deleted or replaced), every later commit would go to an unlinked file and vanish at
    // the next start. Copy the open database to `path` (SQLite's online backup) and continue
    // there; if that fails, refuse the change and keep the old connection.
    void ensure_file() {
        ensure_open();
        if (path.empty() || path == ":memory:") return;
        struct stat st{};
        if (::stat(path.c_str(), &st) == 0) {
            if (st.st_dev == dev && st.st_ino == ino) return;
        } else if (errno != ENOENT) {
            return;  // cannot tell (permissions, I/O): the change itself reports what fails
        }
        // The old file's -wal and -shm, if left behind, would be read as the new file's.
        for (const char* suffix : {"-wal", "-shm"}) ::unlink((path + suffix).c_str());
        sqlite3* fresh = nullptr;
        int rc = sqlite3_open_v2(path.c_str(), &fresh, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
                                 nullptr);
        if (rc == SQLITE_OK) {
            sqlite3_backup* b = sqlite3_backup_init(fresh, "main", db, "main");
            rc = b ? sqlite3_backup_step(b, -1) : sqlite3_errcode(fresh);
            if (b) sqlite3_backup_finish(b);
            rc = rc == SQLITE_DONE ? SQLITE_OK : rc;
        }
        if (rc != SQLITE_OK) {
            const std::string why = fresh ? sqlite3_errmsg(fresh) : "out of memory";
            const bool full = rc == SQLITE_FULL || (fresh && sqlite3_errcode(fresh) == SQLITE_FULL);
            sqlite3_close_v2(fresh);
            ::unlink(path.c_str());  // a partial copy must not pass for the store at the next start
            throw StoreError("job store: " + path + " was removed and could not be written anew: " + why, full);
        }
        // Closed in this order on purpose: closing the last connection to a WAL database
        // removes "<path>-wal" and "<path>-shm" by name, so both the copy's and the old
        // connection's must be closed before the new connection creates its own.
        sqlite3_close_v2(fresh);
        close();
        open();  // on failure db stays null and ensure_open() tries again on the next call
    }

    void close() {
        for (auto& [sql, st] : cache) sqlite3_finalize(st);
        cache.clear();
        sqlite3_close_v2(db);
        db = nullptr;
    }
};

SqliteJobStore::SqliteJobStore(const std::string& path, int64_t max_bytes) : impl_(std::make_unique<Impl>()) {
    impl_->path = path;
    impl_->max_bytes = max_bytes;
    impl_->open();
}

void SqliteJobStore::set_max_bytes(int64_t max_bytes) {
    std::lock_guard lock(impl_->mu);
    impl_->max_bytes = max_bytes;
    impl_->ensure_open();
    impl_->apply_max_bytes();
}

SqliteJobStore::~SqliteJobStore() { impl_->close(); }

void SqliteJobStore::insert(JobRecord& rec) {
    std::lock_guard lock(impl_->mu);
    impl_->ensure_file();
    impl_->check_bound();
    Impl& m = *impl_;
    Transaction tx(m.db, "insert");
    int64_t seq = 1;
    {
        Stmt s = m.prepare("SELECT COALESCE(MAX(seq), 0) + 1 FROM jobs", "insert");
        if (s.step()) seq = sqlite3_column_int64(s.get(), 0);
    }
    m.change("insert",
             "INSERT INTO jobs (id, state, spec_json, priority, seq, created_at, started_at, finished_at, error, "
             "report_json, attempts) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11)",
             rec.id, to_string(rec.state), rec.spec_json, int64_t{rec.priority}, seq, rec.created_at, rec.started_at,
             rec.finished_at, rec.error, rec.report_json, int64_t{rec.attempts});
    tx.commit();
    rec.seq = seq;  // only once committed, so a failed insert leaves the caller's record untouched
}

std::optional<JobRecord> SqliteJobStore::get(const std::string& id) const {
    std::lock_guard lock(impl_->mu);
    impl_->ensure_open();
    auto found = impl_->rows("get", "WHERE id = ?1", id);
    if (found.empty()) return std::nullopt;
    return std::move(found.front());
}

std::vector<JobRecord> SqliteJobStore::list(std::optional<JobState> state, size_t offset, size_t limit) const {
    std::lock_guard lock(impl_->mu);
    impl_->ensure_open();
    const int64_t lim = to_i64(std::min(limit, kMaxListLimit)), off = to_i64(offset);
    // Two fixed statements rather than "?1 IS NULL OR state = ?1", which would hide the indexes.
    if (state)
        return impl_->rows("list", "WHERE state = ?1 ORDER BY seq DESC LIMIT ?2 OFFSET ?3", to_string(*state), lim,
                           off);
    return impl_->rows("list", "ORDER BY seq DESC LIMIT ?1 OFFSET ?2", lim, off);
}

size_t SqliteJobStore::count(std::optional<JobState> state) const {
    std::lock_guard lock(impl_->mu);
    impl_->ensure_open();
    Stmt s = state ? impl_->prepare("SELECT COUNT(*) FROM jobs WHERE state = ?1", "count")
                   : impl_->prepare("SELECT COUNT(*) FROM jobs", "count");
    if (state) s.bind(1, to_string(*state));
    return s.step() ? static_cast<size_t>(sqlite3_column_int64(s.get(), 0)) : 0;
}

// The transitions are conditional UPDATEs: the WHERE clause is the state machine, and the row
// count says whether this call made the transition, with no read-then-write race.
bool SqliteJobStore::mark_running(const std::string& id, double started_at) {
    std::lock_guard lock(impl_->mu);
    impl_->ensure_file();
    return impl_->change("mark_running",
                         "UPDATE jobs SET state = 'running', started_at = ?2, attempts = attempts + 1 "
                         "WHERE id = ?1 AND state = 'queued'",
                         id, started_at) == 1;
}

bool SqliteJobStore::finish(const std::string& id, JobState state, double finished_at, const std::string& error,
                      const std::string& report_json) {
    if (!is_final(state))
        throw std::invalid_argument(std::string("job store: finish needs a final state, got ") + to_string(state));
    std::lock_guard lock(impl_->mu);
    impl_->ensure_file();
    return impl_->change("finish",
                         "UPDATE jobs SET state = ?2, finished_at = ?3, error = ?4, report_json = ?5 "
                         "WHERE id = ?1 AND state IN ('queued', 'waiting', 'running', 'paused')",
                         id, to_string(state), finished_at, error, report_json) == 1;
}

bool SqliteJobStore::pause(const std::string& id) {
    std::lock_guard lock(impl_->mu);
    impl_->ensure_file();
    return impl_->change("pause", "UPDATE jobs SET state = 'paused' WHERE id = ?1 AND state IN ('queued', 'running')", id) == 1;
}

bool SqliteJobStore::release(const std::string& id) {
    std::lock_guard lock(impl_->mu);
    impl_->ensure_file();
    return impl_->change("release", "UPDATE jobs SET state = 'queued' WHERE id = ?1 AND state = 'waiting'", id) == 1;
}

bool SqliteJobStore::resume(const std::string& id) {
    std::lock_guard lock(impl_->mu);
    impl_->ensure_file();
    return impl_->change("resume", "UPDATE jobs SET state = 'queued', started_at = 0 WHERE id = ?1 AND state = 'paused'", id) == 1;
}

// Both requeues keep attempts: it counts starts, and the interrupted run did start.
bool SqliteJobStore::requeue(const std::string& id) {
    std::lock_guard lock(impl_->mu);
    impl_->ensure_file();
    return impl_->change("requeue",
                         "UPDATE jobs SET state = 'queued', started_at = 0 WHERE id = ?1 AND state = 'running'", id) == 1;
}

int SqliteJobStore::requeue_all_running() {
    std::lock_guard lock(impl_->mu);
    impl_->ensure_file();
    return impl_->change("requeue_all_running",
                         "UPDATE jobs SET state = 'queued', started_at = 0 WHERE state = 'running'");
}

std::vector<JobRecord> SqliteJobStore::queued_in_order() const {
    std::lock_guard lock(impl_->mu);
    impl_->ensure_open();
    return impl_->rows("queued_in_order", "WHERE state = 'queued' ORDER BY priority DESC, seq ASC");
}

bool SqliteJobStore::remove_final(const std::string& id) {
    std::lock_guard lock(impl_->mu);
    impl_->ensure_file();
    return impl_->change("remove_final",
                         "DELETE FROM jobs WHERE id = ?1 AND state IN ('succeeded', 'failed', 'canceled')", id) == 1;
}

}  // namespace tessera::server
