#include "server/queue/task_log.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string_view>
#include <memory>
#include <mutex>

#include <spdlog/sinks/sink.h>
#include <spdlog/spdlog.h>

#include "api/json_text.h"

namespace tessera::server {

namespace {

thread_local TaskRecord* t_record = nullptr;  // the innermost capture's

void keep(std::vector<std::string>& v, const std::string& line) {
    if (v.size() < kMaxTaskLines) v.push_back(line);
    else if (v.size() == kMaxTaskLines) v.push_back("… further lines not kept");
}

// A sink beside the console's: it hands each line to the capture of the thread that logs it.
class CaptureSink final : public spdlog::sinks::sink {
public:
    void log(const spdlog::details::log_msg& msg) override {
        TaskRecord* r = t_record;
        if (!r) return;
        const std::string_view payload(msg.payload.data(), std::min<size_t>(msg.payload.size(), 2048));
        const auto level = spdlog::level::to_string_view(msg.level);
        std::string line(level.data(), level.size());
        line += ": ";
        line += payload;
        keep(r->lines, line);
        if (msg.level == spdlog::level::warn) keep(r->warnings, std::string(payload));
        if (msg.level >= spdlog::level::err) keep(r->errors, std::string(payload));
    }
    void flush() override {}
    void set_pattern(const std::string&) override {}
    void set_formatter(std::unique_ptr<spdlog::formatter>) override {}
};

// Installed before main, while one thread runs: the default logger's sinks are not to be
// changed once threads log.
const bool kInstalled = [] {
    spdlog::default_logger()->sinks().push_back(std::make_shared<CaptureSink>());
    return true;
}();

}  // namespace

nlohmann::json to_json(const TaskRecord& r) {
    auto opt = [](const std::optional<int>& v) { return v ? nlohmann::json(*v) : nlohmann::json(nullptr); };
    return {{"task", r.task}, {"pass", opt(r.pass)}, {"tile", opt(r.tile)}, {"frame", opt(r.frame)}, {"node", r.node},
            {"start", r.start}, {"end", r.end}, {"attempt", r.attempt}, {"outcome", r.outcome},
            {"warnings", r.warnings}, {"errors", r.errors}, {"lines", r.lines}};
}

TaskLogCapture::TaskLogCapture(TaskRecord& into) : outer_(t_record) {
    (void)kInstalled;
    t_record = &into;
}

TaskLogCapture::~TaskLogCapture() { t_record = outer_; }

void append_task_record(const std::string& path, const TaskRecord& r) {
    const std::string line = api::json_text(to_json(r)) + "\n";
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    bool ok = fd >= 0 && ::write(fd, line.data(), line.size()) == ssize_t(line.size());
    if (fd >= 0) ok = ::close(fd) == 0 && ok;
    if (!ok) spdlog::warn("cannot append to the job log {}", path);
}

TaskLogIndex::Mark TaskLogIndex::before(const std::string& path, uint64_t file, size_t line) const {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = marks_.find(path);
    if (it == marks_.end() || it->second.file != file || it->second.at.empty()) return {};
    const size_t k = std::min(line / kLogMarkStride, it->second.at.size() - 1);
    return {k * kLogMarkStride, it->second.at[k].first, it->second.at[k].second};
}

void TaskLogIndex::learn(const std::string& path, uint64_t file, size_t line, uint64_t offset, uint64_t hash) {
    if (line % kLogMarkStride != 0) return;
    std::lock_guard<std::mutex> lock(mutex_);
    auto [it, fresh] = marks_.try_emplace(path);
    if (fresh) {
        order_.push_back(path);
        if (order_.size() > kLogIndexFiles) {
            marks_.erase(order_.front());
            order_.pop_front();
        }
    }
    if (it->second.file != file) it->second = Marks{file, {}};
    auto& v = it->second.at;
    // Marks are learnt in order as a reader passes them; one out of order (a reader that
    // started before a mark it skipped) waits for the reader that passes the gap.
    if (line / kLogMarkStride == v.size()) v.emplace_back(offset, hash);
}

void TaskLogIndex::forget(const std::string& path) {
    std::lock_guard<std::mutex> lock(mutex_);
    marks_.erase(path);
    order_.erase(std::remove(order_.begin(), order_.end(), path), order_.end());
}

namespace {

uint64_t id_of(const struct stat& st) { return (uint64_t(st.st_dev) << 40) ^ uint64_t(st.st_ino); }

uint64_t line_hash(std::string_view line) { return std::hash<std::string_view>{}(line); }

}  // namespace

uint64_t log_file_id(const std::string& path) {
    struct stat st {};
    return ::stat(path.c_str(), &st) == 0 ? id_of(st) : 0;
}

LogPage read_task_log(const std::string& path, size_t from, size_t limit, size_t bytes, TaskLogIndex* index) {
    LogPage page;
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return page;
    FILE* f = ::fdopen(fd, "rb");
    if (!f) {
        ::close(fd);
        return page;
    }
    const std::unique_ptr<FILE, int (*)(FILE*)> closing(f, &std::fclose);
    struct stat st {};
    const uint64_t file = ::fstat(fd, &st) == 0 ? id_of(st) : 0;  // of the file opened, whatever the path names later
    TaskLogIndex::Mark mark = index && file ? index->before(path, file, from) : TaskLogIndex::Mark{};
    char* buf = nullptr;
    size_t cap = 0;
    struct FreeLine {
        char*& p;
        ~FreeLine() { std::free(p); }
    } free_line{buf};
    auto next_line = [&](std::string_view& line) {
        const ssize_t got = ::getline(&buf, &cap, f);
        // A record is one write(2), but a reader may see part of one: without its newline it is
        // not counted (Next-From stays before it), so the next page has it whole.
        if (got <= 0 || buf[got - 1] != '\n') return false;
        line = std::string_view(buf, size_t(got - 1));
        return true;
    };
    std::string_view line;
    bool have = false;  // `line` holds the mark's line, read to check it
    if (mark.line > 0) {
        // A mark holds while the line found there is the one learnt (a file rewritten in place
        // has other lines there); else the file is read from its start and learnt anew.
        if (::fseeko(f, off_t(mark.offset), SEEK_SET) == 0 && next_line(line) && line_hash(line) == mark.hash) {
            have = true;
        } else {
            index->forget(path);
            mark = {};
            ::fseeko(f, 0, SEEK_SET);
        }
    }
    size_t n = mark.line, taken = 0;
    uint64_t at = mark.offset;  // where the line read next starts
    // The lines between the mark and `from` are read and dropped one by one: a reader holds a
    // line, not the file.
    while (taken < limit && (have || next_line(line))) {
        have = false;
        const uint64_t start = at;
        at += line.size() + 1;
        if (line.empty()) continue;
        if (index && file) index->learn(path, file, n, start, line_hash(line));
        if (n++ < from) continue;
        if (taken > 0 && page.ndjson.size() + line.size() + 1 > bytes) break;
        page.ndjson += line;
        page.ndjson += '\n';
        ++taken;
    }
    // Past the end, the next line is the log's next: a reader that overshot is told where.
    page.next = std::min(from, n) + taken;
    return page;
}

}  // namespace tessera::server
