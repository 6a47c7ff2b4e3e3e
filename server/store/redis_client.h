#pragma once
// A small synchronous Redis client over hiredis: one connection, commands as argument vectors
// (binary-safe), replies as plain values, Lua scripts by SHA with their source as fallback.
// A lost connection is opened again on the next command, so a Redis restart costs the callers
// one failed command each, which they retry. Not thread-safe: one per thread.
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

struct redisContext;

namespace tessera::server {

// redis://[user:password@]host:port/db (also rediss is refused: Debian's hiredis 0.14 has no TLS).
struct RedisUrl {
    std::string host = "127.0.0.1";
    int port = 6379;
    std::string user, password;
    int db = 0;
    // Throws std::invalid_argument naming what is wrong (never echoing the password).
    static RedisUrl parse(const std::string& url);
    // The address for logs and reports: the password never appears.
    std::string redacted() const;
};

struct RedisError : std::runtime_error {
    // `connection`: Redis could not be reached or the connection broke; otherwise Redis
    // answered with an error. `out_of_memory`: Redis refused a write past its maxmemory.
    bool connection = false;
    bool out_of_memory = false;
    RedisError(const std::string& what, bool connection_, bool oom = false)
        : std::runtime_error(what), connection(connection_), out_of_memory(oom) {}
};

struct RedisValue {
    enum Type { nil, integer, string, array, status } type = nil;
    long long number = 0;
    std::string text;
    std::vector<RedisValue> items;

    bool is_nil() const { return type == nil; }
    // The value as an integer: integer replies, or strings holding one.
    long long as_int() const;
};

// A double as the farm's records hold it in Redis: every bit kept (%.17g), so a time or a sum read
// back equals the one written.
std::string redis_number(double v);

// A Lua script, sent once per connection by its source and afterwards by its SHA-1.
struct RedisScript {
    explicit RedisScript(std::string src) : source(std::move(src)) {}
    std::string source;
};

class Redis {
public:
    explicit Redis(RedisUrl url, double timeout_s = 5.0);
    ~Redis();
    Redis(const Redis&) = delete;
    Redis& operator=(const Redis&) = delete;

    // Throws RedisError; an error reply is an exception, not a value.
    RedisValue command(const std::vector<std::string>& args);
    RedisValue eval(const RedisScript& script, const std::vector<std::string>& keys, const std::vector<std::string>& args);
    // Several commands in one round trip; replies in order (error replies are exceptions).
    std::vector<RedisValue> pipeline(const std::vector<std::vector<std::string>>& commands);
    const RedisUrl& url() const { return url_; }

private:
    void connect();
    void drop();
    RedisUrl url_;
    double timeout_s_;
    redisContext* ctx_ = nullptr;
    std::unordered_map<std::string, std::string> shas_;  // source → SHA-1 of the scripts this connection has loaded
};

}  // namespace tessera::server
