#include "server/queue/notifier.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <sys/socket.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <memory>
#include <random>
#include <stdexcept>

#include <httplib.h>
#include <spdlog/spdlog.h>

namespace tessera::server {

namespace {

double unix_now() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }

std::string lower(std::string s) {
    for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

// Addresses that reach the server's own network: loopback, private, link-local, unspecified,
// carrier-grade NAT, unique-local and multicast.
bool is_internal(const sockaddr* sa) {
    if (sa->sa_family == AF_INET) {
        const uint32_t a = ntohl(reinterpret_cast<const sockaddr_in*>(sa)->sin_addr.s_addr);
        auto in = [&](uint32_t net, int bits) { return (a >> (32 - bits)) == (net >> (32 - bits)); };
        return in(0x7f000000, 8) || in(0x0a000000, 8) || in(0xac100000, 12) || in(0xc0a80000, 16) || in(0xa9fe0000, 16) ||
               in(0x00000000, 8) || in(0x64400000, 10) || in(0xe0000000, 4) || in(0xf0000000, 4) || in(0xc6120000, 15) ||
               in(0xc0000000, 24);
    }
    if (sa->sa_family == AF_INET6) {
        const in6_addr& a = reinterpret_cast<const sockaddr_in6*>(sa)->sin6_addr;
        if (IN6_IS_ADDR_LOOPBACK(&a) || IN6_IS_ADDR_UNSPECIFIED(&a) || IN6_IS_ADDR_LINKLOCAL(&a) || IN6_IS_ADDR_MULTICAST(&a)) return true;
        // Only global unicast (2000::/3) reaches outside, and the well-known NAT64 prefix
        // (64:ff9b::/96), judged by the IPv4 address it carries, as 6to4's (2002::/16) is.
        auto v4_at = [&](int at) {
            sockaddr_in v4{};
            v4.sin_family = AF_INET;
            std::memcpy(&v4.sin_addr, &a.s6_addr[at], 4);
            return is_internal(reinterpret_cast<const sockaddr*>(&v4));
        };
        if (IN6_IS_ADDR_V4MAPPED(&a)) return v4_at(12);
        if ((a.s6_addr[0] & 0xe0) != 0x20) {
            static const unsigned char kNat64[12] = {0x00, 0x64, 0xff, 0x9b, 0, 0, 0, 0, 0, 0, 0, 0};  // 64:ff9b::/96
            const bool nat64 = std::memcmp(a.s6_addr, kNat64, 12) == 0;
            return nat64 ? v4_at(12) : true;  // loopback, ULA, site- and link-local, v4-compatible, ...
        }
        if (a.s6_addr[0] == 0x20 && a.s6_addr[1] == 0x02) return v4_at(2);  // 6to4
        return false;
    }
    return true;
}

std::string address_text(const sockaddr* sa) {
    char buf[INET6_ADDRSTRLEN] = {};
    if (sa->sa_family == AF_INET) inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(sa)->sin_addr, buf, sizeof buf);
    else inet_ntop(AF_INET6, &reinterpret_cast<const sockaddr_in6*>(sa)->sin6_addr, buf, sizeof buf);
    return buf;
}

// How an allow entry admits host:port: 0 not, 1 by a wildcard, 2 by naming the host itself.
int admits(const std::string& entry, const HttpTarget& t) {
    std::string host = lower(entry), port = t.https ? "443" : "80";  // no port: the scheme's own
    if (!host.empty() && host.front() == '[') {  // [v6] or [v6]:port
        const size_t close = host.find(']');
        if (close == std::string::npos) return 0;
        if (host.size() > close + 2 && host[close + 1] == ':') port = host.substr(close + 2);
        host = host.substr(1, close - 1);
    } else if (const size_t c = host.rfind(':'); c != std::string::npos) {
        port = host.substr(c + 1);
        host = host.substr(0, c);
    }
    if (port != "*" && port != std::to_string(t.port)) return 0;
    if (host == t.host) return 2;
    if (host == "*") return 1;
    if (host.rfind("*.", 0) == 0) {
        const std::string suffix = host.substr(1);  // ".domain"
        return t.host.size() > suffix.size() && t.host.compare(t.host.size() - suffix.size(), suffix.size(), suffix) == 0 ? 1 : 0;
    }
    return 0;
}

// Stops a client's request in flight (httplib shuts its socket down) when it outlives `limit`.
class AttemptDeadline {
public:
    AttemptDeadline(httplib::ClientImpl& client, std::chrono::microseconds limit)
        : thread_([this, &client, limit] {
              std::unique_lock<std::mutex> lock(mutex_);
              if (!cv_.wait_for(lock, limit, [this] { return done_; })) {
                  passed_ = true;
                  client.stop();
              }
          }) {}
    ~AttemptDeadline() {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            done_ = true;
        }
        cv_.notify_all();
        thread_.join();
    }
    bool passed() {
        std::lock_guard<std::mutex> lock(mutex_);
        return passed_;
    }

private:
    std::mutex mutex_;
    std::condition_variable cv_;
    bool done_ = false, passed_ = false;
    std::thread thread_;  // last: started once the rest is made
};

