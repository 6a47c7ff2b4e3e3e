#pragma once
// Job records for the store tests: ids from numbers, and a record with a recognisable spec.
#include <cstdio>
#include <string>

#include "server/store/job_store.h"

namespace tessera::server::test {

inline std::string hex_id(uint64_t n) {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(n));
    return buf;
}

inline JobRecord make_job(uint64_t n, int priority = 0) {
    JobRecord r;
    r.id = hex_id(n);
    r.spec_json = R"({"scene":"builtin:cornell_box","n":)" + std::to_string(n) + "}";
    r.priority = priority;
    r.created_at = 1700000000.0 + static_cast<double>(n);
    return r;
}

}  // namespace tessera::server::test
