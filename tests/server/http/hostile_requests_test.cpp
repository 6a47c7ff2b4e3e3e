// What a hostile or careless client sends, over real sockets to a real server: every request
// gets an answer (a problem+json with a 4xx), nothing it sends ends the process or is read past
// its budget, and the server goes on answering.
#include <gtest/gtest.h>
#include <httplib.h>

#include <cerrno>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "tests/server/raw_socket.h"
#include "tests/server/server_fixture.h"

namespace tessera::server {
namespace {
using nlohmann::json;

std::string body_of(const std::string& answer) {
    const size_t at = answer.find("\r\n\r\n");
    return at == std::string::npos ? "" : answer.substr(at + 4);
}

// An answer that is one problem+json response with a 4xx status.
void expect_problem_answer(const std::string& answer, const std::string& what) {
    const int status = status_of(answer);
    EXPECT_GE(status, 400) << what << ": " << answer.substr(0, 300);
    EXPECT_LT(status, 500) << what << ": " << answer.substr(0, 300);
    EXPECT_NE(answer.find("application/problem+json"), std::string::npos) << what << ": " << answer.substr(0, 300);
    const json problem = json::parse(body_of(answer), nullptr, false);
    EXPECT_TRUE(problem.is_object()) << what << ": " << answer.substr(0, 300);
}

std::string post(const std::string& path, const std::string& type, const std::string& body) {
    return "POST " + path + " HTTP/1.1\r\nHost: x\r\nContent-Type: " + type + "\r\nContent-Length: " + std::to_string(body.size()) +
           "\r\nConnection: close\r\n\r\n" + body;
}

std::string nested(const std::string& open, const std::string& close, int depth, const std::string& inner = "1") {
    std::string s;
    s.reserve(size_t(depth) * (open.size() + close.size()) + inner.size());
    for (int i = 0; i < depth; ++i) s += open;
    s += inner;
    for (int i = 0; i < depth; ++i) s += close;
    return s;
}

class Hostile : public Server {
protected:
    void expect_alive() {
        auto r = httplib::Client("127.0.0.1", port_).Get("/healthz");
        ASSERT_TRUE(r) << "the server stopped answering";
        EXPECT_EQ(r->status, 200);
    }
};

// Bytes that are not UTF-8, percent-encoded or raw, in every place a route puts a path or a
// query into its answer or its log: each is answered, and with tokens required too.
TEST_F(Hostile, InvalidUtf8InPathsAndQueriesIsAnswered) {
    start();
    const std::vector<std::pair<std::string, std::string>> requests = {
        {"GET", "/%ff"}, {"GET", "/ui/%ff"}, {"GET", "/healthz%ff"}, {"GET", "/v1/jobs/%ff"},
        {"GET", "/v1/jobs/%ff%fe/report.json"}, {"GET", "/v1/jobs/%ff/image.png?exposure=%ff"}, {"DELETE", "/v1/jobs/%ff"},
        {"DELETE", "/v1/jobs/%ff/results"}, {"PUT", "/v1/jobs/%ff"}, {"GET", "/v1/events?job=%ff"}, {"GET", "/v1/jobs?state=%ff"},
        {"GET", "/v1/jobs?limit=%ff"}, {"POST", "/v1/scenes?name=%ff.gltf"}, {"PATCH", "/%c3%28"}, {"GET", "/\xff\xfe"},
        {"GET", "/v1/jobs/%ed%a0%80"},
    };
    for (const auto& [method, path] : requests) {
        const std::string body = method == "POST" ? "{}" : "";
        const std::string head = method + " " + path + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n" +
                                 (body.empty() ? "" : "Content-Length: " + std::to_string(body.size()) + "\r\n") + "\r\n";
        expect_problem_answer(raw_exchange(port_, head + body), method + " " + path);
    }
    expect_alive();
}

TEST_F(Hostile, InvalidUtf8InUploadsIsRefusedNotFatal) {
    start();
    // A GLB header and a JSON chunk holding a 0xFF byte (the lengths are the hostile file's own).
    static const char glb[] = "glTF\x02\0\0\0\x20\0\0\0\x0c\0\0\0JSON{\"\xff\":1}";
    const std::string glb_with_bad_json(glb, sizeof glb - 1);
    const std::string png = std::string("\x89PNG\r\n\x1a\n", 8) + std::string(61, '\xff');
    const std::vector<std::pair<std::string, std::string>> uploads = {
        {"bad.gltf", "{\"asset\":{\"version\":\"\xff\"}}"},
        {"bad2.gltf", "{\"asset\":{\"version\":\"2.0\"},\"images\":[{\"uri\":\"\xff\xfe.png\"}],\"textures\":[{\"source\":0}]}"},
        {"png.gltf", png},
        {"bad.glb", glb_with_bad_json},
        {"bad.dae", "<?xml version=\"1.0\"?><COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" version=\"1.4.1\">"
                    "<library_visual_scenes><visual_scene id=\"s\"><node><instance_geometry url=\"#\xff\xfe\"/></node>"
                    "</visual_scene></library_visual_scenes><scene><instance_visual_scene url=\"#s\"/></scene></COLLADA>"},
    };
    for (const auto& [name, bytes] : uploads)
        expect_problem_answer(raw_exchange(port_, post("/v1/scenes?name=" + name, "application/octet-stream", bytes)), name);
    expect_alive();
}

// A key given twice in one object is refused (a proxy that checked the first would pass a job
// that runs the last), at the top and inside a field.
TEST_F(Hostile, AKeyGivenTwiceIsRefused) {
    start();
    for (const std::string body : {R"({"scene":"builtin:cornell_box","spp":1,"spp":4096})",
                                   R"({"scene":"builtin:cornell_box","adaptive":{"batch":8,"batch":16}})"}) {
        const std::string answer = raw_exchange(port_, post("/v1/jobs", "application/json", body));
        EXPECT_EQ(status_of(answer), 400) << answer.substr(0, 300);
        EXPECT_NE(body_of(answer).find("/problems/duplicate-key"), std::string::npos) << answer.substr(0, 400);
    }
}

// Nesting is refused before anything walks it, inside a field as at the top, in a job, a
// comparison and a glTF upload; a job nested within the bound is judged on its fields.
TEST_F(Hostile, DeepNestingIsRefusedByItsBound) {
    limits_.max_job_body = 4 << 20;  // the depth is what is refused, not the size
    start();
    const std::string deep_object = nested("{\"a\":", "}", 100000);
    const std::vector<std::pair<std::string, std::string>> bodies = {
        {"/v1/jobs", R"({"scene":"builtin:cornell_box","adaptive":)" + deep_object + "}"},
        {"/v1/jobs", deep_object},
        {"/v1/jobs", R"({"scene":"builtin:cornell_box","adaptive":)" + nested("[", "]", 100000) + "}"},
        {"/v1/comparisons", R"({"scene":"builtin:cornell_box","configs":[)" + deep_object + "]}"},
    };
    for (const auto& [path, body] : bodies) {
        const std::string answer = raw_exchange(port_, post(path, "application/json", body));
        EXPECT_EQ(status_of(answer), 400) << answer.substr(0, 300);
        EXPECT_NE(body_of(answer).find("/problems/json-too-deep"), std::string::npos) << answer.substr(0, 400);
    }
    // 64 levels are allowed (the default bound): the error is about the field, not the depth.
    const std::string within = raw_exchange(port_, post("/v1/jobs", "application/json",
                                                    R"({"scene":"builtin:cornell_box","adaptive":)" + nested("{\"a\":", "}", 62) + "}"));
    EXPECT_EQ(status_of(within), 400);
    EXPECT_EQ(body_of(within).find("json-too-deep"), std::string::npos) << within.substr(0, 400);
    const std::string gltf = R"({"asset":{"version":"2.0"},"extras":)" + deep_object + "}";
    const std::string upload = raw_exchange(port_, post("/v1/scenes?name=deep.gltf", "application/octet-stream", gltf));
    EXPECT_EQ(status_of(upload), 422) << upload.substr(0, 300);
    EXPECT_NE(upload.find("nests deeper than 64"), std::string::npos) << upload.substr(0, 400);
    expect_alive();
}

// A chunked body has no length up front: it is cut at the route's bound (with the framing's
// allowance) with a 413 and the connection closed, whatever the client goes on sending.
TEST_F(Hostile, ChunkedBodiesAreCutAtTheirBound) {
    limits_.max_job_body = 64 << 10;
    limits_.max_upload = 256 << 10;
    start();
    for (const auto& [path, bound] : std::vector<std::pair<std::string, size_t>>{{"/v1/jobs", limits_.max_job_body},
                                                                                   {"/v1/scenes?name=x.gltf", limits_.max_upload}}) {
        const int fd = connect_loopback(port_);
        ASSERT_GE(fd, 0);
        ASSERT_TRUE(send_all(fd, "POST " + path + " HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nTransfer-Encoding: chunked\r\n\r\n"));
        const std::string chunk = "1000\r\n" + std::string(0x1000, ' ') + "\r\n";
        size_t sent = 0;
        std::string answer;
        // Up to 128 MiB, and 20 s: a server that reads every byte takes all of it (it did: 1 GiB
        // before a 400), one that cuts the body answers while the kernel's buffers still take
        // the client's writes (tens of MiB at most here).
        const auto t0 = std::chrono::steady_clock::now();
        while (sent < (128u << 20) && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(20)) {
            pollfd p{fd, POLLIN | POLLOUT, 0};
            if (::poll(&p, 1, 1000) <= 0) continue;
            if (p.revents & POLLIN) {
                answer = read_until_close(fd, 3000);
                break;
            }
            const ssize_t n = ::send(fd, chunk.data(), chunk.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
            if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) continue;
            if (n <= 0) break;
            sent += size_t(n);
        }
        if (answer.empty()) answer = read_until_close(fd, 3000);
        ::close(fd);
        EXPECT_EQ(status_of(answer), 413) << path << ": " << answer.substr(0, 300);
        EXPECT_NE(answer.find("Connection: close"), std::string::npos) << answer.substr(0, 300);
        EXPECT_LT(sent, 64u << 20) << path << ": the server read on past its bound of " << bound;
    }
    expect_alive();
}

// A POST without Content-Length or Transfer-Encoding has an empty body (RFC 9112): answered at
// once, not after the client gives up. Other framings are refused.
TEST_F(Hostile, BodiesAreFramedAsHttpSays) {
    start();
    const int fd = connect_loopback(port_);
    ASSERT_GE(fd, 0);
    const auto t0 = std::chrono::steady_clock::now();
    send_all(fd, "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n\r\n");
    char buf[512];
    pollfd p{fd, POLLIN, 0};
    ASSERT_GT(::poll(&p, 1, 3000), 0) << "no answer to an unframed POST while the connection stays open";
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    ::close(fd);
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(3));
    EXPECT_EQ(status_of(std::string(buf, size_t(std::max<ssize_t>(n, 0)))), 400);
    for (const std::string& framing : {std::string("Transfer-Encoding: gzip\r\n"), std::string("Transfer-Encoding: chunked\r\nContent-Length: 2\r\n"),
                                       std::string("Transfer-Encoding: chunked, chunked\r\n")}) {
        const std::string answer = raw_exchange(port_, "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n" + framing + "\r\n2\r\n{}\r\n0\r\n\r\n");
        EXPECT_EQ(status_of(answer), 400) << framing << answer.substr(0, 300);
    }
    // Methods a route does not take are 405 before any body, with a body or without.
    for (const std::string& request : {std::string("PUT /v1/jobs HTTP/1.1\r\nHost: x\r\n\r\n"), std::string("PATCH /v1/jobs/abc HTTP/1.1\r\nHost: x\r\n\r\n"),
                                       std::string("PUT /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Length: 2\r\n\r\n{}")}) {
        const std::string answer = raw_exchange(port_, request, 3000);
        EXPECT_EQ(status_of(answer), 405) << request << answer.substr(0, 300);
        EXPECT_NE(answer.find("Allow: "), std::string::npos) << answer.substr(0, 300);
    }
    expect_alive();
}

// Compressed bodies would be inflated without a bound (a megabyte of gzip is a gigabyte of
// body): refused. Many ranges would copy an answer once per range: the whole answer instead.
TEST_F(Hostile, CompressedBodiesAndManyRangesAreNotMultipliers) {
    start();
    const std::string gz = raw_exchange(port_, "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                                               "Content-Encoding: gzip\r\nContent-Length: 4\r\n\r\nabcd");
    EXPECT_EQ(status_of(gz), 415) << gz.substr(0, 300);
    EXPECT_NE(gz.find("unsupported-content-encoding"), std::string::npos) << gz.substr(0, 400);
    std::string ranges = "bytes=0-";
    for (int i = 0; i < 1000; ++i) ranges += ",0-";
    const std::string many = raw_exchange(port_, "GET /ui/app.js HTTP/1.1\r\nHost: x\r\nRange: " + ranges + "\r\nConnection: close\r\n\r\n");
    EXPECT_EQ(status_of(many), 200) << many.substr(0, 300);
    // A Range is for result files alone (response_bytes.h): the page's script comes whole.
    const std::string one = raw_exchange(port_, "GET /ui/app.js HTTP/1.1\r\nHost: x\r\nRange: bytes=0-9\r\nConnection: close\r\n\r\n");
    EXPECT_EQ(status_of(one), 200) << one.substr(0, 300);
    EXPECT_EQ(body_of(one).size(), body_of(many).size());
    // Two Content-Lengths: refused, whatever they say.
    const std::string two = raw_exchange(port_, "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                                                "Content-Length: 2\r\nContent-Length: 2\r\n\r\n{}");
    EXPECT_EQ(status_of(two), 400) << two.substr(0, 300);
    // A broken head: answered, then the connection ends (the rest is not read as requests).
    const std::string broken = raw_exchange(port_, "FOO\r\nHost: x\r\n\r\nGET /healthz HTTP/1.1\r\nHost: x\r\n\r\n");
    EXPECT_EQ(status_of(broken), 400) << broken;
    EXPECT_EQ(broken.find("HTTP/1.1 ", 1), std::string::npos) << "a second answer after a broken request: " << broken;
    expect_alive();
}

// Bodies read at once share one bound: past it a request is refused before its body is read
// (503, Retry-After), and served again once the others are done.
TEST_F(Hostile, BodiesInFlightShareABound) {
    limits_.max_bodies_in_flight = 1 << 20;
    start();
    // A client that declared 800 KB and sends it slowly holds that much of the bound.
    const int slow = connect_loopback(port_);
    ASSERT_GE(slow, 0);
    const std::string body(800'000, ' ');
    ASSERT_TRUE(send_all(slow, "POST /v1/scenes?name=slow.gltf HTTP/1.1\r\nHost: x\r\nContent-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body.substr(0, 1000)));
    // Until its head is read, the other upload still fits: asked again until the bound is held
    // (a loaded machine may take a while to read the slow client's head).
    const std::string other = post("/v1/scenes?name=other.gltf", "application/octet-stream", std::string(500'000, ' '));
    std::string refused;
    for (int i = 0; i < 100 && status_of(refused) != 503; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        refused = raw_exchange(port_, other);
    }
    EXPECT_EQ(status_of(refused), 503) << refused.substr(0, 300);
    EXPECT_NE(refused.find("Retry-After"), std::string::npos) << refused.substr(0, 300);
    EXPECT_NE(refused.find("--max-bodies-mb"), std::string::npos) << refused.substr(0, 400);
    // Small bodies still fit beside it.
    const std::string small = raw_exchange(port_, post("/v1/jobs", "application/json", "{}"));
    EXPECT_EQ(status_of(small), 400) << small.substr(0, 300);
    send_all(slow, body.substr(1000));
    const std::string slow_answer = read_until_close(slow, 10000);
    ::close(slow);
    EXPECT_EQ(status_of(slow_answer), 422) << slow_answer.substr(0, 300);  // not glTF, but read and judged
    // The slow body's share comes back once its answer is written (just after the client reads it).
    std::string again;
    for (int i = 0; i < 100 && status_of(again) != 422; ++i) {
        if (i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
        again = raw_exchange(port_, other);
    }
    EXPECT_EQ(status_of(again), 422) << again.substr(0, 300);
}

TEST_F(Hostile, HeadsPastTheirBudgetGet431) {
    limits_.max_head_bytes = 16 << 10;
    start();
    std::string head = "GET /healthz HTTP/1.1\r\nHost: x\r\n";
    while (head.size() < (64u << 10)) head += "X-Filler: " + std::string(1000, 'a') + "\r\n";
    const std::string answer = raw_exchange(port_, head + "\r\n");
    EXPECT_EQ(status_of(answer), 431) << answer.substr(0, 300);
    EXPECT_NE(answer.find("--max-header-bytes"), std::string::npos) << answer.substr(0, 400);
    expect_alive();
}

// HTTP/1.1 clients and proxies may send requests before the answers: each is answered, in order.
TEST_F(Hostile, PipelinedRequestsAreAnsweredInOrder) {
    start();
    const std::string job = json{{"scene", "builtin:cornell_box"}, {"width", 8}, {"height", 8}}.dump();
    std::string requests;
    for (int i = 0; i < 3; ++i) requests += "GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n";
    requests += "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: " + std::to_string(job.size()) + "\r\n\r\n" + job;
    requests += "GET /v1/jobs/nosuchjob HTTP/1.1\r\nHost: x\r\n\r\n";
    requests += "GET /readyz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
    const std::string answer = raw_exchange(port_, requests);
    std::vector<int> statuses;
    for (size_t at = answer.find("HTTP/1.1 "); at != std::string::npos; at = answer.find("HTTP/1.1 ", at + 1))
        statuses.push_back(std::stoi(answer.substr(at + 9, 3)));
    EXPECT_EQ(statuses, (std::vector<int>{200, 200, 200, 202, 404, 200})) << answer;
    auto jobs = client_->Get("/v1/jobs");
    ASSERT_TRUE(jobs);
    EXPECT_EQ(json::parse(jobs->body)["jobs"].size(), 1u) << "the pipelined POST was not run once";
}

// A texture that declares 16384 × 16384 texels in a 1.4 MB file is refused from its header,
// before a byte of it is decoded; the answer names the budget.
TEST_F(Hostile, TextureBombsAreRefusedFromTheirHeader) {
    start();
    // A PNG signature and an IHDR chunk are all stb_image reads for the size.
    std::string png("\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR\0\0\x40\0\0\0\x40\0\x08\x06\0\0\0\0\0\0\0", 33);
    png += std::string("\0\0\0\0IEND\xae\x42\x60\x82", 12);
    static const char* b64 = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string encoded;
    for (size_t i = 0; i < png.size(); i += 3) {
        const uint32_t v = uint32_t(uint8_t(png[i])) << 16 | (i + 1 < png.size() ? uint32_t(uint8_t(png[i + 1])) << 8 : 0) |
                           (i + 2 < png.size() ? uint32_t(uint8_t(png[i + 2])) : 0);
        encoded += b64[v >> 18 & 63];
        encoded += b64[v >> 12 & 63];
        encoded += i + 1 < png.size() ? b64[v >> 6 & 63] : '=';
        encoded += i + 2 < png.size() ? b64[v & 63] : '=';
    }
    const std::string gltf =
        R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],)"
        R"("meshes":[{"primitives":[{"attributes":{"POSITION":0,"TEXCOORD_0":1},"material":0}]}],)"
        R"("materials":[{"pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}],"textures":[{"source":0}],)"
        R"("images":[{"uri":"data:image/png;base64,)" + encoded + R"("}],)"
        R"("buffers":[{"byteLength":60,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/"}],)"
        R"("bufferViews":[{"buffer":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":24}],)"
        R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},)"
        R"({"bufferView":1,"componentType":5126,"count":3,"type":"VEC2"}]})";
    const std::string answer = raw_exchange(port_, post("/v1/scenes?name=bomb.gltf", "application/octet-stream", gltf));
    EXPECT_EQ(status_of(answer), 422) << answer.substr(0, 400);
    EXPECT_NE(answer.find("16384x16384"), std::string::npos) << answer.substr(0, 400);
    EXPECT_NE(answer.find("texture budget"), std::string::npos) << answer.substr(0, 400);
    expect_alive();
}

}  // namespace
}  // namespace tessera::server
