// Signed notifications through a real server to real receivers on loopback (httplib servers
// started here, http and https with a certificate made here): signed with HMAC-SHA256, retried while the receiver answers 500, each attempt
// in the job's log; a URL outside the allow list, a redirect out of it, or an address of the
// server's own network that the list does not name is never contacted.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <openssl/x509v3.h>

#include "server/queue/notifier.h"
#include "tests/server/server_fixture.h"

namespace tessera::server {
namespace {

using nlohmann::json;

// A webhook receiver on a free loopback port: it records every request and answers `status`
// for the first `failures` of them, then 200 (or redirects everything, with `redirect`).
class Receiver {
public:
    explicit Receiver(int failures = 0, std::string redirect = "", size_t body = 0)
        : failures_(failures), redirect_(std::move(redirect)), body_(body) {
        server_.Post(".*", [this](const httplib::Request& req, httplib::Response& res) {
            std::lock_guard<std::mutex> lock(mutex_);
            got_.push_back(req);
            if (!redirect_.empty()) {
                res.status = 302;
                res.set_header("Location", redirect_);
            } else {
                res.status = int(got_.size()) <= failures_ ? 500 : 200;
                if (body_) res.set_content(std::string(body_, 'x'), "text/plain");
            }
        });
        port_ = server_.bind_to_any_port("127.0.0.1");
        thread_ = std::thread([this] { server_.listen_after_bind(); });
    }
    ~Receiver() {
        server_.stop();
        thread_.join();
    }
    int port() const { return port_; }
    std::string url(const std::string& path = "/hook") const { return "http://127.0.0.1:" + std::to_string(port_) + path; }
    std::vector<httplib::Request> requests() {
        std::lock_guard<std::mutex> lock(mutex_);
        return got_;
    }
    // Waits until it has `n` requests (or 20 s).
    std::vector<httplib::Request> wait_for(size_t n) {
        for (int i = 0; i < 2000 && requests().size() < n; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
        return requests();
    }

private:
    int failures_;
    std::string redirect_;
    size_t body_;
    httplib::Server server_;
    int port_ = 0;
    std::thread thread_;
    std::mutex mutex_;
    std::vector<httplib::Request> got_;
};

// A self-signed certificate for 127.0.0.1 (its own CA), and its key, as PEM files.
void write_certificate(const std::string& cert_path, const std::string& key_path) {
    EVP_PKEY* key = EVP_EC_gen("P-256");
    ASSERT_NE(key, nullptr);
    X509* x = X509_new();
    X509_set_version(x, 2);
    ASN1_INTEGER_set(X509_get_serialNumber(x), 1);
    X509_gmtime_adj(X509_getm_notBefore(x), -60);
    X509_gmtime_adj(X509_getm_notAfter(x), 3600);
    X509_set_pubkey(x, key);
    X509_NAME* name = X509_get_subject_name(x);
    X509_NAME_add_entry_by_txt(name, "CN", MBSTRING_ASC, reinterpret_cast<const unsigned char*>("tessera test receiver"), -1, -1, 0);
    X509_set_issuer_name(x, name);
    X509V3_CTX ctx;
    X509V3_set_ctx_nodb(&ctx);
    X509V3_set_ctx(&ctx, x, x, nullptr, nullptr, 0);
    for (const auto& [nid, value] : {std::pair{NID_subject_alt_name, "IP:127.0.0.1"}, std::pair{NID_basic_constraints, "critical,CA:TRUE"}}) {
        X509_EXTENSION* e = X509V3_EXT_conf_nid(nullptr, &ctx, nid, value);
        X509_add_ext(x, e, -1);
        X509_EXTENSION_free(e);
    }
    X509_sign(x, key, EVP_sha256());
    FILE* f = std::fopen(cert_path.c_str(), "w");
    PEM_write_X509(f, x);
    std::fclose(f);
    f = std::fopen(key_path.c_str(), "w");
    PEM_write_PrivateKey(f, key, nullptr, nullptr, 0, nullptr, nullptr);
    std::fclose(f);
    X509_free(x);
    EVP_PKEY_free(key);
}

// An https receiver on a free loopback port, with that certificate: it records every request.
class TlsReceiver {
public:
    TlsReceiver(const std::string& cert, const std::string& key) : server_(cert.c_str(), key.c_str()) {
        server_.Post(".*", [this](const httplib::Request& req, httplib::Response& res) {
            std::lock_guard<std::mutex> lock(mutex_);
            got_.push_back(req);
            res.status = 200;
        });
        port_ = server_.bind_to_any_port("127.0.0.1");
        thread_ = std::thread([this] { server_.listen_after_bind(); });
    }
    ~TlsReceiver() {
        server_.stop();
        thread_.join();
    }
    int port() const { return port_; }
    std::string url() const { return "https://127.0.0.1:" + std::to_string(port_) + "/hook"; }
    std::vector<httplib::Request> wait_for(size_t n) {
        for (int i = 0; i < 2000; ++i) {
            {
                std::lock_guard<std::mutex> lock(mutex_);
                if (got_.size() >= n) return got_;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        std::lock_guard<std::mutex> lock(mutex_);
        return got_;
    }

private:
    httplib::SSLServer server_;
    int port_ = 0;
    std::thread thread_;
    std::mutex mutex_;
    std::vector<httplib::Request> got_;
};

std::vector<json> log_lines(httplib::Client& c, const std::string& id) {
    std::vector<json> out;
    std::istringstream in(c.Get("/v1/jobs/" + id + "/log")->body);
    for (std::string line; std::getline(in, line);) out.push_back(json::parse(line));
    return out;
}

json with_notify(json job, const std::string& url, bool frames = false) {
    job["notify"] = {{"url", url}, {"frames", frames}};
    return job;
}

// RFC 4231, test case 2.
TEST(Notifier, HmacSha256MatchesTheRfc) {
    EXPECT_EQ(hmac_sha256_hex("Jefe", "what do ya want for nothing?"), "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843");
}

TEST(Notifier, UrlsAndTheAllowList) {
    EXPECT_EQ(parse_http_url("http://Example.COM:8080/a?b").host, "example.com");
    EXPECT_EQ(parse_http_url("http://example.com").path, "/");
    EXPECT_EQ(parse_http_url("http://[::1]:9/x").port, 9);
    EXPECT_TRUE(parse_http_url("https://x/").https);
    EXPECT_EQ(parse_http_url("https://x/").port, 443);
    EXPECT_EQ(parse_http_url("https://x:8443/").port, 8443);
    for (const char* bad : {"ftp://x/", "http://", "https://", "http://u:p@x/", "https://u@x/", "http://x:99999/", "http://x:a/", "http://[::1/"})
        EXPECT_THROW(parse_http_url(bad), std::invalid_argument) << bad;
    NotifyPolicy p;
    p.allow = {"*:8080", "127.0.0.1:9000"};
    EXPECT_EQ(admitted_address("http://127.0.0.1:9000/h", p), "127.0.0.1");
    // A wildcard does not admit the server's own network, whatever the name.
    EXPECT_THROW(admitted_address("http://127.0.0.1:8080/h", p), std::invalid_argument);
    EXPECT_THROW(admitted_address("http://localhost:8080/h", p), std::invalid_argument);
    EXPECT_THROW(admitted_address("http://10.1.2.3:8080/h", p), std::invalid_argument);
    EXPECT_THROW(admitted_address("http://169.254.169.254:8080/latest", p), std::invalid_argument);
    for (const char* inside : {"http://[::ffff:127.0.0.1]:8080/h", "http://[64:ff9b::a9fe:a9fe]:8080/h", "http://[64:ff9b:1::a00:5]:8080/h",
                               "http://[2002:7f00:1::]:8080/h", "http://[fec0::1]:8080/h", "http://[::1]:8080/h", "http://[fd00::5]:8080/h",
                               "http://[::127.0.0.1]:8080/h", "http://198.18.0.1:8080/h", "http://192.0.0.8:8080/h", "http://240.0.0.1:8080/h",
                               "http://0.0.0.0:8080/h", "http://100.64.0.1:8080/h"})
        EXPECT_THROW(admitted_address(inside, p), std::invalid_argument) << inside;
    EXPECT_EQ(admitted_address("http://[64:ff9b::808:808]:8080/h", p), "64:ff9b::808:808") << "NAT64 of a public address";
    EXPECT_THROW(admitted_address("http://127.0.0.1:9001/h", p), std::invalid_argument) << "another port";
    p.allow = {"*.hooks.test:*"};
    EXPECT_THROW(admitted_address("http://evilhooks.test/h", p), std::invalid_argument);
    // An entry without a port admits the URL's scheme's own: 80 for http, 443 for https.
    p.allow = {"127.0.0.1"};
    EXPECT_EQ(admitted_address("http://127.0.0.1/h", p), "127.0.0.1");
    EXPECT_EQ(admitted_address("https://127.0.0.1/h", p), "127.0.0.1");
    EXPECT_THROW(admitted_address("https://127.0.0.1:80/h", p), std::invalid_argument);
}

class Notify : public Server {
protected:
    void restart_with_ca(const std::string& ca) {
        notify_.ca_file = ca;
        restart();
    }
};

TEST_F(Notify, ASignedNotificationIsRetriedUntilTheReceiverTakesIt) {
    Receiver hook(2);  // 500, 500, then 200
    notify_.secret = "s3cret";
    notify_.allow = {"127.0.0.1:" + std::to_string(hook.port())};
    notify_.first_retry_s = 0.1;
    start();
    const std::string id = submit(with_notify(kSmallJob, hook.url("/hook?x=1")));
    wait_state(id, {"succeeded"});
    const auto got = hook.wait_for(3);
    ASSERT_EQ(got.size(), 3u);
    for (const auto& r : got) {
        EXPECT_EQ(r.path, "/hook");
        EXPECT_EQ(r.get_header_value("X-Tessera-Signature"), "sha256=" + hmac_sha256_hex("s3cret", r.body));
        EXPECT_EQ(r.get_header_value("X-Tessera-Event"), "succeeded");
        EXPECT_EQ(r.get_header_value("X-Tessera-Delivery"), got[0].get_header_value("X-Tessera-Delivery")) << "one delivery, retried";
        const json body = json::parse(r.body);
        EXPECT_EQ(body["event"], "succeeded");
        EXPECT_EQ(body["job"]["id"], id);
        EXPECT_EQ(body["job"]["state"], "succeeded");
    }
    EXPECT_NE(got[0].get_header_value("X-Tessera-Signature"), "sha256=" + hmac_sha256_hex("another key", got[0].body));
    // Each attempt in the job's log.
    std::vector<std::string> outcomes;
    for (int i = 0; i < 100; ++i) {
        outcomes.clear();
        for (const json& t : log_lines(*client_, id))
            if (t["task"] == "notify") outcomes.push_back(t["outcome"]);
        if (outcomes.size() == 3) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    EXPECT_EQ(outcomes, (std::vector<std::string>{"failed", "failed", "done"}));
    EXPECT_EQ(hook.requests().size(), 3u) << "nothing after the receiver took it";
}

// https: the receiver's certificate is checked for the URL's host against --notify-ca; signed
// as over http. A server that does not trust the receiver's certificate sends it nothing.
TEST_F(Notify, AnHttpsReceiverWithACertificateTheServerTrusts) {
    const std::string dir = (std::filesystem::temp_directory_path() / ("tessera_tls_" + std::to_string(::getpid()))).string();
    std::filesystem::create_directories(dir);
    write_certificate(dir + "/cert.pem", dir + "/key.pem");
    TlsReceiver hook(dir + "/cert.pem", dir + "/key.pem");
    ASSERT_GT(hook.port(), 0);
    notify_.secret = "s3cret";
    notify_.allow = {"127.0.0.1:" + std::to_string(hook.port())};
    notify_.first_retry_s = 0.05;
    notify_.max_attempts = 2;
    // Not trusted (the system's CAs): every try fails its check, and the receiver gets nothing.
    start();
    const std::string refused = submit(with_notify(kSmallJob, hook.url()));
    wait_state(refused, {"succeeded"});
    std::vector<json> tries;
    for (int i = 0; i < 200 && tries.size() < 2; ++i) {
        tries.clear();
        for (const json& t : log_lines(*client_, refused))
            if (t["task"] == "notify") tries.push_back(t);
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ASSERT_EQ(tries.size(), 2u);
    for (const json& t : tries) EXPECT_EQ(t["outcome"], "failed") << t.dump();
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    EXPECT_TRUE(hook.wait_for(0).empty()) << "a receiver whose certificate fails the check gets no body";
    // Trusted through --notify-ca: delivered, signed.
    restart_with_ca(dir + "/cert.pem");
    const std::string id = submit(with_notify(kSmallJob, hook.url()));
    wait_state(id, {"succeeded"});
    const auto got = hook.wait_for(1);
    ASSERT_EQ(got.size(), 1u);
    EXPECT_EQ(got[0].get_header_value("X-Tessera-Signature"), "sha256=" + hmac_sha256_hex("s3cret", got[0].body));
    EXPECT_EQ(json::parse(got[0].body)["job"]["id"], id);
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
}

// A receiver that answers a byte at a time, each within the read timeout, would hold the
// notifier for ever: the whole try is cut at three timeouts, and the next delivery goes out.
TEST_F(Notify, AReceiverThatDripsItsAnswerIsCutOff) {
    const int listener = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::bind(listener, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    ASSERT_EQ(::listen(listener, 4), 0);
    socklen_t len = sizeof addr;
    ::getsockname(listener, reinterpret_cast<sockaddr*>(&addr), &len);
    const int drip_port = ntohs(addr.sin_port);
    std::atomic<bool> stop{false};
    std::thread drip([&] {
        pollfd p{listener, POLLIN, 0};
        while (!stop && ::poll(&p, 1, 50) == 0) {}
        if (stop) return;
        const int c = ::accept(listener, nullptr, nullptr);
        const std::string answer = "HTTP/1.1 200 OK\r\nContent-Length: 0\r\n\r\n";
        for (size_t i = 0; i < answer.size() && !stop; ++i) {
            if (::send(c, &answer[i], 1, MSG_NOSIGNAL) != 1) break;
            std::this_thread::sleep_for(std::chrono::milliseconds(400));  // under the 0.5 s read timeout
        }
        ::close(c);
    });
    Receiver good;
    notify_.secret = "s3cret";
    notify_.allow = {"127.0.0.1:" + std::to_string(drip_port), "127.0.0.1:" + std::to_string(good.port())};
    notify_.timeout_s = 0.5;
    notify_.max_attempts = 1;
    start();
    const std::string slow = submit(with_notify(kSmallJob, "http://127.0.0.1:" + std::to_string(drip_port) + "/drip"));
    wait_state(slow, {"succeeded"});
    const auto t0 = std::chrono::steady_clock::now();
    const std::string next = submit(with_notify(kSmallJob, good.url()));
    wait_state(next, {"succeeded"});
    ASSERT_EQ(good.wait_for(1).size(), 1u) << "the next delivery went out";
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 8.0)
        << "the dripping answer (15 s whole) was cut at 1.5 s";
    bool cut = false;
    for (int i = 0; i < 100 && !cut; ++i) {
        for (const json& t : log_lines(*client_, slow))
            if (t["task"] == "notify" && t["outcome"] == "failed" && t["errors"].dump().find("no whole answer within") != std::string::npos) cut = true;
        if (!cut) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    EXPECT_TRUE(cut) << "the try is logged as cut off";
    stop = true;
    drip.join();
    ::close(listener);
}

TEST_F(Notify, NothingOutsideTheAllowListIsEverContacted) {
    Receiver outside;                     // not in the list
    Receiver redirector(0, outside.url());  // in the list, redirecting out of it
    notify_.secret = "s3cret";
    notify_.allow = {"127.0.0.1:" + std::to_string(redirector.port()), "*:" + std::to_string(outside.port())};
    notify_.first_retry_s = 0.05;
    start();
    // Outside the list, or inside it by a wildcard only (its own network): refused at submission.
    expect_problem(post_job(with_notify(kSmallJob, "http://127.0.0.1:1/hook")), 400, "/notify/url");
    expect_problem(post_job(with_notify(kSmallJob, outside.url())), 400, "/notify/url");
    expect_problem(post_job(with_notify(kSmallJob, "ftp://127.0.0.1/")), 400, "/notify/url");
    // A redirect out of the list: not followed, not retried.
    const std::string id = submit(with_notify(kSmallJob, redirector.url()));
    wait_state(id, {"succeeded"});
    ASSERT_EQ(redirector.wait_for(1).size(), 1u);
    std::this_thread::sleep_for(std::chrono::milliseconds(400));
    EXPECT_EQ(redirector.requests().size(), 1u) << "a redirect is not retried";
    EXPECT_TRUE(outside.requests().empty()) << "the redirect was followed";
    bool logged = false;
    for (const json& t : log_lines(*client_, id))
        if (t["task"] == "notify")
            for (const auto& e : t["errors"]) logged = logged || e.get<std::string>().find("redirects are not followed") != std::string::npos;
    EXPECT_TRUE(logged);
}

// A receiver that answers 200 with a huge body: delivered (its status read), the body not.
TEST_F(Notify, AHugeAnswerIsNotRead) {
    Receiver hook(0, "", 64 << 20);
    notify_.secret = "k";
    notify_.allow = {"127.0.0.1:" + std::to_string(hook.port())};
    start();
    const std::string id = submit(with_notify(kSmallJob, hook.url()));
    wait_state(id, {"succeeded"});
    ASSERT_EQ(hook.wait_for(1).size(), 1u);
    std::vector<std::string> outcomes;
    for (int i = 0; i < 200 && outcomes.empty(); ++i) {
        for (const json& t : log_lines(*client_, id))
            if (t["task"] == "notify") outcomes.push_back(t["outcome"]);
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    EXPECT_EQ(outcomes, std::vector<std::string>{"done"});
}

TEST_F(Notify, WithoutASecretNotificationsAreRefused) {
    start();
    expect_problem(post_job(with_notify(kSmallJob, "http://127.0.0.1:9/x")), 400, "/notify");
}

TEST_F(Notify, AShotsFramesWhenAsked) {
    Receiver hook;
    notify_.secret = "k";
    notify_.allow = {"127.0.0.1:" + std::to_string(hook.port())};
    start();
    const json shot = {{"scene", "cornell_shot"}, {"width", 16}, {"height", 12}, {"spp", 1}, {"max_depth", 1},
                       {"frames", {{"start", 0}, {"end", 48}, {"step", 24}}}};
    const std::string id = submit(with_notify(shot, hook.url(), true));
    wait_state(id, {"succeeded"});
    const auto got = hook.wait_for(4);
    ASSERT_EQ(got.size(), 4u);
    for (int i = 0; i < 3; ++i) EXPECT_EQ(got[size_t(i)].get_header_value("X-Tessera-Event"), "frame");
    EXPECT_EQ(got[3].get_header_value("X-Tessera-Event"), "succeeded");
}

}  // namespace
}  // namespace tessera::server
