// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Sorting more fixed-size records than memory should hold: a reader that
/// meets a city's worth of keys (every geometry id of a file, say) pushes
/// them here; up to a budget they stay in memory, beyond it each full buffer
/// is sorted and appended as a run to one anonymous file (unlinked at once:
/// nothing is left behind, even by a crash), and forEachSorted merges the
/// runs with a small buffer each (the budget shared among them, at least
/// 4 KiB a run). An input that fits the budget never touches the disk.

#include <algorithm>
#include <filesystem>
#include <functional>
#include <queue>
#include <type_traits>
#include <vector>

#include "core/scratch_file.h"
#include "core/status.h"

namespace cityatlas {

template <class T>
class ExternalSorter {
    static_assert(std::is_trivially_copyable_v<T>, "records go to disk as bytes");

public:
    /// Runs go to `dir` (empty: the system's temporary folder); at most
    /// `budget_bytes` of records are held before a run is written.
    explicit ExternalSorter(std::filesystem::path dir, size_t budget_bytes = size_t{32} << 20)
        : file_(std::move(dir), "cityatlas-sort"), cap_(std::max<size_t>(1, budget_bytes / sizeof(T))) {}
    ~ExternalSorter() { closeFile(); }
    ExternalSorter(const ExternalSorter&) = delete;
    ExternalSorter& operator=(const ExternalSorter&) = delete;

    /// Adds `v`; a failed run write (disk full) is returned here and again
    /// by forEachSorted, and later pushes are dropped.
    Status push(const T& v) {
        if (!failed_.ok()) return failed_;
        if (buffer_.size() == buffer_.capacity()) buffer_.reserve(std::min(cap_, std::max<size_t>(4096, 2 * buffer_.size())));
        buffer_.push_back(v);
        ++size_;
        if (buffer_.size() == cap_) failed_ = spill();
        return failed_;
    }
    uint64_t size() const { return size_; }
    size_t runs() const { return runs_.size(); }

    /// Every record pushed, in ascending order (operator<), then the sorter
    /// is empty again.
    Status forEachSorted(const std::function<void(const T&)>& fn) {
        if (!failed_.ok()) return failed_;
        if (runs_.empty()) {
            std::sort(buffer_.begin(), buffer_.end());
            for (const T& v : buffer_) fn(v);
        } else {
            if (!buffer_.empty())
                if (Status s = spill(); !s.ok()) return s;
            std::vector<T>().swap(buffer_);
            if (Status s = merge(fn); !s.ok()) return s;
        }
        std::vector<T>().swap(buffer_);
        closeFile();
        size_ = 0;
        return Status::Ok();
    }

private:
    struct Run {
        uint64_t first = 0, count = 0, next = 0;  // its records in the file; the next one to read
        std::vector<T> buffer;
        size_t at = 0;  // in buffer
    };

    ScratchFile file_;  // the runs
    size_t cap_;
    std::vector<T> buffer_;
    std::vector<Run> runs_;
    uint64_t written_ = 0;  // records in it
    size_t read_records_ = 1;  // a run's read buffer while merging
    uint64_t size_ = 0;
    Status failed_;

    Status spill() {
        std::sort(buffer_.begin(), buffer_.end());
        runs_.push_back(Run{written_, buffer_.size(), 0, {}, 0});
        if (Status s = file_.write(written_ * sizeof(T), buffer_.data(), buffer_.size() * sizeof(T), "sort runs"); !s.ok())
            return s;
        written_ += buffer_.size();
        buffer_.clear();
        return Status::Ok();
    }

    // Refills `r`'s buffer from its file; false at its end or on an error (`error` set).
    bool refill(Run& r, Status* error) {
        r.buffer.clear();
        r.at = 0;
        const uint64_t n = std::min<uint64_t>(r.count - r.next, read_records_);
        if (n == 0) return false;
        r.buffer.resize(n);
        if (Status s = file_.read((r.first + r.next) * sizeof(T), r.buffer.data(), n * sizeof(T), "sort runs"); !s.ok()) {
            *error = s;
            return false;
        }
        r.next += n;
        return true;
    }

    Status merge(const std::function<void(const T&)>& fn) {
        Status error;
        using Head = std::pair<T, size_t>;  // a run's smallest unread record, and the run
        auto later = [](const Head& a, const Head& b) { return b.first < a.first || (!(a.first < b.first) && b.second < a.second); };
        std::priority_queue<Head, std::vector<Head>, decltype(later)> heads(later);
        const size_t bytes = std::clamp<size_t>(cap_ * sizeof(T) / runs_.size(), size_t{4} << 10, size_t{256} << 10);
        read_records_ = std::max<size_t>(1, bytes / sizeof(T));
        for (size_t k = 0; k < runs_.size(); ++k)
            if (refill(runs_[k], &error)) heads.push({runs_[k].buffer[0], k});
        while (!heads.empty() && error.ok()) {
            const auto [v, k] = heads.top();
            heads.pop();
            fn(v);
            Run& r = runs_[k];
            if (++r.at < r.buffer.size() || refill(r, &error)) heads.push({r.buffer[r.at], k});
        }
        return error;
    }

    void closeFile() {
        file_.close();
        written_ = 0;
        runs_.clear();
    }
};

}  // namespace cityatlas
