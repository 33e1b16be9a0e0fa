// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Small helpers shared by the ingest tests.

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace cityatlas::test {

/// A fresh path `name` under a per-process scratch folder `group` in the
/// system temp directory (removed first if it exists; its parent created).
inline std::filesystem::path scratchPath(const std::string& group, const std::string& name) {
    namespace fs = std::filesystem;
    fs::path p = fs::temp_directory_path() / (group + "_" + std::to_string(getpid())) / name;
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
