// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Small helpers shared by the ingest tests.

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <string>

namespace cityatlas::test {

namespace detail {
// Removes a scratch folder when the test process that made it exits (not a
// forked child: it would remove its parent's files); CITYATLAS_KEEP_SCRATCH=1
// keeps them for a look after a failure.
class ScratchRemover {
public:
    explicit ScratchRemover(std::filesystem::path dir) : dir_(std::move(dir)), pid_(getpid()) {}
    ScratchRemover(const ScratchRemover&) = delete;
    ScratchRemover& operator=(const ScratchRemover&) = delete;
    ~ScratchRemover() {
        const char* keep = std::getenv("CITYATLAS_KEEP_SCRATCH");
        if (getpid() != pid_ || (keep != nullptr && *keep != '\0' && *keep != '0')) return;
        std::error_code ec;
        std::filesystem::remove_all(dir_, ec);
    }

private:
    std::filesystem::path dir_;
    pid_t pid_;
};
}  // namespace detail

/// A fresh path `name` under a per-process scratch folder `group` in the
/// system temp directory (removed first if it exists; its parent created).
/// The group's folder is removed when the process exits (see ScratchRemover).
inline std::filesystem::path scratchPath(const std::string& group, const std::string& name) {
    namespace fs = std::filesystem;
    const fs::path root = fs::temp_directory_path() / (group + "_" + std::to_string(getpid()));
    {
        static std::mutex mutex;
        static std::map<std::string, detail::ScratchRemover> removers;
        const std::lock_guard lock(mutex);
        removers.try_emplace(root.string(), root);
    }
    fs::path p = root / name;
    fs::remove_all(p);
    fs::create_directories(p.parent_path());
    return p;
}

/// The team's shared folder (real data): $CITYATLAS_SHARED, else the path the
/// build was configured with. May not exist on a user's clone: callers skip.
inline std::filesystem::path sharedDir() {
    const char* env = std::getenv("CITYATLAS_SHARED");
    if (env != nullptr && *env != '\0') return env;
#ifdef CITYATLAS_SHARED_DEFAULT
    return CITYATLAS_SHARED_DEFAULT;
#else
    return {};
#endif
}

}  // namespace cityatlas::test
