// The web page served from the binary: its files, their headers, and no token needed for them.
#include <gtest/gtest.h>

#include <regex>

#include "tests/server/server_fixture.h"
#include "server/http/web_assets.h"

namespace tessera::server {
namespace {

TEST_F(Server, TheWebPageIsServedFromTheBinary) {
    limits_.auth = BearerAuth({"0123456789abcdef0123"});
    start();
    auto index = client_->Get("/");
    ASSERT_TRUE(index);
    ASSERT_EQ(index->status, 200) << "a page without a token: it holds no data";
    EXPECT_EQ(index->get_header_value("Content-Type"), "text/html; charset=utf-8");
    EXPECT_NE(index->body.find("<html"), std::string::npos);
    const std::string csp = index->get_header_value("Content-Security-Policy");
    EXPECT_NE(csp.find("default-src 'self'"), std::string::npos) << "nothing from other hosts";
    EXPECT_EQ(index->get_header_value("X-Content-Type-Options"), "nosniff");
    // Every compiled-in file, byte for byte, with its type; every script the page loads exists.
    size_t files = 0;
    for (const WebAsset* a = web_assets(); a->name; ++a, ++files) {
        auto r = client_->Get(std::string("/ui/") + a->name);
        ASSERT_TRUE(r);
        EXPECT_EQ(r->status, 200) << a->name;
        EXPECT_EQ(r->body, std::string(reinterpret_cast<const char*>(a->data), a->size)) << a->name;
        const std::string name = a->name;
        if (name.size() > 3 && name.substr(name.size() - 3) == ".js") {
            EXPECT_EQ(r->get_header_value("Content-Type"), "text/javascript; charset=utf-8");
        }
        if (name.size() > 4 && name.substr(name.size() - 4) == ".css") {
            EXPECT_EQ(r->get_header_value("Content-Type"), "text/css; charset=utf-8");
        }
    }
    EXPECT_GE(files, 3u);
    std::smatch m;
    std::string rest = index->body;
    const std::regex src(R"re((?:src|href)="/ui/([^"]+)")re");
    size_t referenced = 0;
    while (std::regex_search(rest, m, src)) {
        ++referenced;
        auto r = client_->Get("/ui/" + m[1].str());
        ASSERT_TRUE(r);
        EXPECT_EQ(r->status, 200) << m[1];
        rest = m.suffix();
    }
    EXPECT_GE(referenced, 2u) << "the page loads its script and style from /ui/";
    expect_problem(client_->Get("/ui/missing.js"), 404);
    expect_problem(client_->Get("/ui/../server/http_api.cpp"), 404);
    expect_problem(client_->Post("/", "x", "text/plain"), 405);
    // The API behind the page still needs the token.
    expect_problem(client_->Get("/v1/jobs"), 401);
}

}  // namespace
}  // namespace tessera::server
