#include "server/memory_return.h"
#include "server/store/redis_client.h"

#include <hiredis/hiredis.h>

#include <cmath>
#include <cstdio>
#include <mutex>
#include <cstdlib>

namespace tessera::server {

std::string redis_number(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

namespace {

RedisValue convert(const redisReply* r) {
    RedisValue v;
    switch (r->type) {
        case REDIS_REPLY_INTEGER: v.type = RedisValue::integer; v.number = r->integer; break;
        case REDIS_REPLY_STRING: v.type = RedisValue::string; v.text.assign(r->str, r->len); break;
        case REDIS_REPLY_STATUS: v.type = RedisValue::status; v.text.assign(r->str, r->len); break;
        case REDIS_REPLY_ARRAY:
            v.type = RedisValue::array;
            v.items.reserve(r->elements);
            for (size_t i = 0; i < r->elements; ++i) v.items.push_back(convert(r->element[i]));
            break;
        default: v.type = RedisValue::nil;
    }
    return v;
}

// Error replies nested in arrays (EXEC, script results) are errors too.
void throw_if_error(const redisReply* r) {
    if (r->type == REDIS_REPLY_ERROR) {
        const std::string msg(r->str, r->len);
        throw RedisError("redis: " + msg, false, msg.rfind("OOM", 0) == 0);
    }
    if (r->type == REDIS_REPLY_ARRAY)
        for (size_t i = 0; i < r->elements; ++i) throw_if_error(r->element[i]);
}

struct ReplyDeleter {
    void operator()(redisReply* r) const { if (r) freeReplyObject(r); }
};
using Reply = std::unique_ptr<redisReply, ReplyDeleter>;

}  // namespace

long long RedisValue::as_int() const {
    if (type == integer) return number;
    if (type == string || type == status) {
        char* end = nullptr;
        const long long v = std::strtoll(text.c_str(), &end, 10);
        if (end && *end == 0 && !text.empty()) return v;
    }
    throw RedisError("redis: expected an integer reply", false);
}

RedisUrl RedisUrl::parse(const std::string& url) {
    const std::string scheme = "redis://";
    if (url.rfind("rediss://", 0) == 0) throw std::invalid_argument("rediss:// (TLS) is not supported by Debian's hiredis; use redis://");
    if (url.rfind(scheme, 0) != 0) throw std::invalid_argument("the Redis address must look like redis://[user:password@]host:port/db");
    RedisUrl u;
    std::string rest = url.substr(scheme.size());
    const size_t at = rest.rfind('@');
    if (at != std::string::npos) {
        const std::string cred = rest.substr(0, at);
        rest = rest.substr(at + 1);
        const size_t colon = cred.find(':');
        if (colon == std::string::npos) u.password = cred;  // redis://password@host
        else { u.user = cred.substr(0, colon); u.password = cred.substr(colon + 1); }
    }
    const size_t slash = rest.find('/');
    std::string hostport = rest.substr(0, slash);
    if (slash != std::string::npos) {
        const std::string db = rest.substr(slash + 1);
        if (!db.empty()) {
            char* end = nullptr;
            const long v = std::strtol(db.c_str(), &end, 10);
            if (!end || *end || v < 0 || v > 15) throw std::invalid_argument("the Redis database must be a number 0..15, not '" + db + "'");
            u.db = int(v);
        }
    }
    // [v6]:port or host:port; a bare v6 address needs its brackets.
    const size_t close = hostport.rfind(']');
    const size_t colon = hostport.rfind(':');
    if (colon != std::string::npos && (close == std::string::npos || colon > close)) {
        const std::string port = hostport.substr(colon + 1);
        char* end = nullptr;
        const long p = std::strtol(port.c_str(), &end, 10);
        if (port.empty() || !end || *end || p < 1 || p > 65535) throw std::invalid_argument("the Redis port must be 1..65535, not '" + port + "'");
        u.port = int(p);
        hostport = hostport.substr(0, colon);
    }
    if (hostport.size() > 2 && hostport.front() == '[' && hostport.back() == ']') hostport = hostport.substr(1, hostport.size() - 2);
    if (hostport.empty()) throw std::invalid_argument("the Redis address has no host");
    u.host = hostport;
    return u;
}

std::string RedisUrl::redacted() const {
    std::string s = "redis://";
    if (!user.empty() || !password.empty()) s += (user.empty() ? "" : user + ":") + std::string("***@");
    return s + host + ":" + std::to_string(port) + "/" + std::to_string(db);
}

Redis::Redis(RedisUrl url, double timeout_s) : url_(std::move(url)), timeout_s_(timeout_s) { tune_allocator(); }

Redis::~Redis() { drop(); }

void Redis::drop() {
    if (ctx_) redisFree(ctx_);
    ctx_ = nullptr;
}

void Redis::connect() {
    if (ctx_) return;
    timeval tv;
    tv.tv_sec = long(timeout_s_);
    tv.tv_usec = long((timeout_s_ - std::floor(timeout_s_)) * 1e6);
    redisContext* c = redisConnectWithTimeout(url_.host.c_str(), url_.port, tv);
    if (!c || c->err) {
        const std::string why = c ? c->errstr : "out of memory";
        if (c) redisFree(c);
        throw RedisError("redis at " + url_.redacted() + ": cannot connect: " + why, true);
    }
    redisSetTimeout(c, tv);
    ctx_ = c;
    auto setup = [&](std::vector<std::string> args, const char* what) {
        std::vector<const char*> argv;
        std::vector<size_t> lens;
        for (const auto& a : args) { argv.push_back(a.data()); lens.push_back(a.size()); }
        Reply r(static_cast<redisReply*>(redisCommandArgv(ctx_, int(argv.size()), argv.data(), lens.data())));
        if (!r || r->type == REDIS_REPLY_ERROR) {
            // The reply's text may quote the command; never the password.
            const std::string why = r ? std::string(r->str, r->len) : std::string(ctx_->errstr);
            drop();
            throw RedisError("redis at " + url_.redacted() + ": " + what + " refused: " + why, r == nullptr);
        }
    };
    if (!url_.password.empty()) {
        if (url_.user.empty()) setup({"AUTH", url_.password}, "AUTH");
        else setup({"AUTH", url_.user, url_.password}, "AUTH");
    }
    if (url_.db) setup({"SELECT", std::to_string(url_.db)}, "SELECT");
}

RedisValue Redis::command(const std::vector<std::string>& args) {
    return pipeline({args}).front();
}

std::vector<RedisValue> Redis::pipeline(const std::vector<std::vector<std::string>>& commands) {
    connect();
    for (const auto& args : commands) {
        std::vector<const char*> argv;
        std::vector<size_t> lens;
        for (const auto& a : args) { argv.push_back(a.data()); lens.push_back(a.size()); }
        if (redisAppendCommandArgv(ctx_, int(argv.size()), argv.data(), lens.data()) != REDIS_OK) {
            const std::string why = ctx_->errstr;
            drop();
            throw RedisError("redis at " + url_.redacted() + ": " + why, true);
        }
    }
    std::vector<RedisValue> out;
    out.reserve(commands.size());
    std::string error;
    bool oom = false;
    for (size_t i = 0; i < commands.size(); ++i) {
        void* raw = nullptr;
        if (redisGetReply(ctx_, &raw) != REDIS_OK || !raw) {
            const std::string why = ctx_->errstr[0] ? ctx_->errstr : "connection lost";
            drop();
            throw RedisError("redis at " + url_.redacted() + ": " + why, true);
        }
        Reply r(static_cast<redisReply*>(raw));
        try {
            throw_if_error(r.get());
        } catch (const RedisError& e) {
            // Read every reply before throwing, so the connection stays in step.
            if (error.empty()) { error = e.what(); oom = e.out_of_memory; }
            out.emplace_back();
            continue;
        }
        out.push_back(convert(r.get()));
    }
    if (!error.empty()) throw RedisError(error, false, oom);
    return out;
}

RedisValue Redis::eval(const RedisScript& script, const std::vector<std::string>& keys, const std::vector<std::string>& args) {
    auto call = [&](const char* verb, const std::string& body) {
        std::vector<std::string> cmd = {verb, body, std::to_string(keys.size())};
        cmd.insert(cmd.end(), keys.begin(), keys.end());
        cmd.insert(cmd.end(), args.begin(), args.end());
        return command(cmd);
    };
    // By source, not by address: a script destroyed and another made at its address is another script.
    auto known = shas_.find(script.source);
    if (known != shas_.end()) {
        try {
            return call("EVALSHA", known->second);
        } catch (const RedisError& e) {
            // A restarted Redis has forgotten its scripts: send the source again.
            // (Only Redis's own NOSCRIPT reply: a script's error that mentions it must not run it twice.)
            if (e.connection || std::string(e.what()).rfind("redis: NOSCRIPT", 0) != 0) throw;
        }
    }
    const std::string sha = command({"SCRIPT", "LOAD", script.source}).text;
    shas_[script.source] = sha;
    return call("EVALSHA", sha);
}

}  // namespace tessera::server
