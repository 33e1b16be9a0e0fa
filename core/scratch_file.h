// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// A scratch file for data that does not fit in memory (core/external_sort.h's
/// runs, core/windowed_records.h's old records): created on the first write
/// in a given folder (empty: the system's temporary folder) and unlinked at
/// once, so nothing is left behind, even by a crash. Reads and writes at an
/// offset, whole or an error naming the folder.

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <system_error>

#include "core/status.h"

namespace cityatlas {

class ScratchFile {
public:
    /// The file will be `prefix` plus a unique suffix in `dir`.
    explicit ScratchFile(std::filesystem::path dir = {}, std::string prefix = "cityatlas-scratch")
        : dir_(std::move(dir)), prefix_(std::move(prefix)) {}
    ~ScratchFile() { close(); }
    ScratchFile(const ScratchFile&) = delete;
    ScratchFile& operator=(const ScratchFile&) = delete;
    ScratchFile(ScratchFile&& o) noexcept : dir_(std::move(o.dir_)), prefix_(std::move(o.prefix_)), fd_(o.fd_) { o.fd_ = -1; }
    ScratchFile& operator=(ScratchFile&& o) noexcept {
        if (this != &o) close(), dir_ = std::move(o.dir_), prefix_ = std::move(o.prefix_), fd_ = o.fd_, o.fd_ = -1;
        return *this;
    }

    /// Writes `bytes` bytes at `offset` (creating the file first); `what`
    /// names the data in an error.
    Status write(uint64_t offset, const void* data, size_t bytes, const char* what) {
        if (fd_ < 0) {
            std::string path = (std::filesystem::path(where()) / (prefix_ + "-XXXXXX")).string();
            fd_ = mkostemp(path.data(), O_CLOEXEC);  // not inherited by the shard workers or the merge (exec)
            if (fd_ < 0) return ioError(path, "cannot create a scratch file for", what);
            unlink(path.c_str());
        }
        const char* p = static_cast<const char*>(data);
        auto at = static_cast<off_t>(offset);
        while (bytes > 0) {
            const ssize_t n = ::pwrite(fd_, p, bytes, at);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) return ioError(where(), "cannot write", what, n == 0 ? ENOSPC : errno);
            p += n, bytes -= static_cast<size_t>(n), at += n;
        }
        return Status::Ok();
    }
    /// Reads `bytes` bytes at `offset` back (written before).
    Status read(uint64_t offset, void* data, size_t bytes, const char* what) const {
        char* p = static_cast<char*>(data);
        auto at = static_cast<off_t>(offset);
        while (bytes > 0) {
            const ssize_t n = fd_ < 0 ? -1 : ::pread(fd_, p, bytes, at);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) return ioError(where(), "cannot read back", what, n == 0 ? EIO : fd_ < 0 ? EBADF : errno);
            p += n, bytes -= static_cast<size_t>(n), at += n;
        }
        return Status::Ok();
    }
    /// Closes (and so deletes) the file.
    void close() {
        if (fd_ >= 0) ::close(fd_);
        fd_ = -1;
    }
    /// The folder the file is (or will be) in.
    std::string where() const {
        if (!dir_.empty()) return dir_.string();
        std::error_code ec;  // TMPDIR naming no folder: /tmp, and an error there if it is missing too
        const std::filesystem::path tmp = std::filesystem::temp_directory_path(ec);
        return ec ? std::string("/tmp") : tmp.string();
    }

private:
    std::filesystem::path dir_;
    std::string prefix_;
    int fd_ = -1;

    // "folder: what: reason" (a write or read that returns 0 sets no errno: its reason is given).
    static Status ioError(const std::string& where, const char* action, const char* what, int error = errno) {
        return Status::Io(where + ": " + action + " " + what + ": " + std::strerror(error));
    }
};

}  // namespace cityatlas
