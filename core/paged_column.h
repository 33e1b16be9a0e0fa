// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// A column of fixed-size records by index whose memory stops growing: the
/// first pages stay in memory, pages past `memory_bytes` go to a scratch file
/// (core/scratch_file.h) and come back through a small cache when read.
///
/// What a process holds per texture of a city (the texture table's 20 bytes
/// in every process of a build) grew with the city until stop 54: 2 GB held
/// about 16 million textures. A column holds at most `memory_bytes` whatever
/// its size; up to that it is a vector (no file, no lock), beyond it the
/// records read most recently stay in memory and the others cost a `pread`
/// of a page when asked for (the page cache's memory, not the process's).
///
/// Threads: records are added (`push_back`) by one thread, before or
/// between reads; `get` may be called by many threads at once, `set` too
/// (on different records). A page that cannot go to its file (a full disk)
/// stays in memory: the column works as a vector would, `status()` says why.
/// A page that cannot come back (a failing disk) throws std::runtime_error.

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include "core/scratch_file.h"
#include "core/status.h"

namespace cityatlas {

template <class T>
class PagedColumn {
    static_assert(std::is_trivially_copyable_v<T>, "records go to disk as bytes");

public:
    static constexpr size_t kPageRecords = 16384;
    static constexpr size_t kPageBytes = kPageRecords * sizeof(T);

    /// Pages go to `dir` (empty: the system's temporary folder) once the
    /// column passes `memory_bytes`; `what` names the records in an error.
    explicit PagedColumn(std::filesystem::path dir = {}, const char* what = "records",
                         size_t memory_bytes = size_t{64} << 20)
        : dir_(std::move(dir)), what_(what), state_(std::make_unique<State>(dir_)) {
        // A quarter of the pages (at least two) for the cache of those on
        // disk, the rest in memory for good: a column under the budget is a
        // vector, one above it reads its first records without a lock.
        const size_t pages = std::max<size_t>(3, memory_bytes / kPageBytes);
        cache_pages_ = std::max<size_t>(2, pages / 4);
        pinned_pages_ = pages - cache_pages_;
    }
    PagedColumn(const PagedColumn& o) : PagedColumn(o.dir_, o.what_, o.memoryBytes()) {
        for (size_t i = 0; i < o.size(); ++i) push_back(o.get(i));
    }
    PagedColumn& operator=(const PagedColumn& o) {
        if (this != &o) *this = PagedColumn(o);
        return *this;
    }
    PagedColumn(PagedColumn&&) noexcept = default;
    PagedColumn& operator=(PagedColumn&&) noexcept = default;

    /// Where pages go, for a column that has none there yet.
    void setScratchDir(const std::filesystem::path& dir) {
        if (state_->on_disk) return;
        dir_ = dir;
        state_->file = ScratchFile(dir_, "cityatlas-column");
    }

    size_t size() const { return size_; }
    bool empty() const { return size_ == 0; }

    void push_back(const T& r) {
        const size_t p = size_ / kPageRecords;
        if (p == pages_.size()) addPage();
        Page& page = pages_[p];
        if (p < pinned_pages_) {
            page.data[size_ % kPageRecords] = r;
        } else {
            std::lock_guard<std::mutex> lock(state_->mutex);
            T* data = residentLocked(p);
            data[size_ % kPageRecords] = r;
            page.dirty = true;
        }
        ++size_;
    }

    /// Record `i` (< size()).
    T get(size_t i) const {
        const size_t p = i / kPageRecords;
        if (p < pinned_pages_) return pages_[p].data[i % kPageRecords];
        std::lock_guard<std::mutex> lock(state_->mutex);
        return residentLocked(p)[i % kPageRecords];
    }
    T operator[](size_t i) const { return get(i); }

    /// Replaces record `i` (< size()).
    void set(size_t i, const T& r) {
        const size_t p = i / kPageRecords;
        if (p < pinned_pages_) {
            pages_[p].data[i % kPageRecords] = r;
            return;
        }
        std::lock_guard<std::mutex> lock(state_->mutex);
        residentLocked(p)[i % kPageRecords] = r;
        pages_[p].dirty = true;
    }

