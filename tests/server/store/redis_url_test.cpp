#include "server/store/redis_client.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace tessera::server {
namespace {

TEST(RedisUrl, ParsesEveryPart) {
    const RedisUrl u = RedisUrl::parse("redis://alice:s3cret@cache.example:6380/3");
    EXPECT_EQ(u.user, "alice");
    EXPECT_EQ(u.password, "s3cret");
    EXPECT_EQ(u.host, "cache.example");
    EXPECT_EQ(u.port, 6380);
    EXPECT_EQ(u.db, 3);
    const RedisUrl bare = RedisUrl::parse("redis://10.0.0.5");
    EXPECT_EQ(bare.port, 6379);
    EXPECT_EQ(bare.db, 0);
    EXPECT_TRUE(bare.password.empty());
    EXPECT_EQ(RedisUrl::parse("redis://pw@h:1/").password, "pw");
    const RedisUrl v6 = RedisUrl::parse("redis://[::1]:7000/1");
    EXPECT_EQ(v6.host, "::1");
    EXPECT_EQ(v6.port, 7000);
}

TEST(RedisUrl, CredentialsNeverInTheRedactedForm) {
    const RedisUrl u = RedisUrl::parse("redis://alice:s3cret@h:6380/2");
    EXPECT_EQ(u.redacted(), "redis://alice:***@h:6380/2");
    EXPECT_EQ(u.redacted().find("s3cret"), std::string::npos);
    try {
        RedisUrl::parse("redis://alice:s3cret@h:99999/2");
        FAIL() << "bad port accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_EQ(std::string(e.what()).find("s3cret"), std::string::npos) << e.what();
    }
}

TEST(RedisUrl, RefusesWhatItCannotUse) {
    for (const char* bad : {"http://h:1", "rediss://h:1", "redis://", "redis://h:0", "redis://h:x", "redis://h/16", "redis://h/x"})
        EXPECT_THROW(RedisUrl::parse(bad), std::invalid_argument) << bad;
}

TEST(Redis, UnreachableServerIsAConnectionErrorWithoutThePassword) {
    RedisUrl u = RedisUrl::parse("redis://u:topsecret@127.0.0.1:1/0");
    Redis r(u, 0.5);
    try {
        r.command({"PING"});
        FAIL() << "connected to port 1";
    } catch (const RedisError& e) {
        EXPECT_TRUE(e.connection);
        EXPECT_EQ(std::string(e.what()).find("topsecret"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace tessera::server
