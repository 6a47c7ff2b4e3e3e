// GET /v1/events and a running job's latest pass, against a real server on loopback.
#include <gtest/gtest.h>
#include <httplib.h>

#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/io/image_io.h"
#include "tests/server/server_fixture.h"

namespace tessera::server {
namespace {

using nlohmann::json;

struct SseEvent {
    std::string id, type, data;
};

// A client of the event stream in its own thread, parsing events as the WHATWG standard frames
// them (fields up to a blank line).
class EventReader {
public:
    EventReader(int port, const std::string& path, httplib::Headers headers = {}) {
        thread_ = std::thread([this, port, path, headers] {
            httplib::Client c("127.0.0.1", port);
            c.set_read_timeout(30, 0);
            auto r = c.Get(path, headers,
                           [this](const httplib::Response& res) {
                               std::lock_guard<std::mutex> lock(mu_);
                               status_ = res.status;
                               content_type_ = res.get_header_value("Content-Type");
                               return true;
                           },
                           [this](const char* data, size_t n) {
                               feed(std::string(data, n));
                               return !stop_;
                           });
            std::lock_guard<std::mutex> lock(mu_);
            if (r && status_ == 0) status_ = r->status;
            ended_ = true;
            cv_.notify_all();
        });
    }
    ~EventReader() {
        stop_ = true;
        thread_.join();
    }
    // Waits until `done` holds for the events so far (true) or the stream ends or time runs out.
    bool wait_for(const std::function<bool(const std::vector<SseEvent>&)>& done, double seconds = 60) {
        std::unique_lock<std::mutex> lock(mu_);
        return cv_.wait_for(lock, std::chrono::duration<double>(seconds), [&] { return done(events_) || ended_; }) && done(events_);
    }
    // Until the stream's first bytes: from then on every event is the reader's.
    bool wait_open(double seconds = 10) {
        std::unique_lock<std::mutex> lock(mu_);
        return cv_.wait_for(lock, std::chrono::duration<double>(seconds), [&] { return !raw_.empty() || ended_; }) && !raw_.empty();
    }
    bool wait_ended(double seconds) {
        std::unique_lock<std::mutex> lock(mu_);
        return cv_.wait_for(lock, std::chrono::duration<double>(seconds), [&] { return ended_; });
    }
    std::vector<SseEvent> events() {
        std::lock_guard<std::mutex> lock(mu_);
        return events_;
    }
    std::string raw() {
        std::lock_guard<std::mutex> lock(mu_);
        return raw_;
    }
    int status() {
        std::lock_guard<std::mutex> lock(mu_);
        return status_;
    }
    std::string content_type() {
        std::lock_guard<std::mutex> lock(mu_);
        return content_type_;
    }

private:
    void feed(const std::string& chunk) {
        std::lock_guard<std::mutex> lock(mu_);
        raw_ += chunk;
        pending_ += chunk;
        size_t end;
        while ((end = pending_.find("\n\n")) != std::string::npos) {
            const std::string block = pending_.substr(0, end);
            pending_.erase(0, end + 2);
            SseEvent e;
            bool any = false;
            size_t pos = 0;
            while (pos <= block.size()) {
                size_t nl = block.find('\n', pos);
                if (nl == std::string::npos) nl = block.size();
                const std::string line = block.substr(pos, nl - pos);
                pos = nl + 1;
                if (line.empty() || line[0] == ':') continue;
                const size_t colon = line.find(':');
                const std::string field = line.substr(0, colon);
                std::string value = colon == std::string::npos ? "" : line.substr(colon + 1);
                if (!value.empty() && value[0] == ' ') value.erase(0, 1);
                if (field == "id") e.id = value, any = true;
                else if (field == "event") e.type = value, any = true;
                else if (field == "data") e.data += value, any = true;
            }
            if (any && !e.type.empty()) events_.push_back(e);
        }
        cv_.notify_all();
    }

