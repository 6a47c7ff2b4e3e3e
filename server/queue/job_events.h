#pragma once
// The job events that GET /v1/events streams (Server-Sent Events): a bounded history with
// increasing ids, so that a client reconnecting with Last-Event-ID gets what it missed, or is
// told to re-read the list when that has already been dropped.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <string>
#include <vector>

namespace tessera::server {

struct JobEvent {
    uint64_t id = 0;
    std::string type;    // created, state, progress, pass
    std::string job_id;
    std::string data;    // one line of JSON
};

class JobEvents {
public:
    // Ids start at the process's start time in microseconds, so that they keep increasing over
    // a restart and an id from an earlier process is recognised as one (its events are gone).
    // At most `capacity` events and `max_bytes` of their data (an event carries a job's whole
    // status, whose settings a comparison's labels can make large).
    explicit JobEvents(size_t capacity = 4096, size_t max_bytes = 64u << 20);

    void publish(std::string type, std::string job_id, std::string data);

    struct Batch {
        std::vector<JobEvent> events;
        bool lost = false;    // events after `after` were dropped, or `after` is no id of ours
        bool closed = false;  // the server stops: end the stream
        uint64_t last = 0;    // the id to wait after next time (events of other jobs included)
    };
    // The events after id `after` (of job `job` unless empty), waiting up to `wait` for one.
    Batch wait_after(uint64_t after, const std::string& job, std::chrono::milliseconds wait);
    // The id a new subscriber starts after: it sees only what comes next.
    uint64_t last_id() const;
    // Whether anyone is reading (a farm's API node looks for changes only then).
    int subscribers() const;

    // A reader for as long as it lives.
    class Subscription {
    public:
        explicit Subscription(JobEvents& events);
        ~Subscription();
        Subscription(const Subscription&) = delete;
        Subscription& operator=(const Subscription&) = delete;
    private:
        JobEvents& events_;
    };

    // Ends every stream (the server stops); later waits return at once.
    void close();

private:
    mutable std::mutex mutex_;
    std::condition_variable cv_;
    std::deque<JobEvent> history_;
    size_t capacity_;
    size_t max_bytes_;
    size_t bytes_ = 0;
    uint64_t first_id_;  // the id before this process's first event
    uint64_t next_id_;
    int subscribers_ = 0;
    bool closed_ = false;
};

}  // namespace tessera::server
