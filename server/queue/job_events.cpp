#include "server/queue/job_events.h"

#include <iterator>

namespace tessera::server {

JobEvents::JobEvents(size_t capacity, size_t max_bytes) : capacity_(capacity ? capacity : 1), max_bytes_(max_bytes) {
    first_id_ = uint64_t(std::chrono::duration_cast<std::chrono::microseconds>(
                             std::chrono::system_clock::now().time_since_epoch()).count());
    next_id_ = first_id_ + 1;
}

void JobEvents::publish(std::string type, std::string job_id, std::string data) {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        bytes_ += data.size();
        history_.push_back({next_id_++, std::move(type), std::move(job_id), std::move(data)});
        while (history_.size() > 1 && (history_.size() > capacity_ || bytes_ > max_bytes_)) {
            bytes_ -= history_.front().data.size();
            history_.pop_front();
        }
    }
    cv_.notify_all();
}

JobEvents::Batch JobEvents::wait_after(uint64_t after, const std::string& job, std::chrono::milliseconds wait) {
    Batch b;
    std::unique_lock<std::mutex> lock(mutex_);
    // Known ids run from first_id_ (nothing seen yet) to the last one given out; one before
    // the oldest held means events in between were dropped.
    if (after < first_id_ || after >= next_id_ || (!history_.empty() && after + 1 < history_.front().id)) {
        b.lost = true;
        b.last = next_id_ - 1;
        return b;
    }
    auto collect = [&] {
        auto it = history_.end();
        while (it != history_.begin() && std::prev(it)->id > after) --it;
        for (; it != history_.end(); ++it)
            if (job.empty() || it->job_id == job) b.events.push_back(*it);
        after = next_id_ - 1;
        return !b.events.empty();
    };
    const auto deadline = std::chrono::steady_clock::now() + wait;
    for (;;) {
        if (closed_) {
            b.closed = true;
            break;
        }
        if (collect()) break;
        if (cv_.wait_until(lock, deadline) == std::cv_status::timeout) {
            b.closed = closed_;
            if (!closed_) collect();
            break;
        }
    }
    b.last = after;
    return b;
}

uint64_t JobEvents::last_id() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return next_id_ - 1;
}

int JobEvents::subscribers() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return subscribers_;
}

JobEvents::Subscription::Subscription(JobEvents& events) : events_(events) {
    std::lock_guard<std::mutex> lock(events_.mutex_);
    ++events_.subscribers_;
}

JobEvents::Subscription::~Subscription() {
    std::lock_guard<std::mutex> lock(events_.mutex_);
    --events_.subscribers_;
}

void JobEvents::close() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        closed_ = true;
    }
    cv_.notify_all();
}

}  // namespace tessera::server
