// Holds server/http/response_bytes.h: a result file is streamed in small reads, never copied
// whole into a response, and images encoded on request are bounded together (a hostile client
// that asks and never reads cannot make the server hold more than the bound).
#include "server/http/response_bytes.h"

#include <gtest/gtest.h>
#include <httplib.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>

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
    httplib::Response res;
    send_file(res, path.string(), "image/x-exr");
    EXPECT_TRUE(res.body.empty());  // nothing of the file in the response itself
    EXPECT_EQ(res.content_length_, content.size());
    size_t largest = 0;
    EXPECT_EQ(drain(res, &largest), content);
    EXPECT_LE(largest, size_t(64) << 10);
    fs::remove(path);
    httplib::Response missing;
    EXPECT_THROW(send_file(missing, path.string(), "image/x-exr"), std::runtime_error);
}

TEST(ResponseBytes, EncodedImagesAreBoundedTogetherUntilTheirClientsHaveThem) {
    EncodedResponses enc(1000);
    auto bytes = [](size_t n) { return [n] { return std::vector<unsigned char>(n, 7); }; };
    auto first = std::make_optional<httplib::Response>();
    ASSERT_TRUE(enc.send(*first, 600, bytes(600), "image/png"));
    EXPECT_EQ(enc.held(), 600u);
    EXPECT_EQ(drain(*first), std::string(600, char(7)));
    // While the first response lives (its client has not read it all), a second would pass the bound.
    httplib::Response second;
    EXPECT_FALSE(enc.send(second, 600, bytes(600), "image/png"));
    EXPECT_EQ(second.content_length_, 0u);
    EXPECT_EQ(enc.held(), 600u);
    httplib::Response small;
    EXPECT_TRUE(enc.send(small, 300, bytes(250), "image/png"));  // within it: the size, not the estimate, is held
    EXPECT_EQ(enc.held(), 850u);
    first.reset();  // the response is gone: its bytes are given back
    EXPECT_EQ(enc.held(), 250u);
    EXPECT_TRUE(enc.send(second, 600, bytes(600), "image/png"));
    // One is always allowed, however large: a huge image can still be fetched alone.
    EncodedResponses tiny(10);
    httplib::Response big;
    EXPECT_TRUE(tiny.send(big, 5000, bytes(5000), "image/x-exr"));
    // An encoder that throws holds nothing.
    EncodedResponses e2(1000);
    httplib::Response r;
    EXPECT_THROW(e2.send(r, 100, [] () -> std::vector<unsigned char> { throw std::runtime_error("no"); }, "image/png"),
                 std::runtime_error);
    EXPECT_EQ(e2.held(), 0u);
}

}  // namespace
}  // namespace tessera::server
