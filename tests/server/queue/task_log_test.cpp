// A job log's pages read from its file: at most `limit` lines and about `bytes`, a line larger
// than that alone, and a last line still being appended (no newline yet) left for the next page.
#include "server/queue/task_log.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

namespace tessera::server {
namespace {

namespace fs = std::filesystem;

class TaskLogFile : public ::testing::Test {
protected:
    void SetUp() override {
        path_ = (fs::temp_directory_path() / ("tessera_task_log_" + std::to_string(::getpid()) + ".jsonl")).string();
    }
    void TearDown() override { fs::remove(path_); }
    void write(const std::string& text) { std::ofstream(path_, std::ios::binary | std::ios::trunc) << text; }
    std::string path_;
};

TEST_F(TaskLogFile, PagesByLinesAndBytes) {
    write("{\"a\":1}\n{\"a\":2}\n{\"a\":3}\n{\"a\":4}\n");
    LogPage p = read_task_log(path_, 0, 2);
    EXPECT_EQ(p.ndjson, "{\"a\":1}\n{\"a\":2}\n");
    EXPECT_EQ(p.next, 2u);
    p = read_task_log(path_, 2, 100);
    EXPECT_EQ(p.ndjson, "{\"a\":3}\n{\"a\":4}\n");
    EXPECT_EQ(p.next, 4u);
    p = read_task_log(path_, 9, 100);
    EXPECT_EQ(p.ndjson, "");
    EXPECT_EQ(p.next, 4u) << "a reader ahead of the log is told where it ends";
    p = read_task_log(path_, 1, 100, 17);  // two lines are 16 bytes, three 24
    EXPECT_EQ(p.ndjson, "{\"a\":2}\n{\"a\":3}\n");
    EXPECT_EQ(p.next, 3u);
    p = read_task_log(path_, 1, 100, 3);
    EXPECT_EQ(p.ndjson, "{\"a\":2}\n") << "a line larger than the budget comes alone";
    EXPECT_EQ(p.next, 2u);
    EXPECT_EQ(read_task_log(path_ + ".none", 0, 100).ndjson, "");
}

TEST_F(TaskLogFile, ALineBeingAppendedIsLeftForTheNextPage) {
    write("{\"a\":1}\n{\"a\":2}\n{\"a\":3, \"li");
    LogPage p = read_task_log(path_, 0, 100);
    EXPECT_EQ(p.ndjson, "{\"a\":1}\n{\"a\":2}\n");
    EXPECT_EQ(p.next, 2u);
    write("{\"a\":1}\n{\"a\":2}\n{\"a\":3, \"lines\":[]}\n");
    p = read_task_log(path_, p.next, 100);
    EXPECT_EQ(p.ndjson, "{\"a\":3, \"lines\":[]}\n") << "read whole once its newline is there";
    EXPECT_EQ(p.next, 3u);
}

}  // namespace
}  // namespace tessera::server