    /// Bytes held in memory (pages and their list).
    size_t bytes() const {
        std::lock_guard<std::mutex> lock(state_->mutex);
        size_t resident = 0;
        for (const Page& page : pages_) resident += page.data ? kPageBytes : 0;
        return resident + pages_.capacity() * sizeof(Page);
    }
    /// Bytes of pages written to the scratch file.
    uint64_t bytesOnDisk() const {
        std::lock_guard<std::mutex> lock(state_->mutex);
        return state_->on_disk;
    }
    /// The budget given at construction, as pages.
    size_t memoryBytes() const { return (pinned_pages_ + cache_pages_) * kPageBytes; }
    /// Why pages stayed in memory beyond the budget (a full disk), if any.
    Status status() const {
        std::lock_guard<std::mutex> lock(state_->mutex);
        return state_->failed;
    }

private:
    struct Page {
        std::unique_ptr<T[]> data;  // null: on disk
        bool dirty = false;         // in memory and newer than the file
        bool written = false;       // has a copy in the file
        uint64_t used = 0;          // when last read, for the cache's choice
    };
    // What a move must carry along whole (the mutex cannot move).
    struct State {
        explicit State(const std::filesystem::path& dir) : file(dir, "cityatlas-column") {}
        std::mutex mutex;
        ScratchFile file;
        uint64_t on_disk = 0;
        uint64_t clock = 0;
        size_t resident = 0;  // cached pages in memory (past the pinned ones)
        Status failed;
    };

    void addPage() {
        pages_.emplace_back();
        const size_t p = pages_.size() - 1;
        if (p < pinned_pages_) {
            pages_[p].data = std::make_unique<T[]>(kPageRecords);
            return;
        }
        std::lock_guard<std::mutex> lock(state_->mutex);
        makeRoomLocked();
        pages_[p].data = std::make_unique<T[]>(kPageRecords);
        pages_[p].dirty = true;
        pages_[p].used = ++state_->clock;
        ++state_->resident;
    }

    // Page p's records in memory, read back if they went to the file.
    T* residentLocked(size_t p) const {
        Page& page = pages_[p];
        page.used = ++state_->clock;
        if (page.data) return page.data.get();
        makeRoomLocked();
        auto data = std::make_unique<T[]>(kPageRecords);
        if (Status s = state_->file.read(uint64_t{p - pinned_pages_} * kPageBytes, data.get(), kPageBytes, what_); !s.ok())
            throw std::runtime_error(s.error);
        page.data = std::move(data);
        page.dirty = false;
        ++state_->resident;
        return page.data.get();
    }

    // Sends the least recently used cached page to the file while the cache
    // is full; after a failed write, keeps everything (a vector's memory).
    void makeRoomLocked() const {
        State& s = *state_;
        while (s.resident >= cache_pages_ && s.failed.ok()) {
            size_t oldest = pages_.size();
            for (size_t p = pinned_pages_; p < pages_.size(); ++p)
                if (pages_[p].data && (oldest == pages_.size() || pages_[p].used < pages_[oldest].used)) oldest = p;
            if (oldest == pages_.size()) return;
            Page& page = pages_[oldest];
            if (page.dirty || !page.written) {
                const uint64_t at = uint64_t{oldest - pinned_pages_} * kPageBytes;
                s.failed = s.file.write(at, page.data.get(), kPageBytes, what_);
                if (!s.failed.ok()) return;
                s.on_disk = std::max(s.on_disk, at + kPageBytes);
                page.written = true;
            }
            page.data.reset();
            page.dirty = false;
            --s.resident;
        }
    }

    std::filesystem::path dir_;
    const char* what_;
    size_t pinned_pages_ = 0;
    size_t cache_pages_ = 0;
    size_t size_ = 0;
    mutable std::vector<Page> pages_;  // get() brings pages back (under the mutex)
    std::unique_ptr<State> state_;
};

}  // namespace cityatlas
