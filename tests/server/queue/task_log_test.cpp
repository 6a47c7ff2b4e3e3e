// A job log's pages read from its file: at most `limit` lines and about `bytes`, a line larger
// than that alone, and a last line still being appended (no newline yet) left for the next page.
#include "server/queue/task_log.h"

#include <gtest/gtest.h>

#include <algorithm>
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

// Paging through a long log with an index reads what paging without one reads, and starts each
// page at a mark near it, not at the file's start; a file made anew is not read by old marks.
TEST_F(TaskLogFile, AnIndexedReaderReadsWhatAPlainOneReadsFromNearItsPage) {
    std::string text;
    for (int i = 0; i < 2000; ++i) {
        text += "{\"i\":" + std::to_string(i) + ",\"pad\":\"" + std::string(size_t(i % 37), 'x') + "\"}\n";
        if (i % 301 == 0) text += "\n";  // empty lines are not counted, by either
    }
    write(text);
    TaskLogIndex index;
    std::string whole;
    size_t from = 0;
    for (int pages = 0; pages < 100; ++pages) {
        const LogPage plain = read_task_log(path_, from, 97);
        const LogPage fast = read_task_log(path_, from, 97, kMaxLogPageBytes, &index);
        ASSERT_EQ(fast.ndjson, plain.ndjson) << "from " << from;
        ASSERT_EQ(fast.next, plain.next);
        if (fast.ndjson.empty()) break;
        whole += fast.ndjson;
        from = fast.next;
    }
    EXPECT_EQ(from, 2000u);
    std::string expected = text;
    for (size_t at; (at = expected.find("\n\n")) != std::string::npos;) expected.erase(at, 1);
    EXPECT_EQ(whole, expected);
    const TaskLogIndex::Mark mark = index.before(path_, log_file_id(path_), 1900);
    EXPECT_NE(mark.hash, 0u);
    EXPECT_EQ(mark.line, 1792u) << "the reader learnt every mark it passed";
    EXPECT_EQ(text.compare(mark.offset, 9, "{\"i\":1792"), 0);
    // Random reads after the index is full agree with plain ones.
    for (size_t f : {0u, 1u, 255u, 256u, 257u, 1023u, 1999u, 2000u, 5000u}) {
        EXPECT_EQ(read_task_log(path_, f, 3, kMaxLogPageBytes, &index).ndjson, read_task_log(path_, f, 3).ndjson) << f;
        EXPECT_EQ(read_task_log(path_, f, 3, kMaxLogPageBytes, &index).next, read_task_log(path_, f, 3).next) << f;
    }
    // Rewritten in place (the same inode) with lines of the same lengths: every mark still falls
    // after a newline, but its line is not the one learnt, so the marks are learnt anew.
    std::string same_shape = text;
    std::replace(same_shape.begin(), same_shape.end(), 'x', 'y');
    write(same_shape);
    EXPECT_EQ(read_task_log(path_, 1900, 2, kMaxLogPageBytes, &index).ndjson, read_task_log(path_, 1900, 2).ndjson);
    EXPECT_NE(index.before(path_, log_file_id(path_), 1900).hash, mark.hash) << "learnt anew";
    // ... and with other lines altogether: the marks fall inside lines.
    std::string other;
    for (int i = 0; i < 2000; ++i) other += "{\"j\":" + std::to_string(i) + ",\"pad\":\"" + std::string(980, 'y') + "\"}\n";
    ASSERT_NE(other[mark.offset - 1], '\n');
    write(other);
    const LogPage p = read_task_log(path_, 1900, 1, kMaxLogPageBytes, &index);
    EXPECT_EQ(p.ndjson.substr(0, 12), "{\"j\":1900,\"p");
    EXPECT_EQ(p.next, 1901u);
}

}  // namespace
}  // namespace tessera::server