std::string new_delivery_id() {
    static thread_local std::mt19937_64 rng{std::random_device{}()};
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(rng()));
    return buf;
}

}  // namespace

HttpTarget parse_http_url(const std::string& url) {
    HttpTarget t;
    t.https = url.rfind("https://", 0) == 0;
    if (!t.https && url.rfind("http://", 0) != 0) throw std::invalid_argument("not an http:// or https:// URL");
    if (t.https) t.port = 443;
    const std::string rest = url.substr(t.https ? 8 : 7);
    const size_t slash = rest.find('/');
    const std::string authority = rest.substr(0, slash);
    t.path = slash == std::string::npos ? "/" : rest.substr(slash);
    if (authority.empty() || authority.find('@') != std::string::npos) throw std::invalid_argument("no host, or a user in the URL");
    std::string host = authority, port;
    if (host.front() == '[') {  // [v6] or [v6]:port
        const size_t close = host.find(']');
        if (close == std::string::npos) throw std::invalid_argument("an unclosed [ in the host");
        const std::string after = host.substr(close + 1);
        if (!after.empty() && (after[0] != ':' || after.size() == 1)) throw std::invalid_argument("text after the host");
        if (!after.empty()) port = after.substr(1);
        host = host.substr(1, close - 1);
    } else if (const size_t c = host.rfind(':'); c != std::string::npos) {
        port = host.substr(c + 1);
        host = host.substr(0, c);
        if (port.empty()) throw std::invalid_argument("a bad port");
    }
    if (!port.empty()) {
        if (port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos) throw std::invalid_argument("a bad port");
        t.port = std::stoi(port);
    }
    if (host.empty() || t.port < 1 || t.port > 65535) throw std::invalid_argument("no host, or a port out of range");
    t.host = lower(host);
    return t;
}

std::string admitted_address(const std::string& url, const NotifyPolicy& policy) {
    const HttpTarget t = parse_http_url(url);
    int how = 0;
    for (const std::string& e : policy.allow) how = std::max(how, admits(e, t));
    if (how == 0) throw std::invalid_argument(t.host + ":" + std::to_string(t.port) + " is not in the server's --notify-allow list");
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    addrinfo* res = nullptr;
    if (getaddrinfo(t.host.c_str(), nullptr, &hints, &res) != 0 || !res)
        throw std::invalid_argument(t.host + " has no address");
    std::string first;
    std::string refused;
    for (addrinfo* a = res; a; a = a->ai_next) {
        // Every address the name has, not only the first: a name that also points inside is refused.
        if (is_internal(a->ai_addr) && how < 2) refused = address_text(a->ai_addr);
        if (first.empty()) first = address_text(a->ai_addr);
    }
    freeaddrinfo(res);
    if (!refused.empty())
        throw std::invalid_argument(t.host + " is " + refused + ", an address of this server's own network, which only an --notify-allow "
                                                                "entry naming " + t.host + " itself admits");
    return first;
}

std::string hmac_sha256_hex(const std::string& key, const std::string& body) {
    unsigned char md[EVP_MAX_MD_SIZE];
    unsigned int len = 0;
    HMAC(EVP_sha256(), key.data(), int(key.size()), reinterpret_cast<const unsigned char*>(body.data()), body.size(), md, &len);
    static const char* hex = "0123456789abcdef";
    std::string out;
    for (unsigned int i = 0; i < len; ++i) {
        out += hex[md[i] >> 4];
        out += hex[md[i] & 15];
    }
    return out;
}

Notifier::Notifier(NotifyPolicy policy, std::string node, Record record)
    : policy_(std::move(policy)), node_(std::move(node)), record_(std::move(record)), thread_([this] { run(); }) {}

Notifier::~Notifier() { stop(); }

void Notifier::send(const std::string& job, const std::string& url, const std::string& event, const std::string& body) {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (stopping_) return;
        // Bounded: past it the oldest delivery is dropped (and logged), not the server's memory.
        if (queue_.size() >= kMaxQueued) {
            spdlog::warn("job {}: the {} notification to {} was dropped: {} deliveries wait", queue_.front().job, queue_.front().event,
                         queue_.front().url, queue_.size());
            queue_.pop_front();
        }
        queue_.push_back({job, url, event, body, new_delivery_id(), 1, std::chrono::steady_clock::now()});
    }
    cv_.notify_one();
}

void Notifier::stop() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (stopping_) return;
        stopping_ = true;
        for (const Delivery& d : queue_) spdlog::warn("job {}: the {} notification to {} was not delivered before shutdown", d.job, d.event, d.url);
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
}

