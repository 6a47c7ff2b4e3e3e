#include "server/http/response_bytes.h"

#include <httplib.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <functional>
#include <optional>
#include <string_view>
#include <utility>
#include <stdexcept>

#include "server/http/problem.h"

namespace tessera::server {
namespace {

// Files up to this size are answered from memory (compressed by httplib where the client
// accepts it); larger ones are streamed.
constexpr uint64_t kInMemory = 256 << 10;

// The Range hold_range took aside for this thread's request, and its If-Range.
thread_local std::optional<httplib::Range> t_range;
thread_local std::optional<std::string> t_if_range;
// Whether this thread's answer takes ranges (a result file, an image that does not change).
thread_local bool t_takes_ranges = false;

// An answer's validators: an ETag always, a Last-Modified where the answer is a file.
struct Validators {
    std::string etag;
    std::string last_modified;  // as sent (IMF-fixdate); empty for none
    time_t modified = 0;     // when the file took its place, whether its date is sent or not
    bool file_time = false;  // `modified` is a file's
};

// The types httplib 0.11 compresses (its can_compress_content_type).
bool compressed_by_httplib(const std::string& type) {
    return type.rfind("text/", 0) == 0 || type == "image/svg+xml" || type == "application/javascript" ||
           type == "application/json" || type == "application/xml" || type == "application/xhtml+xml";
}


// An HTTP date in any of its three forms (RFC 9110 5.6.7): IMF-fixdate, RFC 850, asctime.
std::optional<time_t> parse_http_date(const std::string& s) {
    for (const char* form : {"%a, %d %b %Y %H:%M:%S GMT", "%A, %d-%b-%y %H:%M:%S GMT", "%a %b %e %H:%M:%S %Y"}) {
        std::tm tm{};
        const char* end = strptime(s.c_str(), form, &tm);
        if (!end || *end != '\0') continue;
        // A day the month lacks (30 Feb) is no date: timegm would carry it into the next month.
        std::tm back = tm;
        const time_t t = timegm(&back);
        if (back.tm_mday != tm.tm_mday || back.tm_mon != tm.tm_mon || back.tm_hour != tm.tm_hour || back.tm_min != tm.tm_min ||
            back.tm_sec != tm.tm_sec)
            return std::nullopt;
        return t;
    }
    return std::nullopt;
}

std::string trim(std::string s) {
    const size_t a = s.find_first_not_of(" \t");
    if (a == std::string::npos) return "";
    return s.substr(a, s.find_last_not_of(" \t") - a + 1);
}

// A header's values over all its lines, as one comma-separated list (RFC 9110 5.3).
std::string joined(const httplib::Request& req, const char* name) {
    std::string all;
    const size_t n = req.get_header_value_count(name);
    for (size_t i = 0; i < n; ++i) all += (i ? "," : "") + req.get_header_value(name, i);
    return all;
}

// A date header's one value; several (or none) are no date (RFC 9110 13.1.3).
std::optional<time_t> one_date(const httplib::Request& req, const char* name) {
    if (req.get_header_value_count(name) != 1) return std::nullopt;
    return parse_http_date(trim(req.get_header_value(name)));
}

bool weak(const std::string& tag) { return tag.rfind("W/", 0) == 0; }

// An If-Match or If-None-Match list against our ETag: weakly (the opaque parts alike) for
// If-None-Match, strongly (both strong and alike) for If-Match (RFC 9110 8.8.3.2).
bool list_hits(const std::string& header, const std::string& etag, bool strong) {
    auto opaque = [](const std::string& t) { return weak(t) ? t.substr(2) : t; };
    size_t at = 0;
    while (at <= header.size()) {
        const size_t comma = header.find(',', at);
        const std::string tag = trim(header.substr(at, comma == std::string::npos ? std::string::npos : comma - at));
        if (tag == "*") return true;
        if (!tag.empty() && (strong ? !weak(tag) && !weak(etag) && tag == etag : opaque(tag) == opaque(etag))) return true;
        if (comma == std::string::npos) break;
        at = comma + 1;
    }
    return false;
}

// Sets the validators and evaluates the request's preconditions in RFC 9110's order (13.2.2):
// If-Match, else If-Unmodified-Since (412 where they fail), then If-None-Match, else
// If-Modified-Since (304 where the client has this answer). True where the answer is decided
// (412 thrown, or 304 set); false where the body is to be sent.
// httplib frames a bodiless answer with `Content-Length: 0`, a 304 too, though RFC 9110 would
// have the 200's length or none: httplib's own client waits for a body on a 304 without it
// (cpp-httplib issue 1998), and every client ignores a 304's length, so it is left as it is.
bool not_modified(const httplib::Request& req, httplib::Response& res, const Validators& v) {
    res.set_header("ETag", v.etag);
    if (!v.last_modified.empty()) res.set_header("Last-Modified", v.last_modified);
    auto failed = [&](const char* header) {
        t_range.reset();
        t_if_range.reset();
        throw Problem(412, "precondition-failed", "Precondition failed",
                      std::string(header) + " does not hold for this answer (its ETag is " + v.etag + ")");
    };
    if (req.has_header("If-Match")) {
        if (!list_hits(joined(req, "If-Match"), v.etag, true)) failed("If-Match");
    } else if (const auto since = one_date(req, "If-Unmodified-Since"); since && v.file_time) {
        // A file within its first second (no date sent) fails a date in that second too: the
        // date may be another file's, written there before it.
        if (v.last_modified.empty() ? v.modified >= *since : v.modified > *since) failed("If-Unmodified-Since");
    }
    bool fresh = false;
    if (req.has_header("If-None-Match")) {
        fresh = list_hits(joined(req, "If-None-Match"), v.etag, false);
    } else if (const auto since = one_date(req, "If-Modified-Since"); since && !v.last_modified.empty()) {
        fresh = v.modified <= *since;
    }
    if (!fresh) return false;
    t_range.reset();
    t_if_range.reset();
    res.status = 304;
    return true;
}

// Fits the range held for this request (if any) to a body of `size` bytes and gives it back to
// the request: an open or overlong end is cut at the body's, a start at or past it is 416.
// Under If-Range the range holds only while the validator it names is this answer's: a strong
// ETag alike, or the Last-Modified date of an answer whose tag is strong (a date is sent only
// for a file a second old then, so the one the client holds was strong when it was sent).
void fit_range(const httplib::Request& req, httplib::Response& res, uint64_t size, const Validators& v) {
    std::optional<httplib::Range> range = t_range;
    const std::optional<std::string> if_range = t_if_range;
    t_range.reset();
    t_if_range.reset();
    if (!range) return;
    if (if_range) {
        const std::string tag = trim(*if_range);
        const bool strong_tag = !tag.empty() && tag.front() == '"';
        const bool date_strong = !weak(v.etag) && !v.last_modified.empty();
        const bool same = strong_tag ? !weak(v.etag) && tag == v.etag : date_strong && tag == v.last_modified;
        if (!same) return;  // changed since the client's part: the whole answer
    }
    int64_t first = range->first, last = range->second;
    const int64_t n = int64_t(size);
    if (first < 0) {  // the last `last` bytes
        if (last <= 0) last = 0;
        first = std::max<int64_t>(0, n - last);
        last = n - 1;
    } else if (last < 0 || last >= n) {
        last = n - 1;
    }
    if (n == 0 || first >= n || first > last) {
        res.set_header("Content-Range", "bytes */" + std::to_string(size));
        throw Problem(416, "range-not-satisfiable", "Range not satisfiable",
                      "the range asked for starts past the end of the " + std::to_string(size) + "-byte answer");
    }
    // httplib's Request is not const where it is made; the handler sees it so.
    const_cast<httplib::Request&>(req).ranges = {{first, last}};
}

}  // namespace

std::string http_date(time_t t) {
    std::tm tm{};
    gmtime_r(&t, &tm);
    char buf[40];
    std::strftime(buf, sizeof buf, "%a, %d %b %Y %H:%M:%S GMT", &tm);
    return buf;
}

void stamp(httplib::Response& res) {
    res.headers.erase("Date");
    res.set_header("Date", http_date(std::time(nullptr)));
    // httplib says `bytes` on every HEAD before routing: the answer's own word replaces it.
    res.headers.erase("Accept-Ranges");
    res.set_header("Accept-Ranges", t_takes_ranges ? "bytes" : "none");
}

void end_answer() {
    t_range.reset();
    t_if_range.reset();
    t_takes_ranges = false;
}

void hold_range(httplib::Request& req) {
    t_range.reset();
    t_if_range.reset();
    t_takes_ranges = false;
    // One range in one Range line (httplib reads the first line alone); anything else, the whole.
    if (req.ranges.size() == 1 && req.get_header_value_count("Range") <= 1 && req.get_header_value_count("If-Range") <= 1) {
        t_range = req.ranges.front();
        if (req.has_header("If-Range")) t_if_range = req.get_header_value("If-Range");
    }
    req.ranges.clear();
}

void send_file(const httplib::Request& req, httplib::Response& res, const std::string& path, const std::string& content_type) {
    // One descriptor for the validator and the bytes: a file renamed over the path meanwhile (a
    // farm's later attempt) can never lend its tag to the other's bytes.
    const int raw = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (raw < 0) throw std::runtime_error(path + ": cannot be read");
    const auto fd = std::shared_ptr<int>(new int(raw), [](int* f) {
        ::close(*f);
        delete f;
    });
    struct stat st {};
    if (::fstat(*fd, &st) != 0 || !S_ISREG(st.st_mode)) throw std::runtime_error(path + ": cannot be read");
    const uint64_t size = uint64_t(st.st_size);
    const bool in_memory = size <= kInMemory;
    Validators v;
    const uint64_t ns = uint64_t(st.st_mtim.tv_sec) * 1'000'000'000u + uint64_t(st.st_mtim.tv_nsec);
    char tag[80];
    // httplib compresses a text answer held in memory where the client accepts it: its bytes
    // then differ by encoding, so its tag is weak (no If-Range resumes it; 304 still does).
    std::snprintf(tag, sizeof tag, "%s\"%llx-%llx-%llx\"", in_memory && compressed_by_httplib(content_type) ? "W/" : "",
                  (unsigned long long)size, (unsigned long long)ns, (unsigned long long)st.st_ino);
    v.etag = tag;
    // When the file took its place: its change time too, which a rename sets, as a file written
    // earlier and renamed over the path (a farm's later attempt) keeps its older mtime.
    const timespec landed = std::make_pair(st.st_ctim.tv_sec, st.st_ctim.tv_nsec) > std::make_pair(st.st_mtim.tv_sec, st.st_mtim.tv_nsec)
                                ? st.st_ctim : st.st_mtim;
    v.modified = landed.tv_sec;
    v.file_time = true;
    // A date is a validator only for a file a second or more in place when it is sent: a file
    // replaced within that second (a shot's frame written again) would carry the same date. A
    // date sent so is strong from then on (RFC 9110 8.8.2.2), as a later file lands a second on.
    timespec now{};
    ::clock_gettime(CLOCK_REALTIME, &now);
    if ((int64_t(now.tv_sec) - landed.tv_sec) * 1'000'000'000 + (now.tv_nsec - landed.tv_nsec) >= 1'000'000'000)
        v.last_modified = http_date(v.modified);
    t_takes_ranges = true;  // a 304 says so too: a cache copies its headers onto what it kept
    if (not_modified(req, res, v)) return;
    fit_range(req, res, size, v);
    auto read_at = [fd, size](char* buf, uint64_t offset, uint64_t length) -> int64_t {
        if (offset >= size) return 0;
        const ssize_t got = ::pread(*fd, buf, size_t(std::min(length, size - offset)), off_t(offset));
        return got < 0 ? -1 : int64_t(got);
    };
    if (in_memory) {
        std::string body(size, '\0');
        uint64_t have = 0;
        for (int64_t got; have < size && (got = read_at(body.data() + have, have, size - have)) > 0;) have += uint64_t(got);
        body.resize(size_t(have));
        res.set_content(std::move(body), content_type);
        return;
    }
    res.set_content_provider(size_t(size), content_type, [read_at, size](size_t offset, size_t length, httplib::DataSink& sink) {
        if (offset >= size) return false;
        char buf[64 << 10];
        const int64_t got = read_at(buf, offset, std::min<uint64_t>(length, sizeof buf));
        // A file cut short under the answer (truncated in place) ends the connection.
        return got > 0 && sink.write(buf, size_t(got));
    });
}

bool EncodedResponses::send(const httplib::Request& req, httplib::Response& res, uint64_t estimate,
                            const std::function<std::vector<unsigned char>()>& encode, const std::string& content_type,
                            const std::string& live) {
    // A live pass is named before it is encoded: a poller that has it gets its 304 without an
    // encoding, and without a place in the budget.
    Validators v;
    if (!live.empty()) {
        char tag[40];
        std::snprintf(tag, sizeof tag, "W/\"%016llx\"", (unsigned long long)std::hash<std::string>{}(live));
        v.etag = tag;
        if (not_modified(req, res, v)) return true;
    }
    const std::shared_ptr<State> state = state_;
    uint64_t now = state->held.load();
    do {
        if (now > 0 && now + estimate > state->budget) return false;
    } while (!state->held.compare_exchange_weak(now, now + estimate));
    std::shared_ptr<const std::vector<unsigned char>> bytes;
    {
        // The reservation is given back on every path; the bytes' own size is held from the
        // moment the shared bytes own it, and given back by their deleter.
        std::unique_ptr<std::vector<unsigned char>> encoded;
        try {
            encoded = std::make_unique<std::vector<unsigned char>>(encode());
        } catch (...) {
            state->held -= estimate;
            throw;
        }
        const uint64_t size = encoded->size();
        state->held += size;
        state->held -= estimate;
        // Should the control block fail to allocate, the deleter runs (and gives `size` back).
        bytes = std::shared_ptr<const std::vector<unsigned char>>(encoded.release(), [state, size](const std::vector<unsigned char>* p) {
            delete p;
            state->held -= size;
        });
    }
    // Weak tags: an encoder may write the time into its bytes (OpenEXR's capDate), so two
    // encodings of one image are alike in meaning, not byte for byte. A live pass is named by
    // what the caller says it is (above); anything else by its bytes' hash (libstdc++'s 64-bit
    // Murmur).
    if (live.empty()) {
        const uint64_t h = std::hash<std::string_view>{}(std::string_view(reinterpret_cast<const char*>(bytes->data()), bytes->size()));
        char tag[48];
        std::snprintf(tag, sizeof tag, "W/\"%016llx-%llx\"", (unsigned long long)h, (unsigned long long)bytes->size());
        v.etag = tag;
        t_takes_ranges = true;
        if (not_modified(req, res, v)) return true;
        fit_range(req, res, bytes->size(), v);
    } else {
        // Its bytes change pass by pass under one URL: no range, so that a resumed download
        // never joins two passes.
        t_range.reset();
        t_if_range.reset();
    }
    if (bytes->empty()) {
        res.set_content("", content_type);
        return true;
    }
    res.set_content_provider(bytes->size(), content_type, [bytes](size_t offset, size_t length, httplib::DataSink& sink) {
        if (offset >= bytes->size()) return false;
        const size_t n = std::min({length, bytes->size() - offset, size_t(1) << 20});
        return sink.write(reinterpret_cast<const char*>(bytes->data()) + offset, n);
    });
    return true;
}

}  // namespace tessera::server
