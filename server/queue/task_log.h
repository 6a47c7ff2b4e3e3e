#pragma once
// A job's log, task by task: what each task was (one process's run of the job or a frame of its
// shot; a farm node's start, tile, assembly or chunk of frames), which node ran it, when, at
// which attempt, how it ended, and the lines the server logged while it ran it.
// GET /v1/jobs/{id}/log serves it as JSON lines, one task a line, oldest first.
#include <cstddef>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace tessera::server {

struct TaskRecord {
    std::string task;                     // render, shot, comparison, frame; start, tile, assemble, frames
    std::optional<int> pass, tile, frame;  // where the task has them
    std::string node;                     // the render node's name; "local" for one process
    double start = 0, end = 0;            // unix seconds
    int attempt = 1;                      // the job's start (one process) or the task's delivery (farm)
    std::string outcome;                  // done, failed, canceled, paused, interrupted, dropped
    std::vector<std::string> warnings, errors, lines;
};

nlohmann::json to_json(const TaskRecord& r);

// What a task keeps: lines beyond these are counted in one last line, and a line is cut at 2 KiB.
inline constexpr size_t kMaxTaskLines = 200;

// Collects what this thread logs (through spdlog, at the logger's level) into `into` while it
// lives: every line in `lines`, warnings and errors also apart. Nested, the innermost collects.
class TaskLogCapture {
public:
    explicit TaskLogCapture(TaskRecord& into);
    ~TaskLogCapture();
    TaskLogCapture(const TaskLogCapture&) = delete;
    TaskLogCapture& operator=(const TaskLogCapture&) = delete;

private:
    TaskRecord* outer_;
};

// Appends one record to a one-process job's log file (a line, written whole with O_APPEND).
// Logged, not thrown, when the disk refuses: a log must not fail its job.
void append_task_record(const std::string& path, const TaskRecord& r);

// A page of a job's log: at most `limit` lines and about kMaxLogPageBytes (a longer line comes
// alone), so that neither a reader nor the server holds a whole log of a long shot or farm job.
inline constexpr size_t kMaxLogPageBytes = size_t(4) << 20;
struct LogPage {
    std::string ndjson;  // the lines, each ending in "\n"
    size_t next = 0;     // the `from` that reads on after them (where the next line will be)
};

// Where every kLogMarkStride-th line of a log file starts, learnt as its pages are read: a reader
// paging through a long log starts near its page instead of reading every line before it, so
// reading a log to its end is linear in its length, not quadratic. A log only grows, so what is
// learnt stays true while the file is the same one: its device and inode, and the line found at
// a mark the one learnt there (its hash); anything else drops the file's marks. At most
// kLogIndexFiles files are remembered, the oldest dropped.
inline constexpr size_t kLogMarkStride = 256;
inline constexpr size_t kLogIndexFiles = 512;
class TaskLogIndex {
public:
    struct Mark {
        size_t line = 0;      // counted as read_task_log counts (empty lines are not)
        uint64_t offset = 0;  // where that line starts
        uint64_t hash = 0;    // of that line, without its newline
    };
    // The last mark at or before `line` in the file `file` (its device and inode; the file's
    // start when none is known).
    Mark before(const std::string& path, uint64_t file, size_t line) const;
    // Line `line`, whose hash is `hash`, starts at `offset`; kept where `line` is a multiple of
    // the stride.
    void learn(const std::string& path, uint64_t file, size_t line, uint64_t offset, uint64_t hash);
    void forget(const std::string& path);

private:
    struct Marks {
        uint64_t file = 0;
        std::vector<std::pair<uint64_t, uint64_t>> at;  // [k]: where line k·stride starts, its hash
    };
    mutable std::mutex mutex_;
    std::unordered_map<std::string, Marks> marks_;
    std::deque<std::string> order_;  // first learnt first
};

// Which file a path names now (its device and inode; 0 for none): what an index's marks belong to.
uint64_t log_file_id(const std::string& path);

// Lines `from` onwards of a log file (none when there is no file), at most `limit` of them and
// about `bytes`. A last line without its newline is being appended: it is left for later. With
// an index, the read starts at its mark before `from` and teaches it the marks it passes.
LogPage read_task_log(const std::string& path, size_t from, size_t limit, size_t bytes = kMaxLogPageBytes,
                      TaskLogIndex* index = nullptr);

}  // namespace tessera::server
