// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// A fixed-size record for every id 0, 1, ... (a feature's summary while a
/// city is read), without a city's worth of them in memory: readers hand
/// over a building's triangles while they read it, so the records being
/// added to are the newest few. Those stay in memory (a window of at most
/// `window` records); older ones go to one scratch file (core/scratch_file.h),
/// half a window at a time. A record asked for behind the window (a reader
/// that comes back to an old building) is read from the file and written
/// back: correct, slower, and counted (`strays`). An input whose ids fit the
/// window never touches the disk.
///
/// The records are the same whatever the window: each record sees the same
/// updates in the same order (tests/ingest/test_windowed_records.cpp).

#include <algorithm>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <type_traits>
#include <vector>

#include "core/scratch_file.h"
#include "core/status.h"

namespace cityatlas {

template <class T>
class WindowedRecords {
    static_assert(std::is_trivially_copyable_v<T>, "records go to disk as bytes");

public:
    /// Older records go to a file in `dir` (empty: the system's temporary
    /// folder); ids not yet added to read as `fresh`.
    explicit WindowedRecords(std::filesystem::path dir = {}, size_t window = size_t{1} << 16, T fresh = T{})
        : file_(std::move(dir), "cityatlas-records"), window_(std::max<size_t>(2, window)), fresh_(fresh) {}

    /// Record `id`, to read or change: valid until the next call. Ids up
    /// to `id` not seen yet are added as `fresh`. After an I/O error (see
    /// status()) an old record reads as `fresh` and changes to it are lost.
    T& at(size_t id) {
        writeStrayBack();
        block_first_ = kNone;  // what the file holds may change
        if (id >= first_) {
            while (id >= first_ + recent_.size()) {
                if (recent_.size() == window_) evictHalf();
                recent_.push_back(fresh_);
            }
            return recent_[id - first_];
        }
        ++strays_;
        stray_id_ = id;
        stray_ = fresh_;
        if (failed_.ok()) failed_ = file_.read(id * sizeof(T), &stray_, sizeof(T), kWhat);
        return stray_;
    }

    /// Record `id` as it stands (`fresh` beyond size()); reading ids in
    /// order reads the file a block at a time.
    T get(size_t id) {
        writeStrayBack();
        if (id >= first_) return id - first_ < recent_.size() ? recent_[id - first_] : fresh_;
        if (block_first_ == kNone || id < block_first_ || id >= block_first_ + block_.size()) {
            const size_t n = std::min<size_t>(kBlock, first_ - id);
            block_.assign(n, fresh_);
            block_first_ = id;
            if (failed_.ok()) failed_ = file_.read(id * sizeof(T), block_.data(), n * sizeof(T), kWhat);
            if (!failed_.ok()) std::fill(block_.begin(), block_.end(), fresh_);
        }
        return block_[id - block_first_];
    }

    size_t size() const { return first_ + recent_.size(); }
    /// Calls of at() behind the window.
    uint64_t strays() const { return strays_; }
    /// The first failed write or read of the file (disk full), if any.
    const Status& status() const { return failed_; }
    /// Frees the records and the file.
    void clear() {
        file_.close();
        std::deque<T>().swap(recent_);
        std::vector<T>().swap(block_);
        first_ = 0, stray_id_ = kNone, block_first_ = kNone, strays_ = 0;
    }

private:
    static constexpr size_t kNone = SIZE_MAX;
    static constexpr size_t kBlock = 4096;
    static constexpr const char* kWhat = "old records";

    ScratchFile file_;  // ids below first_
    size_t window_ = 2;
    T fresh_{};
    std::deque<T> recent_;  // ids first_ .. first_ + recent_.size() - 1
    size_t first_ = 0;      // ids below are in the file
    size_t stray_id_ = kNone;  // an old record handed out by at(), written back on the next call
    T stray_{};
    uint64_t strays_ = 0;
    size_t block_first_ = kNone;  // get()'s read-ahead of old records
    std::vector<T> block_;
    Status failed_;

    void writeStrayBack() {
        if (stray_id_ == kNone) return;
        if (failed_.ok()) failed_ = file_.write(stray_id_ * sizeof(T), &stray_, sizeof(T), kWhat);
        stray_id_ = kNone;
    }

    void evictHalf() {
        const size_t n = recent_.size() / 2;
        std::vector<T> out(recent_.begin(), recent_.begin() + static_cast<std::ptrdiff_t>(n));
        if (failed_.ok()) failed_ = file_.write(first_ * sizeof(T), out.data(), n * sizeof(T), kWhat);
        recent_.erase(recent_.begin(), recent_.begin() + static_cast<std::ptrdiff_t>(n));
        first_ += n;
    }

};

}  // namespace cityatlas
