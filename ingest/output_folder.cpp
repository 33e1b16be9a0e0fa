// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/output_folder.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <unistd.h>

#include <fmt/format.h>

namespace cityatlas {
namespace fs = std::filesystem;
namespace {

fs::path sibling(const fs::path& target, const char* suffix) {
    return target.parent_path() / (target.filename().string() + suffix);
}

// Atomic exchange of two existing paths; false when this file system (or
// kernel) cannot, with errno set.
bool exchange(const fs::path& a, const fs::path& b) {
#ifdef RENAME_EXCHANGE
    return ::renameat2(AT_FDCWD, a.c_str(), AT_FDCWD, b.c_str(), RENAME_EXCHANGE) == 0;
#else
    (void)a, (void)b;
    errno = EINVAL;
    return false;
#endif
}

// remove_all, with the files unlinked by several threads first: a previous
// output of 28,700 files (2.6 GB) took 15.8 s to remove one by one, most of
// it waiting on the file system; 8 unlinkers take well under half of that
// (6,356 files: 3.2-3.9 s -> 1.5 s). Errors are left to remove_all.
void removeFolder(const fs::path& folder, std::error_code& ec) {
    std::vector<fs::path> files;
    std::error_code walk_ec;
    for (auto it = fs::recursive_directory_iterator(folder, walk_ec); !walk_ec && it != fs::recursive_directory_iterator();
         it.increment(walk_ec))
        if (!it->is_directory(walk_ec)) files.push_back(it->path());
    constexpr size_t kThreads = 8, kMinFilesPerThread = 256;
    const size_t threads = std::min(kThreads, files.size() / kMinFilesPerThread);
    if (threads > 1) {
        std::vector<std::thread> unlinkers;
        for (size_t t = 0; t < threads; ++t)
            unlinkers.emplace_back([&, t] {
                for (size_t i = t; i < files.size(); i += threads) ::unlink(files[i].c_str());
            });
        for (std::thread& u : unlinkers) u.join();
    }
    fs::remove_all(folder, ec);
}

}  // namespace

Status recoverInterruptedOutput(const fs::path& target) {
    std::error_code ec;
    const fs::path old = sibling(target, ".old"), partial = sibling(target, ".partial");
    if (!fs::exists(target, ec) && fs::exists(old, ec)) {
        fs::rename(old, target, ec);
        if (ec)
            return Status::Io(fmt::format("{}: cannot restore the previous output from {}: {}", target.string(),
                                          old.string(), ec.message()));
    }
    removeFolder(old, ec);
    removeFolder(partial, ec);
    if (ec) return Status::Io(fmt::format("{}: cannot remove a stale working folder: {}", partial.string(), ec.message()));
    return Status::Ok();
}

Status startWorkingFolder(const fs::path& target, const fs::path& subfolder, fs::path* working) {
    if (Status s = recoverInterruptedOutput(target); !s.ok()) return s;
    *working = sibling(target, ".partial");
    std::error_code ec;
    fs::create_directories(subfolder.empty() ? *working : *working / subfolder, ec);
    if (ec) return Status::Io(fmt::format("{}: cannot create the working folder: {}", working->string(), ec.message()));
    return Status::Ok();
}

Status replaceFolder(const fs::path& finished, const fs::path& target) {
    std::error_code ec;
    if (fs::exists(target, ec) && exchange(finished, target)) {
        removeFolder(finished, ec);  // now the previous output; a kill here leaves a stale .partial, removed next run
        return Status::Ok();
    }
    // No exchange here: the previous folder moves aside first (a reader sees
    // the old or the new one, or neither in the gap; the next run restores it).
    const fs::path old = sibling(target, ".old");
    fs::remove_all(old, ec);
    const bool had_old = fs::exists(target, ec);
    if (had_old) {
        fs::rename(target, old, ec);
        if (ec) return Status::Io(fmt::format("{}: cannot move the previous output aside: {}", target.string(), ec.message()));
    }
    fs::rename(finished, target, ec);
    if (ec) {
        std::error_code ignored;
        if (had_old) fs::rename(old, target, ignored);
        return Status::Io(fmt::format("{}: cannot move into place: {}", target.string(), ec.message()));
    }
    if (had_old) removeFolder(old, ec);
    return Status::Ok();
}

}  // namespace cityatlas
