// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Fixed-size records by index, kept in a scratch file (core/scratch_file.h)
/// instead of memory: what a merge holds per texture of a city and reads
/// back later, mostly in order (the written textures' entries for
/// tileset.json, the textures' digests for the build report), sometimes one
/// at a time (a texture block's digests for its cache key).
///
/// Records are written at any index, a run at a time; indices never written
/// below size() read as zero bytes (holes: T{} for the records kept here). get() reads a chunk of records at a
/// time (fast in order, correct in any); read() reads one record (random
/// access without a chunk's worth of I/O). Memory: one chunk and the
/// append buffer, whatever the count.

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <string>
#include <type_traits>
#include <vector>

#include "core/scratch_file.h"
#include "core/status.h"

namespace cityatlas {

template <class T>
class RecordFile {
    static_assert(std::is_trivially_copyable_v<T>, "records go to disk as bytes");

public:
    /// The file goes to `dir` (empty: the system's temporary folder); `what`
    /// names the records in an error.
    explicit RecordFile(std::filesystem::path dir = {}, const char* what = "records", size_t chunk = 4096)
        : file_(std::move(dir), "cityatlas-records"), what_(what), chunk_records_(std::max<size_t>(1, chunk)) {}

    /// Writes records first .. first + n - 1.
    Status write(size_t first, const T* records, size_t n) {
        if (!failed_.ok()) return failed_;
        if (Status s = flush(); !s.ok()) return s;
        if (n == 0) return Status::Ok();
        failed_ = file_.write(uint64_t{first} * sizeof(T), records, n * sizeof(T), what_);
        size_ = std::max(size_, first + n);
        chunk_first_ = kNone;
        return failed_;
    }
    /// Adds a record at size().
    Status append(const T& r) {
        if (!failed_.ok()) return failed_;
        pending_.push_back(r);
        if (pending_.size() >= chunk_records_) return flush();
        return Status::Ok();
    }
    size_t size() const { return size_ + pending_.size(); }

    /// Record `i` (T{} at or beyond size(), or after an I/O error: status()).
    T get(size_t i) {
        if (i >= size_ && i < size()) return pending_[i - size_];
        if (i >= size_ || !failed_.ok()) return T{};
        if (chunk_first_ == kNone || i < chunk_first_ || i >= chunk_first_ + chunk_.size()) {
            const size_t first = i / chunk_records_ * chunk_records_;
            chunk_.assign(std::min(chunk_records_, size_ - first), T{});
            failed_ = file_.read(uint64_t{first} * sizeof(T), chunk_.data(), chunk_.size() * sizeof(T), what_);
            chunk_first_ = failed_.ok() ? first : kNone;
            if (!failed_.ok()) return T{};
        }
        return chunk_[i - chunk_first_];
    }
    /// Record `i` alone, read from the file (T{} as get()).
    T read(size_t i) {
        if (i >= size_ && i < size()) return pending_[i - size_];
        T r{};
        if (i >= size_ || !failed_.ok()) return r;
        failed_ = file_.read(uint64_t{i} * sizeof(T), &r, sizeof(T), what_);
        return failed_.ok() ? r : T{};
    }
    /// The first failed write or read (disk full), if any.
    const Status& status() const { return failed_; }

private:
    static constexpr size_t kNone = SIZE_MAX;
    ScratchFile file_;
    const char* what_;
    size_t chunk_records_;
    size_t size_ = 0;  // records in the file (holes included)
    std::vector<T> pending_;  // appended, not yet written
    std::vector<T> chunk_;
    size_t chunk_first_ = kNone;
    Status failed_;

    Status flush() {
        if (pending_.empty() || !failed_.ok()) return failed_;
        failed_ = file_.write(uint64_t{size_} * sizeof(T), pending_.data(), pending_.size() * sizeof(T), what_);
        size_ += pending_.size();
        pending_.clear();
        chunk_first_ = kNone;
        return failed_;
    }
};

}  // namespace cityatlas
