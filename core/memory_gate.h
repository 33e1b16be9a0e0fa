// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Lets pieces of work whose memory is known beforehand run side by side only
/// while their estimates add up to at most a budget; a piece larger than the
/// budget runs alone (it waits until nothing else holds the gate). Which
/// pieces share the cores changes the time, never what they compute.
///
/// A thread that waits here blocks outright (it takes no other task meanwhile),
/// so the work a holder does must never wait for another acquire of the same
/// gate: run it under tbb::this_task_arena::isolate when it spawns tasks, or
/// a task stolen while it waits could block on the gate its own thread holds.

#include <condition_variable>
#include <cstddef>
#include <mutex>

namespace cityatlas {

class MemoryGate {
public:
    explicit MemoryGate(size_t budget_bytes) : budget_(budget_bytes) {}
    MemoryGate(const MemoryGate&) = delete;
    MemoryGate& operator=(const MemoryGate&) = delete;

    void acquire(size_t bytes) {
        std::unique_lock lock(mutex_);
        free_.wait(lock, [&] { return in_use_ == 0 || in_use_ + bytes <= budget_; });
        in_use_ += bytes;
    }
    void release(size_t bytes) {
        {
            std::lock_guard lock(mutex_);
            in_use_ -= bytes;
        }
        free_.notify_all();
    }

    /// Holds `bytes` of the gate for its lifetime.
    class Held {
    public:
        Held(MemoryGate& gate, size_t bytes) : gate_(gate), bytes_(bytes) { gate_.acquire(bytes_); }
        ~Held() { gate_.release(bytes_); }
        Held(const Held&) = delete;
        Held& operator=(const Held&) = delete;

    private:
        MemoryGate& gate_;
        size_t bytes_;
    };

private:
    const size_t budget_;
    std::mutex mutex_;
    std::condition_variable free_;
    size_t in_use_ = 0;
};

}  // namespace cityatlas
