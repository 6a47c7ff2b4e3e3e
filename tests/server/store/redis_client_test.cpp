// The Redis client (server/store/redis_client.h) against a real redis-server started for the
// suite: held to its reply types, its pipelines answering in order and staying in step after an
// error reply, its scripts sent by source once and by SHA after (and again once Redis forgets
// them), its errors telling a refusal from a lost connection and an out-of-memory refusal from
// the rest, and its promise that a restart of Redis costs a caller at most one failed command.
// RedisUrl::parse is redis_url_test.cpp's.
#include "server/store/redis_client.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <bit>
#include <cfloat>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "tests/server/raw_socket.h"
#include "tests/server/redis_suite.h"

namespace tessera::server {
namespace {

using namespace std::string_literals;

class RedisClientTest : public test::WithSuiteRedis<> {
protected:
    void SetUp() override { redis_ready("the Redis client is not tested"); }
    // Whatever a test left behind, the next test (and the next suite on this server) gets a
    // running server without a memory limit.
    void TearDown() override {
        if (!redis_) return;
        if (stopped_) redis_->start();
        stopped_ = false;
        if (memory_limited_) unlimit_memory();
    }

    void stop_server() {
        stopped_ = true;
        redis_->stop();
    }
    bool start_server() {
        stopped_ = false;
        return redis_->start();
    }

    // Redis refuses every write from here on (noeviction, and it always holds more than a byte).
    void limit_memory() {
        Redis admin(redis_->url());
        saved_maxmemory_ = admin.command({"CONFIG", "GET", "maxmemory"}).items.at(1).text;
        saved_policy_ = admin.command({"CONFIG", "GET", "maxmemory-policy"}).items.at(1).text;
        memory_limited_ = true;
        admin.command({"CONFIG", "SET", "maxmemory-policy", "noeviction"});
        admin.command({"CONFIG", "SET", "maxmemory", "1"});
    }
    void unlimit_memory() {
        Redis admin(redis_->url());
        admin.command({"CONFIG", "SET", "maxmemory", saved_maxmemory_});
        admin.command({"CONFIG", "SET", "maxmemory-policy", saved_policy_});
        memory_limited_ = false;
    }

    // How many times the server has run SCRIPT LOAD since the last CONFIG RESETSTAT.
    static long long script_loads(Redis& r) {
        const std::string info = r.command({"INFO", "commandstats"}).text;
        // Redis 7 counts subcommands apart ("script|load"); older ones count SCRIPT as a whole.
        for (const std::string& name : {"cmdstat_script|load:calls="s, "cmdstat_script:calls="s}) {
            const size_t at = info.find(name);
            if (at != std::string::npos) return std::atoll(info.c_str() + at + name.size());
        }
        return 0;
    }