    std::mutex mu_;
    std::condition_variable cv_;
    std::vector<SseEvent> events_;
    std::string raw_, pending_, content_type_;
    int status_ = 0;
    bool ended_ = false;
    std::atomic<bool> stop_{false};
    std::thread thread_;
};

std::vector<SseEvent> of_job(const std::vector<SseEvent>& all, const std::string& id) {
    std::vector<SseEvent> out;
    for (const auto& e : all) {
        const json d = json::parse(e.data, nullptr, false);
        if (d.is_object() && d.contains("job") && d["job"]["id"] == id) out.push_back(e);
    }
    return out;
}

bool finished(const std::vector<SseEvent>& events, const std::string& id) {
    for (const auto& e : of_job(events, id))
        if (e.type == "state" && json::parse(e.data)["job"]["state"] == "succeeded") return true;
    return false;
}

class Events : public Server {
protected:
    void SetUp() override {
        limits_.event_keep_alive_s = 0.2;  // readers notice a stop quickly
    }
};

TEST_F(Events, FollowAJobFromCreationToItsResult) {
    start();
    EventReader reader(port_, "/v1/events");
    ASSERT_TRUE(reader.wait_open());
    // A pass-by-pass render: passes of 1, 2, 4, 8 and 16 samples per pixel.
    const std::string id = submit({{"scene", "builtin:cornell_box"}, {"width", 64}, {"height", 48}, {"spp", 16}});
    ASSERT_TRUE(reader.wait_for([&](const auto& ev) { return finished(ev, id); })) << reader.raw();
    EXPECT_EQ(reader.status(), 200);
    EXPECT_EQ(reader.content_type(), "text/event-stream");
    EXPECT_EQ(reader.raw().rfind("retry: ", 0), 0u) << "the stream starts with the reconnection delay";

    const auto events = of_job(reader.events(), id);
    ASSERT_GE(events.size(), 3u);
    EXPECT_EQ(events.front().type, "created");
    EXPECT_EQ(json::parse(events.front().data)["job"]["state"], "queued");
    std::vector<std::string> states;
    int last_pass = -1, passes = 0;
    uint64_t last_id = 0;
    for (const auto& e : events) {
        const uint64_t eid = std::stoull(e.id);
        EXPECT_GT(eid, last_id) << "ids increase";
        last_id = eid;
        const json d = json::parse(e.data);
        if (e.type == "state") states.push_back(d["job"]["state"]);
        if (e.type == "pass") {
            ++passes;
            const json& p = d["pass"];
            EXPECT_EQ(p["index"].get<int>(), last_pass + 1) << "every pass, in order";
            last_pass = p["index"];
            EXPECT_EQ(p["spp"].get<int>(), 1 << last_pass);
            EXPECT_EQ(d["job"]["latest_pass"], p) << "the status says the same";
            if (last_pass > 0) {
                EXPECT_GT(p["est_rel_mse"].get<double>(), 0.0) << "an error estimate from the second pass on";
            }
        }
    }
    EXPECT_EQ(passes, 5);
    EXPECT_EQ(states, (std::vector<std::string>{"running", "succeeded"}));
    const json final_status = json::parse(events.back().data)["job"];
    EXPECT_EQ(events.back().type, "state");
    EXPECT_TRUE(final_status["latest_pass"].is_null()) << "a finished job's curve is in its report";
}

// A shot's followers learn of each frame as it is written, in order, without polling: a "frame"
// event per frame, each counting the frames done and naming the one rendering next.
TEST_F(Events, AShotPublishesAFrameEventPerFrame) {
    start();
    EventReader reader(port_, "/v1/events");
    ASSERT_TRUE(reader.wait_open());
    const std::vector<int> frames = {0, 24, 48};
    const std::string id = submit({{"scene", "cornell_shot"}, {"width", 32}, {"height", 24}, {"spp", 2}, {"max_depth", 2}, {"frames", frames}});
    ASSERT_TRUE(reader.wait_for([&](const auto& ev) { return finished(ev, id); })) << reader.raw();

    std::vector<json> frame_jobs;
    bool ended = false;
    for (const auto& e : of_job(reader.events(), id)) {
        const json d = json::parse(e.data);
        if (e.type == "state" && d["job"]["state"] == "succeeded") ended = true;
        if (e.type != "frame") continue;
        EXPECT_FALSE(ended) << "a frame event after the shot ended: " << e.data;
        frame_jobs.push_back(d["job"]);
    }
    ASSERT_EQ(frame_jobs.size(), frames.size()) << reader.raw();
    for (size_t i = 0; i < frame_jobs.size(); ++i) {
        SCOPED_TRACE("frame event " + std::to_string(i));
        json& job = frame_jobs[i];
        EXPECT_EQ(job["state"], "running");
        json& shot = job["shot"];
        ASSERT_TRUE(shot.is_object()) << job.dump();
        EXPECT_EQ(shot["frames_total"], frames.size());
        EXPECT_EQ(shot["frames_done"], i + 1);
        EXPECT_EQ(shot["current_frame"], i + 1 < frames.size() ? json(frames[i + 1]) : json(nullptr));
        ASSERT_EQ(shot["frames"].size(), frames.size()) << shot.dump();
        EXPECT_EQ(shot["frames"][i]["frame"], frames[i]);
        EXPECT_EQ(shot["frames"][i]["state"], "succeeded");
        EXPECT_TRUE(shot["mean_frame_s"].is_number()) << shot.dump();
    }
}

TEST_F(Events, AReconnectingClientGetsWhatItMissedOrAReset) {
    start();
    std::string first_id;
    std::vector<SseEvent> seen;
    const std::string id = [&] {
        EventReader reader(port_, "/v1/events");
        EXPECT_TRUE(reader.wait_open());
        const std::string job = submit(kSmallJob);
        EXPECT_TRUE(reader.wait_for([&](const auto& ev) { return finished(ev, job); }));
        seen = of_job(reader.events(), job);
        return job;
    }();
    ASSERT_GE(seen.size(), 3u);
    // Back after the first event: every later one, with the same ids.
    EventReader resumed(port_, "/v1/events", {{"Last-Event-ID", seen.front().id}});
    ASSERT_TRUE(resumed.wait_for([&](const auto& ev) { return finished(ev, id); }, 10)) << resumed.raw();
    const auto again = of_job(resumed.events(), id);
    ASSERT_EQ(again.size(), seen.size() - 1);
    for (size_t i = 0; i < again.size(); ++i) {
        EXPECT_EQ(again[i].id, seen[i + 1].id);
        EXPECT_EQ(again[i].type, seen[i + 1].type);
    }
    // An id this process never gave out (another process's, or garbage): re-read the jobs.
    for (const std::string bad : {"1", "99999999999999999", "abc"}) {
        EventReader reset(port_, "/v1/events", {{"Last-Event-ID", bad}});
        ASSERT_TRUE(reset.wait_for([](const auto& ev) { return !ev.empty(); }, 5)) << bad;
        EXPECT_EQ(reset.events().front().type, "reset") << bad;
    }
}

TEST_F(Events, OneJobCanBeFollowedAlone) {
    start();
    const std::string quiet = submit(kLongJob);
    const std::string id = submit(kSmallJob);
    EventReader reader(port_, "/v1/events?job=" + id);
    ASSERT_TRUE(reader.wait_open());
    client_->Delete("/v1/jobs/" + quiet);  // a state event of another job
    ASSERT_TRUE(reader.wait_for([&](const auto& ev) { return finished(ev, id); })) << reader.raw();
    for (const auto& e : reader.events()) EXPECT_EQ(json::parse(e.data)["job"]["id"], id) << e.data;
    expect_problem(client_->Get("/v1/events?job=0123456789abcdef"), 404);
}

TEST_F(Events, StreamsEndOnTheirOwn) {
    limits_.event_stream_s = 0.5;
    start();
    EventReader ends(port_, "/v1/events");
    EXPECT_TRUE(ends.wait_ended(10)) << "a stream ends after event_stream_s; the client reconnects";
    EXPECT_EQ(ends.status(), 200);
}

TEST_F(Events, StoppingTheServerEndsOpenStreams) {
    start();
    EventReader open(port_, "/v1/events");
    ASSERT_TRUE(open.wait_open());
    const auto t0 = std::chrono::steady_clock::now();
    api_->stop();
    EXPECT_TRUE(open.wait_ended(10));
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(5)) << "stopping does not wait for open streams";
}

TEST_F(Events, ARunningJobShowsItsLatestPass) {
    start();
    const std::string id = submit(kLongJob);
    json s;
    for (int i = 0; i < 3000; ++i) {
        s = status(id);
        if (s["state"] == "running" && s["latest_pass"].is_object() && s["latest_pass"]["index"].get<int>() >= 1) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ASSERT_TRUE(s["latest_pass"].is_object()) << s.dump();
    const std::string base = "/v1/jobs/" + id;
    auto png = client_->Get(base + "/image.png");
    ASSERT_TRUE(png);
    ASSERT_EQ(png->status, 200) << png->body;
    EXPECT_EQ(png->body.substr(1, 3), "PNG");
    EXPECT_EQ(png->get_header_value("Cache-Control"), "no-store");
    const int pass = std::stoi(png->get_header_value("X-Tessera-Pass"));
    EXPECT_GE(pass, s["latest_pass"]["index"].get<int>());
    EXPECT_EQ(std::stoi(png->get_header_value("X-Tessera-Pass-Spp")), 1 << pass);
    EXPECT_GT(std::stod(png->get_header_value("X-Tessera-Pass-Error")), 0.0);
    auto exr = client_->Get(base + "/image.exr");
    ASSERT_TRUE(exr && exr->status == 200);
    EXPECT_EQ(exr->body.substr(0, 4), std::string("\x76\x2f\x31\x01", 4));
    // The pass image is the film so far: write it out and read it back as the job's size.
    const std::string path = (dir_ / "pass.exr").string();
    std::ofstream(path, std::ios::binary) << exr->body;
    const Image img = read_image(path);
    EXPECT_EQ(img.width, 400);
    EXPECT_EQ(img.height, 300);
    EXPECT_GE(img.sample_count[0], 1.f);
    auto rate = client_->Get(base + "/rate.png");
    ASSERT_TRUE(rate && rate->status == 200);
    expect_problem(client_->Get(base + "/report.json"), 409);
    client_->Delete(base);
    wait_state(id, {"canceled"});
    expect_problem(client_->Get(base + "/image.png"), 410);
}

TEST_F(Events, ExposureIsAppliedToTheLinearImage) {
    start();
    const std::string id = submit(kSmallJob);
    ASSERT_EQ(wait_state(id, {"succeeded", "failed"})["state"], "succeeded");
    const std::string base = "/v1/jobs/" + id;
    auto plain = client_->Get(base + "/image.png");
    auto zero = client_->Get(base + "/image.png?exposure=0");
    auto bright = client_->Get(base + "/image.png?exposure=1.5");
    ASSERT_TRUE(plain && zero && bright);
    ASSERT_EQ(bright->status, 200) << bright->body;
    EXPECT_EQ(zero->body, plain->body);
    const Image linear = read_image((dir_ / "jobs" / id / "image.exr").string());
    const auto expected = png_bytes(linear, 1.5f);
    EXPECT_EQ(bright->body, std::string(expected.begin(), expected.end()));
    // Read back: every pixel at least as bright, and brighter on average.
    const std::string path = (dir_ / "bright.png").string();
    std::ofstream(path, std::ios::binary) << bright->body;
    const Image b = read_image(path);
    const std::string plain_path = (dir_ / "plain.png").string();
    std::ofstream(plain_path, std::ios::binary) << plain->body;
    const Image p = read_image(plain_path);
    double sb = 0, sp = 0;
    for (size_t i = 0; i < b.rgb.size(); ++i) {
        EXPECT_GE(b.rgb[i], p.rgb[i]);
        sb += b.rgb[i];
        sp += p.rgb[i];
    }
    EXPECT_GT(sb, sp * 1.2);
    for (const char* bad : {"abc", "17", "-16.5", "nan", "inf", "1e400", "", "1x"})
        expect_problem(client_->Get(base + "/image.png?exposure=" + std::string(bad)), 400, "exposure");
    expect_problem(client_->Get(base + "/rate.png?exposure=1"), 400, "exposure");
}

}  // namespace
}  // namespace tessera::server
