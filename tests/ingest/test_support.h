// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Small helpers shared by the ingest tests.

#include <unistd.h>

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

}  // namespace cityatlas::test
