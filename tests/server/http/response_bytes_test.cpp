// Holds server/http/response_bytes.h: a result file is streamed in small reads, never copied
// whole into a response, and images encoded on request are bounded together (a hostile client
// that asks and never reads cannot make the server hold more than the bound).
#include "server/http/response_bytes.h"

#include "server/http/problem.h"

#include <gtest/gtest.h>
#include <httplib.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

namespace tessera::server {
namespace {

namespace fs = std::filesystem;

// Reads a response's content provider as the server would, recording the largest write.
std::string drain(httplib::Response& res, size_t* largest = nullptr) {
    std::string out;
    httplib::DataSink sink;
    sink.write = [&](const char* d, size_t n) {
        out.append(d, n);
        if (largest) *largest = std::max(*largest, n);
        return true;
    };
    sink.is_writable = [] { return true; };
    while (out.size() < res.content_length_)
        if (!res.content_provider_(out.size(), res.content_length_ - out.size(), sink)) break;
    return out;
}

TEST(ResponseBytes, AFileIsStreamedInSmallReadsNotHeldWhole) {
    const fs::path path = fs::temp_directory_path() / ("tessera_stream_" + std::to_string(::getpid()) + ".bin");
    std::string content(1'000'003, '\0');
    for (size_t i = 0; i < content.size(); ++i) content[i] = char((i * 2654435761u) >> 13);
    std::ofstream(path, std::ios::binary).write(content.data(), std::streamsize(content.size()));
    httplib::Request req;
    httplib::Response res;
    send_file(req, res, path.string(), "image/x-exr");
    EXPECT_TRUE(res.body.empty());  // nothing of the file in the response itself
    EXPECT_EQ(res.content_length_, content.size());
    size_t largest = 0;
    EXPECT_EQ(drain(res, &largest), content);
    EXPECT_LE(largest, size_t(64) << 10);
    // httplib checks a range only against a body it holds: the answer fits it to the file.
    const size_t n = content.size();
    for (const auto& [asked, fitted] : std::vector<std::pair<httplib::Range, httplib::Range>>{
             {{10, 99'999'999}, {10, ssize_t(n) - 1}}, {{5, -1}, {5, ssize_t(n) - 1}}, {{-1, 100}, {ssize_t(n) - 100, ssize_t(n) - 1}},
             {{7, 20}, {7, 20}}}) {
        httplib::Request ranged;
        ranged.ranges = {asked};
        hold_range(ranged);
        EXPECT_TRUE(ranged.ranges.empty()) << "taken aside until a file answers";
        httplib::Response r;
        send_file(ranged, r, path.string(), "image/x-exr");
        ASSERT_EQ(ranged.ranges.size(), 1u);
        EXPECT_EQ(ranged.ranges.front(), fitted) << asked.first << "-" << asked.second;
    }
    for (const httplib::Range& past : {httplib::Range{ssize_t(n), -1}, httplib::Range{ssize_t(n) + 5, ssize_t(n) + 9}}) {
        httplib::Request ranged;
        ranged.ranges = {past};
        hold_range(ranged);
        httplib::Response r;
        EXPECT_THROW(send_file(ranged, r, path.string(), "image/x-exr"), Problem);
        EXPECT_EQ(r.get_header_value("Content-Range"), "bytes */" + std::to_string(n));
        EXPECT_TRUE(ranged.ranges.empty()) << "the 416's problem body is not cut by the range";
    }
    // Asked past the end all the same, the provider writes nothing outside the file.
    httplib::Response again;
    send_file(req, again, path.string(), "image/x-exr");
    httplib::DataSink sink;
    size_t written = 0;
    sink.write = [&](const char*, size_t k) { written += k; return true; };
    EXPECT_FALSE(again.content_provider_(n, 1000, sink));
    EXPECT_TRUE(again.content_provider_(n - 3, 1000, sink));
    EXPECT_EQ(written, 3u);
    fs::remove(path);
    httplib::Response missing;
    EXPECT_THROW(send_file(req, missing, path.string(), "image/x-exr"), std::runtime_error);
    // Several ranges, or If-Range (no validator of ours can match it): the whole body.
    httplib::Request several;
    several.ranges = {{0, 9}, {20, 29}};
    hold_range(several);
    httplib::Request conditional;
    conditional.ranges = {{0, 9}};
    conditional.headers.emplace("If-Range", "\"x\"");
    hold_range(conditional);
    for (httplib::Request* whole : {&several, &conditional}) {
        httplib::Response r;
        std::ofstream(path, std::ios::binary) << std::string(100, 'w');
        send_file(*whole, r, path.string(), "image/x-exr");
        EXPECT_TRUE(whole->ranges.empty());
        EXPECT_EQ(r.body, std::string(100, 'w'));
    }
    // A small file fits its range too (its end cut at the file's, 416 past it), as httplib
    // would not: it answered `bytes 0-99999999/1000`.
    {
        std::ofstream(path, std::ios::binary) << std::string(1000, 's');
        httplib::Request ranged;
        ranged.ranges = {{0, 99'999'999}};
        hold_range(ranged);
        httplib::Response r;
        send_file(ranged, r, path.string(), "image/png");
        ASSERT_EQ(ranged.ranges.size(), 1u);
        EXPECT_EQ(ranged.ranges.front(), (httplib::Range{0, 999}));
        httplib::Request past;
        past.ranges = {{1000, -1}};
        hold_range(past);
        httplib::Response p;
        EXPECT_THROW(send_file(past, p, path.string(), "image/png"), Problem);
        EXPECT_EQ(p.get_header_value("Content-Range"), "bytes */1000");
        fs::remove(path);
    }
    // A small file (a report, a curve) is answered from memory, so httplib may compress it;
    // an empty one too.
    for (const size_t size : {size_t(0), size_t(1000)}) {
        std::ofstream(path, std::ios::binary) << std::string(size, 'r');
        httplib::Response small;
        send_file(req, small, path.string(), "application/json");
        EXPECT_EQ(small.body, std::string(size, 'r'));
        EXPECT_FALSE(small.content_provider_);
        fs::remove(path);
    }
}

TEST(ResponseBytes, EncodedImagesAreBoundedTogetherUntilTheirClientsHaveThem) {
    EncodedResponses enc(1000);
    auto bytes = [](size_t n) { return [n] { return std::vector<unsigned char>(n, 7); }; };
    const httplib::Request req;
    auto first = std::make_optional<httplib::Response>();
    ASSERT_TRUE(enc.send(req, *first, 600, bytes(600), "image/png"));
    EXPECT_EQ(enc.held(), 600u);
    EXPECT_EQ(drain(*first), std::string(600, char(7)));
    // While the first response lives (its client has not read it all), a second would pass the bound.
    httplib::Response second;
    EXPECT_FALSE(enc.send(req, second, 600, bytes(600), "image/png"));
    EXPECT_EQ(second.content_length_, 0u);
    EXPECT_EQ(enc.held(), 600u);
    httplib::Response small;
    EXPECT_TRUE(enc.send(req, small, 300, bytes(250), "image/png"));  // within it: the size, not the estimate, is held
    EXPECT_EQ(enc.held(), 850u);
    first.reset();  // the response is gone: its bytes are given back
    EXPECT_EQ(enc.held(), 250u);
    EXPECT_TRUE(enc.send(req, second, 600, bytes(600), "image/png"));
    // One is always allowed, however large: a huge image can still be fetched alone.
    EncodedResponses tiny(10);
    httplib::Response big;
    EXPECT_TRUE(tiny.send(req, big, 5000, bytes(5000), "image/x-exr"));
    // An encoder that throws holds nothing.
    EncodedResponses e2(1000);
    httplib::Response r;
    EXPECT_THROW(e2.send(req, r, 100, [] () -> std::vector<unsigned char> { throw std::runtime_error("no"); }, "image/png"),
                 std::runtime_error);
    EXPECT_EQ(e2.held(), 0u);
    // A range is fitted to the encoded bytes; one past them is 416 and holds nothing after.
    httplib::Request ranged;
    ranged.ranges = {{100, 99'999'999}};
    hold_range(ranged);
    httplib::Response r2;
    ASSERT_TRUE(e2.send(ranged, r2, 300, bytes(300), "image/png"));
    EXPECT_EQ(ranged.ranges.front(), (httplib::Range{100, 299}));
    httplib::DataSink sink;
    size_t written = 0;
    sink.write = [&](const char*, size_t k) { written += k; return true; };
    EXPECT_FALSE(r2.content_provider_(300, 1'000'000, sink));
    EXPECT_TRUE(r2.content_provider_(290, 1'000'000, sink));
    EXPECT_EQ(written, 10u);
    ranged.ranges = {{300, -1}};
    hold_range(ranged);
    httplib::Response r3;
    EXPECT_THROW(e2.send(ranged, r3, 300, bytes(300), "image/png"), Problem);
    EXPECT_EQ(e2.held(), 300u);  // r2's alone
}

// A file names itself by its size, time and inode; an encoded image by its bytes or, while its
// job runs, by its pass. Preconditions as RFC 9110 orders them: 412 where If-Match or
// If-Unmodified-Since fail, 304 where the client has the answer, and a range under If-Range
// only while the answer is the one the client's part came from; a running job's image none.
TEST(ResponseBytes, ValidatorsAnswer304AndGuardResumedRanges) {
    const fs::path path = fs::temp_directory_path() / ("tessera_validators_" + std::to_string(::getpid()) + ".bin");
    std::ofstream(path, std::ios::binary) << std::string(300'000, 'v');
    // Written an hour ago, and in place over a second (its change time, which setting the
    // time sets, is when it landed): its Last-Modified is a strong validator.
    fs::last_write_time(path, fs::file_time_type::clock::now() - std::chrono::hours(1));
    std::this_thread::sleep_for(std::chrono::milliseconds(1100));
    httplib::Request plain;
    httplib::Response first;
    send_file(plain, first, path.string(), "image/x-exr");
    const std::string etag = first.get_header_value("ETag");
    const std::string modified = first.get_header_value("Last-Modified");
    ASSERT_EQ(etag.front(), '"');
    ASSERT_FALSE(modified.empty());
    for (const auto& [name, value] : std::vector<std::pair<std::string, std::string>>{
             {"If-None-Match", etag}, {"If-None-Match", "\"other\", W/" + etag}, {"If-None-Match", "*"}, {"If-Modified-Since", modified},
             {"If-Modified-Since", "Sunday, 06-Nov-44 08:49:37 GMT"}, {"If-Modified-Since", "Sun Nov  6 08:49:37 2044"}}) {
        httplib::Request cond;
        cond.headers.emplace(name, value);
        httplib::Response r;
        send_file(cond, r, path.string(), "image/x-exr");
        EXPECT_EQ(r.status, 304) << name << ": " << value;
        EXPECT_EQ(r.get_header_value("ETag"), etag) << "a 304 names what the client has";
        EXPECT_EQ(r.get_header_value("Last-Modified"), modified);
        stamp(r);
        EXPECT_EQ(r.get_header_value("Accept-Ranges"), "bytes") << "a cache copies a 304's headers onto what it kept";
        end_answer();
        EXPECT_FALSE(r.content_provider_);
        EXPECT_TRUE(r.body.empty());
    }
    for (const auto& [name, value] : std::vector<std::pair<std::string, std::string>>{
             {"If-None-Match", "\"other\""}, {"If-Modified-Since", "Mon, 01 Jan 2001 00:00:00 GMT"}, {"If-Modified-Since", "garbage"},
             {"If-Modified-Since", "Tue, 30 Feb 2044 00:00:00 GMT"}}) {
        httplib::Request cond;
        cond.headers.emplace(name, value);
        httplib::Response r;
        send_file(cond, r, path.string(), "image/x-exr");
        EXPECT_NE(r.status, 304) << name << ": " << value;
        EXPECT_EQ(r.content_length_, 300'000u);
    }
    // A list over several lines is one list; a date given twice is no date.
    {
        httplib::Request cond;
        cond.headers.emplace("If-None-Match", "\"a\"");
        cond.headers.emplace("If-None-Match", etag);
        httplib::Response r;
        send_file(cond, r, path.string(), "image/x-exr");
        EXPECT_EQ(r.status, 304);
        httplib::Request twice;
        twice.headers.emplace("If-Modified-Since", modified);
        twice.headers.emplace("If-Modified-Since", modified);
        httplib::Response r2;
        send_file(twice, r2, path.string(), "image/x-exr");
        EXPECT_NE(r2.status, 304);
    }
    // If-Match and If-Unmodified-Since: 412 where they fail, the answer where they hold.
    for (const auto& [name, value, holds] : std::vector<std::tuple<std::string, std::string, bool>>{
             {"If-Match", etag, true}, {"If-Match", "*", true}, {"If-Match", "\"other\"", false}, {"If-Match", "W/" + etag, false},
             {"If-Unmodified-Since", modified, true}, {"If-Unmodified-Since", "Mon, 01 Jan 2001 00:00:00 GMT", false}}) {
        httplib::Request cond;
        cond.headers.emplace(name, value);
        httplib::Response r;
        if (holds) {
            send_file(cond, r, path.string(), "image/x-exr");
            EXPECT_EQ(r.content_length_, 300'000u) << name << ": " << value;
        } else {
            try {
                send_file(cond, r, path.string(), "image/x-exr");
                ADD_FAILURE() << name << ": " << value << " should fail";
            } catch (const Problem& p) {
                EXPECT_EQ(p.status, 412) << name << ": " << value;
            }
        }
    }
    // Each pair decided by its first: If-Match holding, If-Unmodified-Since is not read; If-None-
    // Match missing, If-Modified-Since is not read.
    for (const auto& [first, second] : std::vector<std::pair<std::pair<std::string, std::string>, std::pair<std::string, std::string>>>{
             {{"If-Match", etag}, {"If-Unmodified-Since", "Mon, 01 Jan 2001 00:00:00 GMT"}},
             {{"If-None-Match", "\"other\""}, {"If-Modified-Since", modified}}}) {
        httplib::Request cond;
        cond.headers.emplace(first.first, first.second);
        cond.headers.emplace(second.first, second.second);
        httplib::Response r;
        EXPECT_NO_THROW(send_file(cond, r, path.string(), "image/x-exr")) << first.first;
        EXPECT_NE(r.status, 304) << first.first;
        EXPECT_EQ(r.content_length_, 300'000u) << first.first;
    }
    // Whether bytes 10-19 asked for under If-Range `validator` are served.
    auto file_range_kept = [&](const std::string& validator) {
        httplib::Request req;
        req.ranges = {{10, 19}};
        req.headers.emplace("If-Range", validator);
        hold_range(req);
        httplib::Response r;
        send_file(req, r, path.string(), "image/x-exr");
        return req.ranges.size() == 1;
    };
    // If-Range with this file's ETag or date: the range; with another's: the whole file.
    for (const auto& [validator, ranged_answer] : std::vector<std::pair<std::string, bool>>{
             {etag, true}, {modified, true}, {"\"other\"", false}, {"W/" + etag, false}})
        EXPECT_EQ(file_range_kept(validator), ranged_answer) << validator;
    // A file written within the second: no date (another file written in the same second would
    // carry it too), and a date for it in If-Range resumes nothing; its ETag still does.
    {
        std::ofstream(path, std::ios::binary | std::ios::trunc) << std::string(300'000, 'w');
        // Its time a minute ahead: within its second however slowly this test runs.
        fs::last_write_time(path, fs::file_time_type::clock::now() + std::chrono::minutes(1));
        httplib::Response fresh;
        send_file(plain, fresh, path.string(), "image/x-exr");
        EXPECT_EQ(fresh.get_header_value("Last-Modified"), "") << "a file younger than a second has no date";
        const std::string fresh_tag = fresh.get_header_value("ETag");
        const auto mtime = std::chrono::system_clock::to_time_t(std::chrono::file_clock::to_sys(fs::last_write_time(path)));
        EXPECT_FALSE(file_range_kept(http_date(mtime)));
        EXPECT_TRUE(file_range_kept(fresh_tag));
        httplib::Request since;
        since.headers.emplace("If-Modified-Since", http_date(mtime));
        httplib::Response r;
        send_file(since, r, path.string(), "image/x-exr");
        EXPECT_NE(r.status, 304) << "no date, no 304 by date";
        // If-Unmodified-Since still holds it to its time: a date before or within its second
        // fails, one after it holds.
        for (const auto& [date, holds] : std::vector<std::pair<std::string, bool>>{
                 {http_date(mtime - 3600), false}, {http_date(mtime), false}, {http_date(mtime + 3600), true},
                 {"Fri, 31 Dec 9999 23:59:59 GMT", true}}) {
            httplib::Request unmodified;
            unmodified.headers.emplace("If-Unmodified-Since", date);
            httplib::Response u;
            try {
                send_file(unmodified, u, path.string(), "image/x-exr");
                EXPECT_TRUE(holds) << date;
            } catch (const Problem& p) {
                EXPECT_FALSE(holds) << date;
                EXPECT_EQ(p.status, 412);
            }
        }
        // A file written an hour ago and renamed over the path just now landed now: no date (a
        // farm's later attempt keeps the time it was written at).
        const fs::path older = path.string() + ".older";
        std::ofstream(older, std::ios::binary) << std::string(300'000, 'o');
        fs::last_write_time(older, fs::file_time_type::clock::now() - std::chrono::hours(1));
        fs::rename(older, path);
        httplib::Response renamed;
        send_file(plain, renamed, path.string(), "image/x-exr");
        EXPECT_EQ(renamed.get_header_value("Last-Modified"), "") << "in place for less than a second";
    }
    // A small text file, which httplib may compress: a weak tag, good for 304 and never for a range.
    std::ofstream(path, std::ios::binary | std::ios::trunc) << "{\"a\": 1}";
    httplib::Response small;
    send_file(plain, small, path.string(), "application/json");
    const std::string weak = small.get_header_value("ETag");
    EXPECT_EQ(weak.rfind("W/\"", 0), 0u) << weak;
    {
        httplib::Request cond;
        cond.headers.emplace("If-None-Match", weak);
        httplib::Response r;
        send_file(cond, r, path.string(), "application/json");
        EXPECT_EQ(r.status, 304);
        httplib::Request ranged;
        ranged.ranges = {{1, 3}};
        ranged.headers.emplace("If-Range", weak);
        hold_range(ranged);
        send_file(ranged, r, path.string(), "application/json");
        EXPECT_TRUE(ranged.ranges.empty()) << "a weak tag never resumes a range";
    }
    httplib::Response png;
    send_file(plain, png, path.string(), "image/png");
    EXPECT_EQ(png.get_header_value("ETag").front(), '"') << "an image is never compressed: a strong tag";
    fs::remove(path);

    // Encoded: the same bytes, the same weak tag (an encoder may write the time into them); a
    // range without If-Range, or under one (a weak tag never matches it: the whole answer).
    EncodedResponses enc(1 << 20);
    auto bytes = [](unsigned char fill) { return [fill] { return std::vector<unsigned char>(1000, fill); }; };
    httplib::Response a, b, c;
    ASSERT_TRUE(enc.send(plain, a, 1000, bytes(3), "image/png"));
    ASSERT_TRUE(enc.send(plain, b, 1000, bytes(3), "image/png"));
    ASSERT_TRUE(enc.send(plain, c, 1000, bytes(4), "image/png"));
    EXPECT_EQ(a.get_header_value("ETag"), b.get_header_value("ETag"));
    EXPECT_NE(c.get_header_value("ETag"), a.get_header_value("ETag"));
    EXPECT_EQ(a.get_header_value("ETag").rfind("W/\"", 0), 0u);
    // Whether bytes 100-199 asked for (under If-Range `validator`, where not empty) are served.
    auto range_kept = [&](const std::string& validator, unsigned char fill, const std::string& live) {
        httplib::Request req;
        req.ranges = {{100, 199}};
        if (!validator.empty()) req.headers.emplace("If-Range", validator);
        hold_range(req);
        httplib::Response r;
        EXPECT_TRUE(enc.send(req, r, 1000, bytes(fill), "image/png", live));
        stamp(r);
        EXPECT_EQ(r.get_header_value("Accept-Ranges"), live.empty() ? "bytes" : "none");
        return req.ranges.size() == 1;
    };
    EXPECT_TRUE(range_kept("", 3, "")) << "an answer that does not change serves its range";
    EXPECT_FALSE(range_kept(a.get_header_value("ETag"), 3, "")) << "a weak tag never resumes one";
    EXPECT_FALSE(range_kept("", 3, "job pass 1")) << "a running job's image: no range";
    // A live pass is named by what it is, whatever its bytes: its tag holds from one encoding
    // of the pass to the next (304), and another pass is another tag.
    httplib::Response p1, p1again, p2;
    ASSERT_TRUE(enc.send(plain, p1, 1000, bytes(5), "image/x-exr", "job pass 1"));
    ASSERT_TRUE(enc.send(plain, p1again, 1000, bytes(6), "image/x-exr", "job pass 1"));
    ASSERT_TRUE(enc.send(plain, p2, 1000, bytes(5), "image/x-exr", "job pass 2"));
    EXPECT_EQ(p1.get_header_value("ETag"), p1again.get_header_value("ETag"));
    EXPECT_NE(p1.get_header_value("ETag"), p2.get_header_value("ETag"));
    httplib::Request cond;
    cond.headers.emplace("If-None-Match", p1.get_header_value("ETag"));
    httplib::Response r;
    bool encoded = false;
    ASSERT_TRUE(enc.send(cond, r, 1000, [&] { encoded = true; return std::vector<unsigned char>(1000, 6); }, "image/x-exr", "job pass 1"));
    EXPECT_EQ(r.status, 304);
    EXPECT_FALSE(r.content_provider_);
    EXPECT_FALSE(encoded) << "a live pass's 304 costs no encoding";
}

}  // namespace
}  // namespace tessera::server