    bool stopped_ = false;
    bool memory_limited_ = false;
    std::string saved_maxmemory_, saved_policy_;
};

TEST_F(RedisClientTest, CommandAnswersEachReplyType) {
    Redis r(redis_->url());

    const RedisValue ok = r.command({"SET", "k", "v"});
    EXPECT_EQ(ok.type, RedisValue::status);
    EXPECT_EQ(ok.text, "OK");
    EXPECT_FALSE(ok.is_nil());
    const RedisValue pong = r.command({"PING"});
    EXPECT_EQ(pong.type, RedisValue::status);
    EXPECT_EQ(pong.text, "PONG");

    const RedisValue n = r.command({"INCRBY", "n", "-42"});
    EXPECT_EQ(n.type, RedisValue::integer);
    EXPECT_EQ(n.number, -42);
    EXPECT_EQ(n.as_int(), -42);

    const RedisValue s = r.command({"GET", "k"});
    EXPECT_EQ(s.type, RedisValue::string);
    EXPECT_EQ(s.text, "v");

    const RedisValue missing = r.command({"GET", "missing"});
    EXPECT_EQ(missing.type, RedisValue::nil);
    EXPECT_TRUE(missing.is_nil());

    // An empty string is a value, not a missing one.
    r.command({"SET", "empty", ""});
    const RedisValue empty = r.command({"GET", "empty"});
    EXPECT_EQ(empty.type, RedisValue::string);
    EXPECT_FALSE(empty.is_nil());
    EXPECT_EQ(empty.text, "");

    const RedisValue arr = r.command({"MGET", "k", "missing", "n"});
    ASSERT_EQ(arr.type, RedisValue::array);
    ASSERT_EQ(arr.items.size(), 3u);
    EXPECT_EQ(arr.items[0].type, RedisValue::string);
    EXPECT_EQ(arr.items[0].text, "v");
    EXPECT_TRUE(arr.items[1].is_nil()) << "a nil inside an array stays nil";
    EXPECT_EQ(arr.items[2].type, RedisValue::string);
    EXPECT_EQ(arr.items[2].as_int(), -42) << "a string holding an integer reads as one";

    const RedisValue none = r.command({"LRANGE", "no-list", "0", "-1"});
    EXPECT_EQ(none.type, RedisValue::array) << "an empty array is not nil";
    EXPECT_TRUE(none.items.empty());

    // Arrays nest (a stream entry is [id, [field, value, ...]]).
    const std::string id = r.command({"XADD", "stream", "*", "f", "1"}).text;
    const RedisValue entries = r.command({"XRANGE", "stream", "-", "+"});
    ASSERT_EQ(entries.items.size(), 1u);
    ASSERT_EQ(entries.items[0].items.size(), 2u);
    EXPECT_EQ(entries.items[0].items[0].text, id);
    ASSERT_EQ(entries.items[0].items[1].type, RedisValue::array);
    ASSERT_EQ(entries.items[0].items[1].items.size(), 2u);
    EXPECT_EQ(entries.items[0].items[1].items[0].text, "f");
    EXPECT_EQ(entries.items[0].items[1].items[1].as_int(), 1);
}

TEST_F(RedisClientTest, AsIntReadsIntegersAndRefusesEverythingElse) {
    Redis r(redis_->url());
    EXPECT_EQ(r.command({"INCRBY", "big", "9000000000"}).as_int(), 9000000000LL) << "past 32 bits";
    EXPECT_EQ(r.command({"GET", "big"}).as_int(), 9000000000LL);
    r.command({"SET", "neg", "-17"});
    EXPECT_EQ(r.command({"GET", "neg"}).as_int(), -17);

    r.command({"SET", "text", "12abc"});
    r.command({"SET", "blank", ""});
    r.command({"RPUSH", "list", "1"});
    const std::vector<std::pair<const char*, RedisValue>> not_integers = {
        {"a status", r.command({"PING"})},
        {"nil", r.command({"GET", "missing"})},
        {"a string with a tail", r.command({"GET", "text"})},
        {"an empty string", r.command({"GET", "blank"})},
        {"an array", r.command({"LRANGE", "list", "0", "-1"})},
    };
    for (const auto& [what, v] : not_integers) {
        try {
            (void)v.as_int();
            ADD_FAILURE() << what << " read as an integer";
        } catch (const RedisError& e) {
            EXPECT_FALSE(e.connection) << what;
        }
    }
}

TEST_F(RedisClientTest, ArgumentsAndRepliesAreBinarySafe) {
    Redis r(redis_->url());
    const std::string key = "k\0ey\r\n"s;
    const std::string value = "a\0b\r\n$3\r\n*1\xff"s;
    EXPECT_EQ(r.command({"SET", key, value}).text, "OK");
    EXPECT_EQ(r.command({"GET", key}).text, value);
    EXPECT_EQ(r.command({"STRLEN", key}).as_int(), static_cast<long long>(value.size()));
    EXPECT_TRUE(r.command({"GET", "k"}).is_nil()) << "the key was not cut at its NUL";

    const RedisScript echo{"return ARGV[1]"};
    EXPECT_EQ(r.eval(echo, {}, {value}).text, value);
}

TEST_F(RedisClientTest, PipelineAnswersInOrder) {
    Redis r(redis_->url());
    const std::vector<RedisValue> out = r.pipeline({{"SET", "a", "1"},
                                                    {"INCR", "a"},
                                                    {"GET", "a"},
                                                    {"GET", "missing"},
                                                    {"RPUSH", "l", "x", "y"},
                                                    {"LRANGE", "l", "0", "-1"}});
    ASSERT_EQ(out.size(), 6u);
    EXPECT_EQ(out[0].type, RedisValue::status);
    EXPECT_EQ(out[0].text, "OK");
    EXPECT_EQ(out[1].type, RedisValue::integer);
    EXPECT_EQ(out[1].number, 2);
    EXPECT_EQ(out[2].text, "2");
    EXPECT_TRUE(out[3].is_nil());
    EXPECT_EQ(out[4].number, 2);
    ASSERT_EQ(out[5].items.size(), 2u);
    EXPECT_EQ(out[5].items[0].text, "x");
    EXPECT_EQ(out[5].items[1].text, "y");

    // Enough commands that the replies cannot all come back in one read.
    std::vector<std::vector<std::string>> many;
    for (int i = 0; i < 2000; ++i) many.push_back({"INCR", "counter"});
    const std::vector<RedisValue> counts = r.pipeline(many);
    ASSERT_EQ(counts.size(), many.size());
    for (size_t i = 0; i < counts.size(); ++i) ASSERT_EQ(counts[i].as_int(), static_cast<long long>(i + 1)) << i;

    EXPECT_TRUE(r.pipeline({}).empty());
}

TEST_F(RedisClientTest, AnErrorReplyIsARefusalNotAConnectionFailure) {
    Redis r(redis_->url());
    r.command({"SET", "text", "x"});
    try {
        r.command({"INCR", "text"});
        ADD_FAILURE() << "INCR of a non-number answered";
    } catch (const RedisError& e) {
        EXPECT_FALSE(e.connection) << e.what();
        EXPECT_FALSE(e.out_of_memory) << e.what();
        EXPECT_NE(std::string(e.what()).find("not an integer"), std::string::npos) << "Redis's own words: " << e.what();
    }
    try {
        r.command({"NO-SUCH-COMMAND"});
        ADD_FAILURE() << "an unknown command answered";
    } catch (const RedisError& e) {
        EXPECT_FALSE(e.connection) << e.what();
    }
    EXPECT_EQ(r.command({"ECHO", "still here"}).text, "still here") << "the connection outlives a refusal";
}

TEST_F(RedisClientTest, APipelineWithAnErrorReadsEveryReplyAndStaysInStep) {
    Redis r(redis_->url());
    r.command({"SET", "text", "x"});
    try {
        r.pipeline({{"SET", "a", "1"}, {"INCR", "text"}, {"SET", "b", "2"}, {"GET", "a"}});
        ADD_FAILURE() << "a pipeline with an error reply answered";
    } catch (const RedisError& e) {
        EXPECT_FALSE(e.connection) << e.what();
        EXPECT_NE(std::string(e.what()).find("not an integer"), std::string::npos) << e.what();
    }
    // Redis ran the commands after the failing one; their replies must not be taken for the
    // answers to the next commands.
    EXPECT_EQ(r.command({"GET", "b"}).text, "2");
    EXPECT_EQ(r.command({"ECHO", "next"}).text, "next");
    const std::vector<RedisValue> out = r.pipeline({{"ECHO", "one"}, {"ECHO", "two"}});
    ASSERT_EQ(out.size(), 2u);
    EXPECT_EQ(out[0].text, "one");
    EXPECT_EQ(out[1].text, "two");
}

TEST_F(RedisClientTest, AnErrorInsideExecsAnswerIsAnError) {
    Redis r(redis_->url());
    EXPECT_EQ(r.command({"MULTI"}).text, "OK");
    EXPECT_EQ(r.command({"SET", "t", "x"}).text, "QUEUED");
    EXPECT_EQ(r.command({"INCR", "t"}).text, "QUEUED");
    try {
        r.command({"EXEC"});
        ADD_FAILURE() << "EXEC's array hid the INCR's error";
    } catch (const RedisError& e) {
        EXPECT_FALSE(e.connection) << e.what();
        EXPECT_NE(std::string(e.what()).find("not an integer"), std::string::npos) << e.what();
    }
    EXPECT_EQ(r.command({"GET", "t"}).text, "x") << "Redis applied the transaction's other commands";
    EXPECT_EQ(r.command({"ECHO", "after"}).text, "after");
}

TEST_F(RedisClientTest, AScriptIsSentBySourceOnceThenBySha) {
    Redis r(redis_->url());
    const RedisScript script{"return {ARGV[1], redis.call('INCR', KEYS[1])}"};
    r.command({"SCRIPT", "FLUSH"});
    r.command({"CONFIG", "RESETSTAT"});
    for (long long i = 1; i <= 3; ++i) {
        const RedisValue v = r.eval(script, {"runs"}, {"tag"});
        ASSERT_EQ(v.type, RedisValue::array);
        ASSERT_EQ(v.items.size(), 2u);
        EXPECT_EQ(v.items[0].text, "tag");
        EXPECT_EQ(v.items[1].as_int(), i) << "the script ran once per eval";
    }
    EXPECT_EQ(script_loads(r), 1) << "the source went over once";
    EXPECT_EQ(r.command({"GET", "runs"}).as_int(), 3);
}

TEST_F(RedisClientTest, AScriptRunsAgainAfterRedisForgetsIt) {
    Redis r(redis_->url());
    const RedisScript script{"return redis.call('INCR', KEYS[1])"};
    ASSERT_EQ(r.eval(script, {"runs"}, {}).as_int(), 1);
    r.command({"CONFIG", "RESETSTAT"});

    // Another client empties the script cache: the SHA this client remembers names nothing.
    Redis(redis_->url()).command({"SCRIPT", "FLUSH"});
    EXPECT_EQ(r.eval(script, {"runs"}, {}).as_int(), 2) << "ran exactly once: the refused EVALSHA did nothing";
    EXPECT_EQ(script_loads(r), 1) << "the source was sent again";
    EXPECT_EQ(r.eval(script, {"runs"}, {}).as_int(), 3);
    EXPECT_EQ(script_loads(r), 1) << "and then the SHA was used again";
}

TEST_F(RedisClientTest, ScriptsKeepTheirOwnSha) {
    Redis r(redis_->url());
    const RedisScript a{"return 'a'"}, b{"return 'b'"};
    for (int round = 0; round < 2; ++round) {
        EXPECT_EQ(r.eval(a, {}, {}).text, "a") << round;
        EXPECT_EQ(r.eval(b, {}, {}).text, "b") << round;
    }
    // One script object on two connections: each loads it for itself.
    Redis other(redis_->url());
    EXPECT_EQ(other.eval(b, {}, {}).text, "b");
    EXPECT_EQ(r.eval(b, {}, {}).text, "b");
}

TEST_F(RedisClientTest, AScriptMadeWhereAnotherWasIsItselfAndAnErrorNamingNoscriptRunsOnce) {
    Redis r(redis_->url());
    // Scripts are known by their source: one made at the address of a destroyed one runs itself.
    std::optional<RedisScript> s;
    s.emplace("return 'first'");
    EXPECT_EQ(r.eval(*s, {}, {}).text, "first");
    s.reset();
    s.emplace("return 'second'");
    EXPECT_EQ(r.eval(*s, {}, {}).text, "second");
    // A script's own error that mentions NOSCRIPT is its error, not Redis forgetting it.
    const RedisScript counted("redis.call('INCR', KEYS[1]) return redis.error_reply('mine: NOSCRIPT here')");
    r.eval(RedisScript("return 1"), {}, {});  // the connection knows scripts; this one is new
    EXPECT_THROW(r.eval(counted, {"tessera:test:noscript"}, {}), RedisError);
    EXPECT_THROW(r.eval(counted, {"tessera:test:noscript"}, {}), RedisError);
    EXPECT_EQ(r.command({"GET", "tessera:test:noscript"}).text, "2") << "each call ran the script once";
}

TEST_F(RedisClientTest, AScriptsErrorIsARefusalAndTheScriptIsNotRunAgain) {
    Redis r(redis_->url());
    const RedisScript fails{"redis.call('INCR', KEYS[1]) return redis.error_reply('boom')"};
    // The second eval goes by SHA: an error that is not NOSCRIPT must not send the source and
    // run the script a second time.
    for (long long i = 1; i <= 2; ++i) {
        try {
            r.eval(fails, {"n"}, {});
            ADD_FAILURE() << "a failing script answered";
        } catch (const RedisError& e) {
            EXPECT_FALSE(e.connection) << e.what();
            EXPECT_NE(std::string(e.what()).find("boom"), std::string::npos) << e.what();
        }
        EXPECT_EQ(r.command({"GET", "n"}).as_int(), i);
    }
    // An error in a script's array answer is an error too.
    const RedisScript nested{"return {1, redis.error_reply('inner failure')}"};
    try {
        r.eval(nested, {}, {});
        ADD_FAILURE() << "an error inside a script's array was returned as a value";
    } catch (const RedisError& e) {
        EXPECT_FALSE(e.connection) << e.what();
        EXPECT_NE(std::string(e.what()).find("inner failure"), std::string::npos) << e.what();
    }
    EXPECT_EQ(r.command({"ECHO", "after"}).text, "after");
}

TEST_F(RedisClientTest, AnAddressNothingListensOnIsAConnectionFailure) {
    RefusingPort closed;
    ASSERT_GT(closed.port(), 0);
    RedisUrl u = redis_->url();
    u.port = closed.port();
    Redis r(u, 2.0);
    for (int attempt = 0; attempt < 2; ++attempt) {
        try {
            r.command({"PING"});
            ADD_FAILURE() << "a command answered from a port nothing listens on";
        } catch (const RedisError& e) {
            EXPECT_TRUE(e.connection) << e.what();
            EXPECT_FALSE(e.out_of_memory);
            EXPECT_NE(std::string(e.what()).find("127.0.0.1:" + std::to_string(closed.port())), std::string::npos)
                << "the message names the address: " << e.what();
        }
    }
    const RedisScript script{"return 1"};
    try {
        r.eval(script, {}, {});
        ADD_FAILURE() << "eval answered from a port nothing listens on";
    } catch (const RedisError& e) {
        EXPECT_TRUE(e.connection) << e.what();
    }
}

TEST_F(RedisClientTest, ARefusedAuthIsARefusalThatNeverQuotesThePassword) {
    RedisUrl u = redis_->url();
    u.password = "pw-that-must-not-leak-7f3a";  // the suite's server has none configured
    Redis r(u);
    try {
        r.command({"PING"});
        ADD_FAILURE() << "AUTH against a server without a password succeeded";
    } catch (const RedisError& e) {
        EXPECT_FALSE(e.connection) << "Redis answered; it refused: " << e.what();
        EXPECT_EQ(std::string(e.what()).find(u.password), std::string::npos) << e.what();
    }
}

TEST_F(RedisClientTest, TheUrlsDatabaseIsSelected) {
    RedisUrl u = redis_->url();
    u.db = 3;
    Redis three(u);
    Redis zero(redis_->url());
    three.command({"SET", "where", "three"});
    EXPECT_TRUE(zero.command({"GET", "where"}).is_nil());
    EXPECT_EQ(Redis(u).command({"GET", "where"}).text, "three");
}

TEST_F(RedisClientTest, AReplySlowerThanTheTimeoutIsAConnectionFailureAndTheNextCommandReconnects) {
    Redis r(redis_->url(), 1.0);
    // BLPOP with no timeout on an empty list never answers: the client's own timeout must end it.
    try {
        r.command({"BLPOP", "never-filled", "0"});
        ADD_FAILURE() << "BLPOP on an empty list answered";
    } catch (const RedisError& e) {
        EXPECT_TRUE(e.connection) << e.what();
    }
    // A late answer to the BLPOP must not be read as this command's.
    EXPECT_EQ(r.command({"ECHO", "after"}).text, "after");
}

TEST_F(RedisClientTest, AWritePastMaxmemoryIsOutOfMemory) {
    Redis r(redis_->url());
    r.command({"SET", "text", "x"});
    limit_memory();

    try {
        r.command({"SET", "k", "v"});
        ADD_FAILURE() << "a write past maxmemory was accepted";
    } catch (const RedisError& e) {
        EXPECT_FALSE(e.connection) << e.what();
        EXPECT_TRUE(e.out_of_memory) << e.what();
    }
    try {
        r.pipeline({{"GET", "text"}, {"RPUSH", "l", "x"}, {"ECHO", "tail"}});
        ADD_FAILURE() << "a pipelined write past maxmemory was accepted";
    } catch (const RedisError& e) {
        EXPECT_FALSE(e.connection) << e.what();
        EXPECT_TRUE(e.out_of_memory) << e.what();
    }
    EXPECT_EQ(r.command({"GET", "text"}).text, "x") << "reads still answer, and the pipeline left the connection in step";
    // A refusal of another kind is not taken for a full Redis (LLEN is a read: it is not refused for memory).
    try {
        r.command({"LLEN", "text"});
        ADD_FAILURE() << "LLEN of a string answered";
    } catch (const RedisError& e) {
        EXPECT_FALSE(e.connection) << e.what();
        EXPECT_FALSE(e.out_of_memory) << e.what();
    }

    unlimit_memory();
    EXPECT_EQ(r.command({"SET", "k", "v"}).text, "OK") << "space came back";
}

TEST_F(RedisClientTest, WhileRedisIsDownCommandsFailAsConnectionFailuresAndRecoverAfter) {
    Redis r(redis_->url(), 2.0);
    ASSERT_EQ(r.command({"PING"}).text, "PONG");
    const RedisScript script{"return 7"};
    ASSERT_EQ(r.eval(script, {}, {}).as_int(), 7);
    const int port = redis_->port();

    stop_server();
    // The first command finds the open connection dead; the next ones cannot connect.
    for (int attempt = 0; attempt < 3; ++attempt) {
        try {
            r.command({"PING"});
            ADD_FAILURE() << "a command answered while Redis was down";
        } catch (const RedisError& e) {
            EXPECT_TRUE(e.connection) << attempt << ": " << e.what();
            EXPECT_FALSE(e.out_of_memory);
        }
    }
    try {
        r.eval(script, {}, {});
        ADD_FAILURE() << "eval answered while Redis was down";
    } catch (const RedisError& e) {
        EXPECT_TRUE(e.connection) << e.what();
    }

    ASSERT_TRUE(start_server());
    if (redis_->port() != port) GTEST_SKIP() << "redis-server came back on another port; the client's address is gone";
    // Every failed command dropped the connection, so this one opens a new one.
    EXPECT_EQ(r.command({"PING"}).text, "PONG");
    EXPECT_EQ(r.eval(script, {}, {}).as_int(), 7) << "the restarted server had forgotten the script";
}

TEST_F(RedisClientTest, ARestartCostsACallerAtMostOneFailedCommand) {
    RedisUrl u = redis_->url();
    u.db = 2;
    Redis r(u, 2.0);
    const RedisScript script{"return redis.call('INCR', KEYS[1])"};
    ASSERT_EQ(r.eval(script, {"before"}, {}).as_int(), 1);
    const int port = redis_->port();

    stop_server();
    ASSERT_TRUE(start_server());
    if (redis_->port() != port) GTEST_SKIP() << "redis-server came back on another port; the client's address is gone";

    // The client still holds the connection to the server that went away.
    int failed = 0;
    std::optional<RedisValue> answer;
    for (int attempt = 0; attempt < 2 && !answer; ++attempt) {
        try {
            answer = r.command({"SET", "after", "1"});
        } catch (const RedisError& e) {
            ++failed;
            EXPECT_TRUE(e.connection) << e.what();
        }
    }
    ASSERT_TRUE(answer.has_value()) << "the second command after the restart failed too";
    EXPECT_EQ(answer->text, "OK");
    EXPECT_LE(failed, 1);
    // The new connection is on the URL's database again.
    EXPECT_EQ(Redis(u).command({"GET", "after"}).text, "1");
    EXPECT_TRUE(Redis(redis_->url()).command({"GET", "after"}).is_nil()) << "written to database 0 after reconnecting";
    EXPECT_EQ(r.eval(script, {"counted"}, {}).as_int(), 1) << "the restarted server had forgotten the script";
}

TEST_F(RedisClientTest, RedisNumberKeepsEveryBit) {
    Redis r(redis_->url());
    for (const double v : {0.0, -0.0, 0.1, 1.0 / 3.0, -2.5, 1700000000.123456789, 1e-310, DBL_MAX, DBL_MIN, 123456789.0}) {
        const std::string text = redis_number(v);
        const double back = std::strtod(text.c_str(), nullptr);
        EXPECT_EQ(std::bit_cast<uint64_t>(back), std::bit_cast<uint64_t>(v)) << text;
        // Read back through Redis the way the farm's records are.
        r.command({"HSET", "numbers", "v", text});
        EXPECT_EQ(std::bit_cast<uint64_t>(std::strtod(r.command({"HGET", "numbers", "v"}).text.c_str(), nullptr)),
                  std::bit_cast<uint64_t>(v))
            << text;
    }
}

}  // namespace
}  // namespace tessera::server
