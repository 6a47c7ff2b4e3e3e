#include "server/store/sqlite_job_store.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "tests/server/job_records.h"

namespace tessera::server {
namespace {

namespace fs = std::filesystem;

using test::hex_id;
using test::make_job;

class JobStoreTest : public ::testing::Test {
protected:
    void SetUp() override {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = fs::temp_directory_path() /
               ("tessera_job_store_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    std::string db_path() const { return (dir_ / "tessera.db").string(); }

    fs::path dir_;
};

TEST_F(JobStoreTest, SurvivesKill9) {
    const std::string path = db_path();
    const pid_t pid = ::fork();
    ASSERT_NE(pid, -1);
    if (pid == 0) {
        // The child must never return into gtest; any failure is reported through the exit code.
        try {
            SqliteJobStore store(path);
            for (uint64_t i = 1; i <= 100; ++i) {
                JobRecord r = make_job(i);
                store.insert(r);
                if (i % 10 == 0 && !store.mark_running(r.id, 1.0)) ::_exit(3);
            }
            ::raise(SIGKILL);  // no destructor, no close, no checkpoint
        } catch (...) {
            ::_exit(2);
        }
        ::_exit(4);
    }
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFSIGNALED(status)) << "child exited with " << (WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    ASSERT_EQ(WTERMSIG(status), SIGKILL);

    SqliteJobStore store(path);
    EXPECT_EQ(store.count(std::nullopt), 100u);
    EXPECT_EQ(store.requeue_all_running(), 10);
    EXPECT_EQ(store.count(JobState::queued), 100u);
    for (uint64_t i = 1; i <= 100; ++i) ASSERT_TRUE(store.get(hex_id(i)).has_value()) << i;
    JobRecord next = make_job(101);
    store.insert(next);
    EXPECT_EQ(next.seq, 101);
}

TEST_F(JobStoreTest, RefusesNewerSchemaVersion) {
    const std::string path = db_path();
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, "CREATE TABLE future(x); PRAGMA user_version=3;", nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
    try {
        SqliteJobStore store(path);
        FAIL() << "a newer schema was opened";
    } catch (const std::runtime_error& e) {
        const std::string msg = e.what();
        EXPECT_NE(msg.find("schema version 3"), std::string::npos) << msg;
        EXPECT_NE(msg.find("newer"), std::string::npos) << msg;
    }
    // Left as found: still version 3 and not switched to WAL by the refused open.
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    sqlite3_stmt* st = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db, "PRAGMA journal_mode", -1, &st, nullptr), SQLITE_OK);
    ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
    EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(st, 0)), "delete");
    sqlite3_finalize(st);
    sqlite3_close(db);
}

TEST_F(JobStoreTest, SetsSchemaVersionAndWal) {
    { SqliteJobStore store(db_path()); }
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(db_path().c_str(), &db), SQLITE_OK);
    for (const auto& [sql, want] : {std::pair<const char*, const char*>{"PRAGMA user_version", "2"},
                                    {"PRAGMA journal_mode", "wal"}}) {
        sqlite3_stmt* st = nullptr;
        ASSERT_EQ(sqlite3_prepare_v2(db, sql, -1, &st, nullptr), SQLITE_OK);
        ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
        EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(st, 0)), want) << sql;
        sqlite3_finalize(st);
    }
    sqlite3_close(db);
}

// A version 1 file (whose CHECK knows five states) is moved to the new table on open: its jobs
// keep every column and their order, and take the new states.
TEST_F(JobStoreTest, AVersion1StoreIsMigratedWithEveryJob) {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(db_path().c_str(), &db), SQLITE_OK);
    const char* v1 = R"(
