// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Content hashes for `cityatlas build`: a rerun with the same inputs (file
// contents, not dates), the same referenced textures and the same parameters
// finds the existing output up to date and does nothing.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/record_file.h"
#include "core/status.h"
#include "ingest/scene.h"

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

/// The file digest of each scene texture, aligned with Scene::textures: 16
/// bytes each (the size in 63 bits, a flag in the last; 24 with a bool
/// beside it), where FileDigest entries (path and hex text) took ~200, and a
/// map of them as many again. Every process of a build holds one a texture of
/// the city (Berlin's textured LOD2: ~10 M).
struct TextureDigest {
    uint64_t xxh3 = 0;
    uint64_t bytes : 63 = 0;
    uint64_t readable : 1 = 0;  ///< 0: the file could not be read (an ingest warning already)
    friend bool operator==(const TextureDigest&, const TextureDigest&) = default;
};
static_assert(sizeof(TextureDigest) == 16);
/// Digest t of a city's textures, wherever they are kept (the read's and the
/// merge's scratch files: core/record_file.h).
using DigestAt = std::function<TextureDigest(size_t)>;
/// Hashes every texture file once (a path that several entries share is read
/// once) into `out`, by texture (16 bytes each, on disk: the read's and the
/// plan's share of a city's textures); an error if the file fails. Repeated
/// paths are found by sorting, on disk in `scratch_dir` past 32 MB.
Status digestTextures(const TextureTable& textures, RecordFile<TextureDigest>* out,
                      const std::filesystem::path& scratch_dir = {});
/// The digest as FileDigest::xxh3 writes it (16 hex digits).
std::string hexDigest(uint64_t xxh3);
/// The readable textures as the build fingerprint lists them: each path once,
/// in first use order (`fn(index of its first entry)`); sorts on disk in
/// `scratch_dir` past 32 MB (TextureTable::forEachFirstOfPath).
void forEachFingerprintTexture(const TextureTable& textures, const DigestAt& digest,
                               const std::function<void(size_t)>& fn, const std::filesystem::path& scratch_dir = {});
/// The build hash: hashStrings of the inputs key and every fingerprint texture
/// as "path=xxh3" (the path as `path_as` writes it, when given), without
/// making that list.
std::string buildHash(const std::string& inputs_key, const TextureTable& textures, const DigestAt& digest,
                      const std::function<std::string(std::string)>& path_as = {});

/// XXH3-64 of a list of strings (length-prefixed), 16 hex digits.
std::string hashStrings(const std::vector<std::string>& parts);

nlohmann::json toJson(const std::vector<FileDigest>& digests);
/// Empty on a malformed list.
std::vector<FileDigest> digestsFromJson(const nlohmann::json& j);

}  // namespace cityatlas::cli
