#pragma once
// Signed notifications of a job's end (and of a shot's frames): its status POSTed to the http or
// https URL the job names (https: the receiver's certificate checked against the system's CAs or
// --notify-ca, for the URL's host), with an HMAC-SHA256 of the body under the server's secret in X-Tessera-Signature
// ("sha256=" and 64 hex digits), retried with back-off while the receiver fails, each attempt in
// the job's log. Only URLs the server's allow list admits are ever called: the host's every
// address is checked and the connection made to that address (no second lookup a DNS answer
// could change), private, loopback and link-local addresses only where an entry names the host
// itself, and redirects are never followed. A server must not become a way into its own network.
#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "server/queue/task_log.h"

namespace tessera::server {

struct NotifyPolicy {
    std::string secret;              // --notify-secret: empty, no notifications are sent (jobs asking are refused)
    std::vector<std::string> allow;  // --notify-allow: host, *.domain or *, each with :port or :* (no port: the scheme's, 80 or 443)
    std::string ca_file;             // --notify-ca: the CA certificates https receivers are checked against ("" the system's)
    int max_attempts = 6;            // first try and retries
    double first_retry_s = 1.0;      // doubling after each failure
    double timeout_s = 10.0;         // to connect, and to read the answer
};

struct HttpTarget {
    bool https = false;
    std::string host;  // as the URL names it (lowercase)
    int port = 80;     // 443 for https when the URL names none
    std::string path;  // from the first '/', "/" when none
};
// Throws std::invalid_argument naming what is wrong.
HttpTarget parse_http_url(const std::string& url);

// The address to connect to when the policy admits the URL; otherwise throws
// std::invalid_argument saying why (not in the allow list, a private address not named, no
// address at all).
std::string admitted_address(const std::string& url, const NotifyPolicy& policy);

// hex(HMAC-SHA256(key, body)).
std::string hmac_sha256_hex(const std::string& key, const std::string& body);

class Notifier {
public:
    // `record` puts an attempt in the job's log (one process: its file; a farm: Redis).
    using Record = std::function<void(const std::string& job, const TaskRecord& attempt)>;
    Notifier(NotifyPolicy policy, std::string node, Record record);
    ~Notifier();
    Notifier(const Notifier&) = delete;
    Notifier& operator=(const Notifier&) = delete;

    const NotifyPolicy& policy() const { return policy_; }
    // Queues a delivery of `body` (the job's status as JSON) for `event` (succeeded, failed,
    // canceled, frame). Never blocks on the network.
    void send(const std::string& job, const std::string& url, const std::string& event, const std::string& body);
    // Stops sending; what is still queued is logged as not delivered.
    void stop();

private:
    struct Delivery {
        std::string job, url, event, body, id;
        int attempt = 1;
        std::chrono::steady_clock::time_point due;
    };
    void run();
    // One attempt: whether to try again.
    bool attempt(const Delivery& d);

    static constexpr size_t kMaxQueued = 10000;
    NotifyPolicy policy_;
    std::string node_;
    Record record_;
    std::mutex mutex_;
    std::condition_variable cv_;
    std::deque<Delivery> queue_;
    bool stopping_ = false;
    std::thread thread_;
};

}  // namespace tessera::server