CREATE TABLE jobs (
    id          TEXT    PRIMARY KEY NOT NULL,
    state       TEXT    NOT NULL CHECK (state IN ('queued','running','succeeded','failed','canceled')),
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
CREATE INDEX jobs_queue_order ON jobs (state, priority DESC, seq ASC);
CREATE UNIQUE INDEX jobs_seq ON jobs (seq);
INSERT INTO jobs VALUES ('00000000000000a1', 'succeeded', '{"scene":"a"}', 3, 1, 10.5, 11.0, 12.0, '', '{"r":1}', 1);
INSERT INTO jobs VALUES ('00000000000000a2', 'queued', '{"scene":"b"}', -2, 2, 20.0, 0, 0, '', '', 0);
PRAGMA user_version=1;)";
    ASSERT_EQ(sqlite3_exec(db, v1, nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
    SqliteJobStore store(db_path());
    const auto a = store.get("00000000000000a1");
    ASSERT_TRUE(a);
    EXPECT_EQ(a->state, JobState::succeeded);
    EXPECT_EQ(a->spec_json, R"({"scene":"a"})");
    EXPECT_EQ(a->priority, 3);
    EXPECT_EQ(a->seq, 1);
    EXPECT_DOUBLE_EQ(a->finished_at, 12.0);
    EXPECT_EQ(a->report_json, R"({"r":1})");
    EXPECT_EQ(a->attempts, 1);
    EXPECT_EQ(store.queued_in_order().size(), 1u);
    EXPECT_TRUE(store.pause("00000000000000a2"));
    EXPECT_EQ(store.get("00000000000000a2")->state, JobState::paused);
    JobRecord next = make_job(3);
    store.insert(next);
    EXPECT_EQ(next.seq, 3);
}

TEST_F(JobStoreTest, OpenErrorsThrowWithSqliteMessage) {
    EXPECT_THROW(SqliteJobStore((dir_ / "no_such_dir" / "tessera.db").string()), std::runtime_error);
    {
        std::ofstream(dir_ / "garbage.db") << std::string(4096, 'x');
    }
    try {
        SqliteJobStore store((dir_ / "garbage.db").string());
        FAIL() << "garbage opened";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("not a database"), std::string::npos) << e.what();
    }
}

// The size bound: a new job is refused as "full", nothing accepted before is lost, the jobs
// already accepted can still be recorded as they finish (or a store at its bound would pin
// every worker), and a larger bound lets new jobs in again. (A real full disk, where SQLite
// itself answers SQLITE_FULL: tests/server/store_faults.sh.)
TEST_F(JobStoreTest, FullStoreRefusesAsFullAndRecovers) {
    SqliteJobStore store(db_path(), 96 * 1024);
    const std::string big(2000, 'x');
    int stored = 0;
    for (uint64_t n = 1; n < 1000; ++n) {
        JobRecord r = make_job(n);
        r.spec_json = big;
        try {
            store.insert(r);
            ++stored;
        } catch (const StoreError& e) {
            EXPECT_TRUE(e.full) << e.what();
            break;
        }
    }
    ASSERT_GT(stored, 5);
    ASSERT_LT(stored, 999) << "the bound never bit";
    EXPECT_EQ(store.count(std::nullopt), size_t(stored));
    JobRecord next = make_job(5000);
    next.spec_json = big + big;
    EXPECT_THROW(store.insert(next), StoreError);
    for (int n = 1; n <= stored; ++n) {
        ASSERT_TRUE(store.mark_running(hex_id(uint64_t(n)), 2.0));
        ASSERT_TRUE(store.finish(hex_id(uint64_t(n)), JobState::succeeded, 3.0, "", std::string(1500, 'r')));
    }
    store.set_max_bytes(0);
    store.insert(next);
    EXPECT_EQ(store.count(std::nullopt), size_t(stored) + 1);
    EXPECT_EQ(store.count(JobState::succeeded), size_t(stored));
}

// The database file deleted under a running server (a clean-up script, an operator): the
// next change writes the open database to the path again, so the jobs accepted before and
// after are both there at the next start.
TEST_F(JobStoreTest, DeletedFileIsWrittenAnew) {
    {
        SqliteJobStore store(db_path());
        JobRecord a = make_job(1);
        store.insert(a);
        for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(db_path() + suffix);
        ASSERT_FALSE(fs::exists(db_path()));
        JobRecord b = make_job(2);
        store.insert(b);
        EXPECT_TRUE(fs::exists(db_path()));
        EXPECT_TRUE(store.mark_running(hex_id(1), 2.0));
    }
    SqliteJobStore reopened(db_path());
    ASSERT_TRUE(reopened.get(hex_id(1)));
    EXPECT_EQ(reopened.get(hex_id(1))->state, JobState::running);
    ASSERT_TRUE(reopened.get(hex_id(2)));
    EXPECT_EQ(reopened.count(std::nullopt), 2u);
}

// A file that is not this store's database any more (replaced by another) counts as removed:
// the store keeps its own records rather than write into someone else's file.
TEST_F(JobStoreTest, ReplacedFileIsWrittenAnew) {
    SqliteJobStore store(db_path());
    JobRecord a = make_job(1);
    store.insert(a);
    for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(db_path() + suffix);
    { std::ofstream(db_path()) << ""; }  // an empty file in its place
    JobRecord b = make_job(2);
    store.insert(b);
    EXPECT_EQ(store.count(std::nullopt), 2u);
}

}  // namespace
}  // namespace tessera::server
