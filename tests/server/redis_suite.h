#pragma once
// A test suite's own redis-server (Debian's binary, a random loopback port, a temporary
// directory): started once for the suite. Its tests fail where CI requires Redis
// (TESSERA_REQUIRE_REDIS=1) and are skipped elsewhere, saying what goes untested.
#include <gtest/gtest.h>

#include <string>

#include "server/store/redis_process.h"

namespace tessera::server::test {

// `Durable`: the AOF written and fsynced on every write (a store's contract); otherwise no AOF.
template <class Base = ::testing::Test, bool Durable = false>
class WithSuiteRedis : public Base {
protected:
    static void SetUpTestSuite() {
        redis_ = new RedisServer(Durable ? "always" : "off");
        if (!redis_->available() || !redis_->start()) {
            delete redis_;
            redis_ = nullptr;
        }
    }
    static void TearDownTestSuite() {
        delete redis_;
        redis_ = nullptr;
    }
    // For SetUp: true when the suite has its server (emptied); otherwise the test is failed or
    // skipped, and SetUp returns at once.
    bool redis_ready(const std::string& untested) {
        if (!redis_) {
            // Recorded from SetUp, a fatal failure or a skip keeps the test body from running.
            const bool fail = redis_required();
            GTEST_MESSAGE_AT_(__FILE__, __LINE__,
                              fail ? "redis-server did not start (TESSERA_REQUIRE_REDIS=1)"
                                   : ("redis-server is not installed (apt-get install redis-server): " + untested).c_str(),
                              fail ? ::testing::TestPartResult::kFatalFailure : ::testing::TestPartResult::kSkip);
            return false;
        }
        Redis(redis_->url()).command({"FLUSHALL"});
        return true;
    }
    static inline RedisServer* redis_ = nullptr;
};

}  // namespace tessera::server::test
