#include "server/store/job_hash.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <map>

namespace tessera::server {

namespace {

// Numbers as Redis holds them; a field that is not one is a record this build cannot read.
template <class T>
T number(const char* field, const std::string& s) {
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(s.c_str(), &end);
    if (s.empty() || *end != '\0' || errno == ERANGE)
        throw StoreError(std::string("job store: field ") + field + " is not a number: '" + s.substr(0, 40) + "'", false);
    return T(v);
}

}  // namespace

const std::vector<JobHashField>& job_hash_fields() {
    static const std::vector<JobHashField> fields = {
        {"id", [](const JobRecord& r) { return r.id; }, [](JobRecord& r, const std::string& v) { r.id = v; }},
        {"state", [](const JobRecord& r) { return std::string(to_string(r.state)); },
         [](JobRecord& r, const std::string& v) {
             if (!parse_job_state(v, r.state)) throw StoreError("job store: job " + r.id + " has a bad state '" + v + "'", false);
         }},
        {"spec", [](const JobRecord& r) { return r.spec_json; }, [](JobRecord& r, const std::string& v) { r.spec_json = v; }},
        {"priority", [](const JobRecord& r) { return std::to_string(r.priority); },
         [](JobRecord& r, const std::string& v) { r.priority = number<int>("priority", v); }},
        {"created_at", [](const JobRecord& r) { return redis_number(r.created_at); },
         [](JobRecord& r, const std::string& v) { r.created_at = number<double>("created_at", v); }},
        {"started_at", [](const JobRecord& r) { return redis_number(r.started_at); },
         [](JobRecord& r, const std::string& v) { r.started_at = number<double>("started_at", v); }},
        {"finished_at", [](const JobRecord& r) { return redis_number(r.finished_at); },
         [](JobRecord& r, const std::string& v) { r.finished_at = number<double>("finished_at", v); }},
        {"error", [](const JobRecord& r) { return r.error; }, [](JobRecord& r, const std::string& v) { r.error = v; }},
        {"report", [](const JobRecord& r) { return r.report_json; }, [](JobRecord& r, const std::string& v) { r.report_json = v; }},
        {"attempts", [](const JobRecord& r) { return std::to_string(r.attempts); },
         [](JobRecord& r, const std::string& v) { r.attempts = number<int>("attempts", v); }},
    };
    return fields;
}

std::vector<std::string> job_hash_arguments(const JobRecord& rec) {
    std::vector<std::string> out;
    for (const JobHashField& f : job_hash_fields()) out.push_back(f.write(rec));
    return out;
}

std::string job_hash_lua_prologue() {
    std::string bind = "local job = {", names = "local job_fields = {";
    size_t i = 0;
    for (const JobHashField& f : job_hash_fields()) {
        bind += std::string(f.name) + " = ARGV[" + std::to_string(++i) + "], ";
        names += std::string("'") + f.name + "', ";
    }
    return bind + "}\n" + names + "}\n";
}

JobRecord job_from_hash(const RedisValue& v) {
    std::map<std::string, const std::string*> by_name;
    for (size_t i = 0; i + 1 < v.items.size(); i += 2) by_name[v.items[i].text] = &v.items[i + 1].text;
    JobRecord r;
    // The id first: the other fields' errors name the job.
    if (auto it = by_name.find("id"); it != by_name.end()) r.id = *it->second;
    for (const JobHashField& f : job_hash_fields())
        if (auto it = by_name.find(f.name); it != by_name.end()) f.read(r, *it->second);
    if (auto it = by_name.find("seq"); it != by_name.end()) r.seq = number<int64_t>("seq", *it->second);
    return r;
}

}  // namespace tessera::server
