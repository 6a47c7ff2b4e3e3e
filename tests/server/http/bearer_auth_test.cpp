// Bearer tokens: what counts as the token, how files and the environment are read, and which
// listen addresses are loopback.
#include "server/http/bearer_auth.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

namespace tessera::server {
namespace {

const std::string kToken = "0123456789abcdef0123456789abcdef";

TEST(BearerAuth, OnlyTheWholeTokenIsAllowed) {
    const BearerAuth auth({kToken, "another-token-of-some-length"});
    EXPECT_TRUE(auth.enabled());
    EXPECT_TRUE(auth.allows("Bearer " + kToken));
    EXPECT_TRUE(auth.allows("bearer " + kToken));             // the scheme is case-insensitive
    EXPECT_TRUE(auth.allows("Bearer   another-token-of-some-length "));
    EXPECT_FALSE(auth.allows("Bearer " + kToken.substr(0, 31)));  // a prefix
    EXPECT_FALSE(auth.allows("Bearer " + kToken + "0"));          // longer
    EXPECT_FALSE(auth.allows("Bearer " + std::string(kToken.size(), '0')));
    EXPECT_FALSE(auth.allows("Bearer "));
    EXPECT_FALSE(auth.allows(""));
    EXPECT_FALSE(auth.allows("Basic " + kToken));
    EXPECT_FALSE(auth.allows(kToken));
    EXPECT_FALSE(auth.allows("Bearer" + kToken));
    EXPECT_FALSE(BearerAuth().enabled());
}

TEST(BearerAuth, TokenFilesAndLists) {
    const auto path = std::filesystem::temp_directory_path() / ("tessera_tokens_" + std::to_string(::getpid()));
    std::ofstream(path) << "# the render farm's clients\n\n" << kToken << "  # alice\n  second-token-0123456789\r\n";
    const auto tokens = BearerAuth::read_token_file(path.string());
    ASSERT_EQ(tokens.size(), 2u);
    EXPECT_EQ(tokens[0], kToken);
    EXPECT_EQ(tokens[1], "second-token-0123456789");
    std::ofstream(path) << "short\n";
    try {
        BearerAuth::read_token_file(path.string());
        ADD_FAILURE() << "a 5-character token was taken";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("line 1"), std::string::npos) << e.what();
        EXPECT_EQ(std::string(e.what()).find("short"), std::string::npos) << "the message must not echo the token";
    }
    std::ofstream(path) << "# nothing\n";
    EXPECT_THROW(BearerAuth::read_token_file(path.string()), std::runtime_error);
    std::filesystem::remove(path);
    EXPECT_THROW(BearerAuth::read_token_file(path.string()), std::runtime_error);

    const auto list = BearerAuth::parse_token_list(" " + kToken + ",second-token-0123456789\n");
    EXPECT_EQ(list.size(), 2u);
    EXPECT_TRUE(BearerAuth::parse_token_list("").empty());
    EXPECT_THROW(BearerAuth::parse_token_list(kToken + ",tiny"), std::runtime_error);
    EXPECT_THROW(BearerAuth::parse_token_list("0123456789abcdef\x7f"), std::runtime_error);
    EXPECT_THROW(BearerAuth::parse_token_list("${TESSERA_TOKENS:-}"), std::runtime_error);  // not expanded
}

TEST(BearerAuth, LoopbackHosts) {
    for (const char* h : {"127.0.0.1", "127.1.2.3", "::1", "localhost"}) EXPECT_TRUE(is_loopback_host(h)) << h;
    for (const char* h : {"0.0.0.0", "::", "192.168.1.2", "10.0.0.1", "example.org", ""}) EXPECT_FALSE(is_loopback_host(h)) << h;
}

}  // namespace
}  // namespace tessera::server
