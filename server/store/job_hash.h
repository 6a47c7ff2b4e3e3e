#pragma once
// A job's record as a farm keeps it, the hash tessera:job:<id>, declared once: each field's name
// in Redis with how it is written and read. The insert script's arguments and its Lua names, the
// decoding of HGETALL, and the test that reads them all back come from this table; a field added
// here reaches all of them. (The render's own fields, written by the farm's scripts as it runs,
// are farm/farm_records.h's.)
#include <string>
#include <vector>

#include "server/store/job_store.h"
#include "server/store/redis_client.h"

namespace tessera::server {

struct JobHashField {
    const char* name;
    std::string (*write)(const JobRecord&);
    // Throws StoreError for a value this build cannot read (a record of another version).
    void (*read)(JobRecord&, const std::string&);
};

// Every field but `seq`, which the insert script assigns.
const std::vector<JobHashField>& job_hash_fields();

// The values in the table's order: the insert script's ARGV.
std::vector<std::string> job_hash_arguments(const JobRecord& rec);

// Lua binding ARGV to the table's names: `local job = {id = ARGV[1], state = ARGV[2], ...}` and
// `local job_fields = {'id', 'state', ...}` (for HSET in the same order).
std::string job_hash_lua_prologue();

// A record from HGETALL's answer (name, value, name, value, ...); fields it lacks keep their
// defaults. Throws StoreError for a value it cannot read.
JobRecord job_from_hash(const RedisValue& hgetall);

}  // namespace tessera::server
