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
    /// Records a page, at most: pages are smaller only where the budget is
    /// under three of them (tests and measurements page a small town).
    static constexpr size_t kPageRecords = 16384;
    static constexpr size_t kPageBytes = kPageRecords * sizeof(T);
    static_assert(kPageRecords == size_t{1} << 14, "page_shift_ starts at 14");

    /// Pages go to `dir` (empty: the system's temporary folder) once the
    /// column passes `memory_bytes`; `what` names the records in an error.
    explicit PagedColumn(std::filesystem::path dir = {}, const char* what = "records",
                         size_t memory_bytes = size_t{64} << 20)
        : dir_(std::move(dir)), what_(what), state_(std::make_unique<State>(dir_)) {
        // Pages of 16,384 records, or as many as three pages fit in the
        // budget (16 at least: a budget of 0 pages a test town record by
        // record, nearly). A quarter of the pages (at least two) for the
        // cache of those on disk, the rest in memory for good: a column under
        // the budget is a vector, one above it reads its first records
        // without a lock.
        while (page_shift_ > 4 && (size_t{3} << page_shift_) * sizeof(T) > memory_bytes) --page_shift_;
        const size_t pages = std::max<size_t>(3, memory_bytes / pageBytes());
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
        const size_t p = size_ >> page_shift_;
        if (p == pages_.size()) addPage();
        Page& page = pages_[p];
        if (p < pinned_pages_) {
            page.data[slot(size_)] = r;
        } else {
            std::lock_guard<std::mutex> lock(state_->mutex);
            T* data = residentLocked(p);
            data[slot(size_)] = r;
            page.dirty = true;
        }
        ++size_;
    }

    /// Record `i` (< size()).
    T get(size_t i) const {
        const size_t p = i >> page_shift_;
        if (p < pinned_pages_) return pages_[p].data[slot(i)];
        std::lock_guard<std::mutex> lock(state_->mutex);
        return residentLocked(p)[slot(i)];
    }
    T operator[](size_t i) const { return get(i); }

    /// Replaces record `i` (< size()).
    void set(size_t i, const T& r) {
        const size_t p = i >> page_shift_;
        if (p < pinned_pages_) {
            pages_[p].data[slot(i)] = r;
            return;
        }
        std::lock_guard<std::mutex> lock(state_->mutex);
        residentLocked(p)[slot(i)] = r;
        pages_[p].dirty = true;
    }

    /// Bytes held in memory (pages and their list).
    size_t bytes() const {
        std::lock_guard<std::mutex> lock(state_->mutex);
        size_t resident = 0;
        for (const Page& page : pages_) resident += page.data ? pageBytes() : 0;
        return resident + pages_.capacity() * sizeof(Page) + state_->cached.capacity() * sizeof(size_t);
    }
    /// Bytes of pages written to the scratch file.
    uint64_t bytesOnDisk() const {
        std::lock_guard<std::mutex> lock(state_->mutex);
        return state_->on_disk;
    }
    /// The budget given at construction, as pages.
    size_t memoryBytes() const { return (pinned_pages_ + cache_pages_) * pageBytes(); }
    /// Records a page (kPageRecords but for budgets under three of them).
    size_t pageRecords() const { return size_t{1} << page_shift_; }
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
        std::vector<size_t> cached;  // the pages past the pinned ones that are in memory
        Status failed;
    };

    size_t pageBytes() const { return pageRecords() * sizeof(T); }
    size_t slot(size_t i) const { return i & (pageRecords() - 1); }

    void addPage() {
        pages_.emplace_back();
        const size_t p = pages_.size() - 1;
        if (p < pinned_pages_) {
            pages_[p].data = std::make_unique<T[]>(pageRecords());
            return;
        }
        std::lock_guard<std::mutex> lock(state_->mutex);
        makeRoomLocked();
        pages_[p].data = std::make_unique<T[]>(pageRecords());
        pages_[p].dirty = true;
        pages_[p].used = ++state_->clock;
        state_->cached.push_back(p);
    }

    // Page p's records in memory, read back if they went to the file.
    T* residentLocked(size_t p) const {
        Page& page = pages_[p];
        page.used = ++state_->clock;
        if (page.data) return page.data.get();
        makeRoomLocked();
        auto data = std::make_unique<T[]>(pageRecords());
        if (Status s = state_->file.read(uint64_t{p - pinned_pages_} * pageBytes(), data.get(), pageBytes(), what_); !s.ok())
            throw std::runtime_error(s.error);
        page.data = std::move(data);
        page.dirty = false;
        state_->cached.push_back(p);
        return page.data.get();
    }

    // Sends the least recently used cached page to the file while the cache
    // is full; after a failed write, keeps everything (a vector's memory).
    void makeRoomLocked() const {
        State& s = *state_;
        while (s.cached.size() >= cache_pages_ && s.failed.ok()) {
            size_t k = 0;  // the least recently used of the cached pages (a few dozen)
            for (size_t j = 1; j < s.cached.size(); ++j)
                if (pages_[s.cached[j]].used < pages_[s.cached[k]].used) k = j;
            const size_t oldest = s.cached[k];
            Page& page = pages_[oldest];
            if (page.dirty || !page.written) {
                const uint64_t at = uint64_t{oldest - pinned_pages_} * pageBytes();
                s.failed = s.file.write(at, page.data.get(), pageBytes(), what_);
                if (!s.failed.ok()) return;
                s.on_disk = std::max(s.on_disk, at + pageBytes());
                page.written = true;
            }
            page.data.reset();
            page.dirty = false;
            s.cached[k] = s.cached.back();
            s.cached.pop_back();
        }
    }

    std::filesystem::path dir_;
    const char* what_;
    unsigned page_shift_ = 14;  // kPageRecords = 1 << 14
    size_t pinned_pages_ = 0;
    size_t cache_pages_ = 0;
    size_t size_ = 0;
    mutable std::vector<Page> pages_;  // get() brings pages back (under the mutex)
    std::unique_ptr<State> state_;
};

}  // namespace cityatlas