void Notifier::run() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!stopping_) {
        if (queue_.empty()) {
            cv_.wait(lock);
            continue;
        }
        // The delivery due first (retries wait; new ones go at once).
        auto next = std::min_element(queue_.begin(), queue_.end(), [](const Delivery& a, const Delivery& b) { return a.due < b.due; });
        if (next->due > std::chrono::steady_clock::now()) {
            cv_.wait_until(lock, next->due);
            continue;
        }
        Delivery d = *next;
        queue_.erase(next);
        lock.unlock();
        const bool again = attempt(d);
        lock.lock();
        if (again && !stopping_) {
            d.due = std::chrono::steady_clock::now() +
                    std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                        std::chrono::duration<double>(policy_.first_retry_s * double(1 << std::min(d.attempt - 1, 10))));
            ++d.attempt;
            queue_.push_back(std::move(d));
        }
    }
}

bool Notifier::attempt(const Delivery& d) {
    TaskRecord log;
    log.task = "notify";
    log.node = node_;
    log.attempt = d.attempt;
    log.start = unix_now();
    bool retry = false;
    const std::string what = "POST " + d.url + " (" + d.event + ", delivery " + d.id + ")";
    try {
        const HttpTarget t = parse_http_url(d.url);
        const std::string address = admitted_address(d.url, policy_);  // again: the list or the name may have changed
        // http: to the checked address. https: named by the host (its certificate is checked
        // for that name, which goes out as SNI) and connected to the checked address all the same.
        std::unique_ptr<httplib::ClientImpl> client;
        if (t.https) {
            auto tls = std::make_unique<httplib::SSLClient>(t.host, t.port);
            tls->enable_server_certificate_verification(true);
            if (!policy_.ca_file.empty()) tls->set_ca_cert_path(policy_.ca_file.c_str());
            client = std::move(tls);
            client->set_hostname_addr_map({{t.host, address}});
        } else {
            client = std::make_unique<httplib::ClientImpl>(address, t.port);
        }
        const auto timeout = std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::duration<double>(policy_.timeout_s));
        // The timeouts bound each read and write; a receiver that drips its answer a byte at a time
        // would hold the one notifier thread for ever: the whole try is cut at three of them.
        AttemptDeadline deadline(*client, 3 * timeout);
        client->set_connection_timeout(timeout);
        client->set_read_timeout(timeout);
        client->set_write_timeout(timeout);
        client->set_follow_location(false);
        const std::string host = t.host.find(':') != std::string::npos ? "[" + t.host + "]" : t.host;  // an IPv6 literal
        const httplib::Headers headers = {
            {"Host", t.port == (t.https ? 443 : 80) ? host : host + ":" + std::to_string(t.port)},
            {"X-Tessera-Signature", "sha256=" + hmac_sha256_hex(policy_.secret, d.body)},
            {"X-Tessera-Event", d.event},
            {"X-Tessera-Delivery", d.id},
            {"User-Agent", "tessera-notify"}};
        // The answer's body is not read past 4 KiB (a receiver must not fill this server's memory).
        httplib::Request req;
        req.method = "POST";
        req.path = t.path;
        req.headers = headers;
        req.headers.emplace("Content-Type", "application/json");
        req.body = d.body;
        // The status comes with the headers; the body is read no further than 4 KiB (it is not
        // used, and a receiver must not fill this server's memory or hold its thread).
        int status = 0;
        size_t read = 0;
        req.response_handler = [&status](const httplib::Response& r) {
            status = r.status;
            return true;
        };
        req.content_receiver = [&read](const char*, size_t n, uint64_t, uint64_t) { return (read += n) <= 4096; };
        const auto res = client->send(req);
        if (res) status = res->status;
        if (deadline.passed()) {
            log.errors.push_back(what + ": no whole answer within " + std::to_string(3 * policy_.timeout_s) + " s");
            retry = true;
        } else if (status == 0) {
            log.errors.push_back(what + ": " + httplib::to_string(res.error()));
            retry = true;
        } else if (status >= 200 && status < 300) {
            log.lines.push_back(what + " → " + std::to_string(status));
        } else {
            // A redirect is not followed (it could point anywhere); a client error will not mend.
            retry = status >= 500 || status == 408 || status == 429;
            log.errors.push_back(what + " → " + std::to_string(status) +
                                 (status >= 300 && status < 400 ? " (redirects are not followed)" : ""));
        }
    } catch (const std::exception& e) {
        log.errors.push_back(what + ": refused: " + e.what());
    }
    retry = retry && d.attempt < policy_.max_attempts;
    if (retry) log.lines.push_back("retrying in " + std::to_string(policy_.first_retry_s * double(1 << std::min(d.attempt - 1, 10))) + " s");
    log.end = unix_now();
    log.outcome = log.errors.empty() ? "done" : "failed";
    if (!log.errors.empty()) spdlog::warn("job {}: {}", d.job, log.errors.back());
    if (record_) record_(d.job, log);
    return retry;
}

}  // namespace tessera::server
