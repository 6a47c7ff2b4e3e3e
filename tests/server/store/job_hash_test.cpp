// The job hash declared once: every field of a record written by the table comes back through
// it, the insert script's Lua names every field in the arguments' order, and a value this build
// cannot read is a StoreError naming the field, not a zero. (The store's contract test runs the
// script itself against a real redis-server.)
#include "server/store/job_hash.h"

#include <gtest/gtest.h>

#include <set>

namespace tessera::server {
namespace {

RedisValue hash_of(const std::vector<std::pair<std::string, std::string>>& fields) {
    RedisValue v;
    v.type = RedisValue::array;
    for (const auto& [name, value] : fields) {
        RedisValue n, x;
        n.type = x.type = RedisValue::string;
        n.text = name;
        x.text = value;
        v.items.push_back(n);
        v.items.push_back(x);
    }
    return v;
}

JobRecord full_record() {
    JobRecord r;
    r.id = "0123456789abcdef";
    r.state = JobState::failed;
    r.spec_json = R"({"scene":"builtin:cornell_box","spp":7})";
    r.priority = -3;
    r.seq = 41;
    r.created_at = 1790000000.123456789;
    r.started_at = 1790000001.5;
    r.finished_at = 1790000002.25;
    r.error = "scene: no buffer 3\nline two";
    r.report_json = R"({"ok":false})";
    r.attempts = 2;
    return r;
}

TEST(JobHash, EveryFieldComesBackThroughTheTable) {
    const JobRecord r = full_record();
    const auto args = job_hash_arguments(r);
    ASSERT_EQ(args.size(), job_hash_fields().size());
    std::vector<std::pair<std::string, std::string>> stored = {{"seq", std::to_string(r.seq)}};
    for (size_t i = 0; i < args.size(); ++i) stored.push_back({job_hash_fields()[i].name, args[i]});
    const JobRecord back = job_from_hash(hash_of(stored));
    EXPECT_EQ(back.id, r.id);
    EXPECT_EQ(back.state, r.state);
    EXPECT_EQ(back.spec_json, r.spec_json);
    EXPECT_EQ(back.priority, r.priority);
    EXPECT_EQ(back.seq, r.seq);
    EXPECT_EQ(back.created_at, r.created_at) << "times keep every bit (%.17g)";
    EXPECT_EQ(back.started_at, r.started_at);
    EXPECT_EQ(back.finished_at, r.finished_at);
    EXPECT_EQ(back.error, r.error);
    EXPECT_EQ(back.report_json, r.report_json);
    EXPECT_EQ(back.attempts, r.attempts);
}

TEST(JobHash, TheScriptNamesEveryFieldInTheArgumentsOrder) {
    const std::string lua = job_hash_lua_prologue();
    std::set<std::string> names;
    for (size_t i = 0; i < job_hash_fields().size(); ++i) {
        const std::string name = job_hash_fields()[i].name;
        EXPECT_TRUE(names.insert(name).second) << name << " twice";
        EXPECT_NE(lua.find(name + " = ARGV[" + std::to_string(i + 1) + "]"), std::string::npos) << lua;
        EXPECT_NE(lua.find("'" + name + "'"), std::string::npos) << lua;
    }
    EXPECT_FALSE(names.count("seq")) << "the script assigns seq";
}

TEST(JobHash, AValueThisBuildCannotReadIsAnError) {
    for (const auto& [field, value] : std::vector<std::pair<std::string, std::string>>{
             {"state", "sleeping"}, {"priority", "high"}, {"created_at", "yesterday"}, {"attempts", ""}, {"seq", "1e999"}}) {
        try {
            job_from_hash(hash_of({{"id", "0123456789abcdef"}, {field, value}}));
            ADD_FAILURE() << field << " = '" << value << "' was read";
        } catch (const StoreError& e) {
            EXPECT_NE(std::string(e.what()).find(field == "state" ? "bad state" : field), std::string::npos) << e.what();
        }
    }
    // Fields a record lacks keep their defaults (a record written before a field was added).
    const JobRecord sparse = job_from_hash(hash_of({{"id", "0123456789abcdef"}, {"state", "queued"}}));
    EXPECT_EQ(sparse.attempts, 0);
    EXPECT_EQ(sparse.error, "");
}

}  // namespace
}  // namespace tessera::server
