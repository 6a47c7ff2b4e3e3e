#pragma once
// Giving memory back to the system once a large scene, job or upload is gone.
//
// glibc's malloc keeps freed memory in its arenas for reuse: after a 1 GiB texture was decoded
// and freed, or a thousand requests in a hundred connection threads, the process stays that
// large while idle. Large blocks are mapped on their own (freed at once), and what the arenas
// hold free is returned after the events that free a lot and every few seconds besides.
#include <atomic>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

namespace tessera::server {

// glibc's malloc for a server that must both shrink when idle and keep its hot buffers: blocks
// of 4 MiB and up (textures, images, request bodies) are mappings of their own, unmapped when
// freed; smaller ones stay in the heap, whose top is not trimmed on every free. Tile films are
// tens to hundreds of kilobytes and hiredis builds each command in a buffer twice that size:
// with glibc's defaults each such buffer was mapped and unmapped, or the heap's top trimmed and
// grown again, on every command (a 53 KB film took 1.1 ms a command against 0.055 ms;
// docs/scaling.md). What the heap holds free is returned by release_free_memory() instead,
// every few seconds. Idempotent.
void tune_allocator();

// Returns the free memory of every arena to the system (malloc_trim). Cheap when little is free.
void release_free_memory();

// Calls `release` (which ends in release_free_memory()) every `interval_s` seconds until
// destroyed.
class MemoryReturn {
public:
    MemoryReturn(double interval_s, std::function<void()> release);
    ~MemoryReturn();
    MemoryReturn(const MemoryReturn&) = delete;
    MemoryReturn& operator=(const MemoryReturn&) = delete;

private:
    std::mutex mutex_;
    std::condition_variable cv_;
    bool stop_ = false;
    std::thread thread_;
};

}  // namespace tessera::server
