// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Content hashes for `cityatlas build`: a rerun with the same inputs (file
// contents, not dates), the same referenced textures and the same parameters
// finds the existing output up to date and does nothing.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/status.h"

namespace cityatlas::cli {

struct FileDigest {
    std::string path;
    uint64_t bytes = 0;
    std::string xxh3;  ///< XXH3-64 of the contents, 16 hex digits
    friend bool operator==(const FileDigest&, const FileDigest&) = default;
};

/// Hashes a file's contents (streamed); the error names the file.
Status digestFile(const std::filesystem::path& path, FileDigest* out);

/// The inputs plus the files a reader opens beside them (a shapefile's .shx,
/// .dbf, .prj, .cpg), in a stable order, duplicates removed.
std::vector<std::filesystem::path> withSidecars(const std::vector<std::filesystem::path>& inputs);

/// XXH3-64 of a list of strings (length-prefixed), 16 hex digits.
std::string hashStrings(const std::vector<std::string>& parts);

nlohmann::json toJson(const std::vector<FileDigest>& digests);
/// Empty on a malformed list.
std::vector<FileDigest> digestsFromJson(const nlohmann::json& j);

}  // namespace cityatlas::cli
