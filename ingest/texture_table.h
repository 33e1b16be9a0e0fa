// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The scene's textures, by reference: a path and what the stages read of the
/// image per triangle (size, channels, wrap).
///
/// A city has millions of textures (a textured LOD2 model writes one image per
/// wall: 15 to 25 a building), and every process of a build holds the table.
/// As `std::vector<TextureRef>` a texture took ~130 bytes: the struct, the
/// vector's spare room and its path on the heap; packed in memory (until
/// stop 53) ~43 bytes. `TextureTable` keeps in memory what the stages read
/// per triangle, at random (12 bytes), and where the path is (8 bytes); the
/// paths themselves, past their first MiB, go to a scratch file (in the
/// build's folder) and are read back on request (`path(i)`: a `pread`, the
/// page cache's memory, not the process's). A table that never passes a MiB
/// (a few tens of thousands of textures) has no file. Where no file can be
/// made (a full disk) the paths stay in memory, as they would have.
///
/// Since stop 54 the 20 bytes a texture stop growing too: past
/// `memory_bytes` (64 MiB, about 3.3 million textures) the entries go to a
/// scratch file by pages (core/paged_column.h), the ones read most recently
/// kept in memory. Every process of a build holds at most that, whatever the
/// city's size.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "core/paged_column.h"
#include "core/scratch_file.h"

namespace cityatlas {

/// CityGML app:wrapMode values.
enum class WrapMode : uint8_t { None, Wrap, Mirror, Clamp, Border };
std::string_view wrapModeName(WrapMode w);  ///< "none", "wrap", ...

/// A texture without its path: what the stages read per triangle.
struct TextureInfo {
    int32_t width_px = 0;
    int32_t height_px = 0;
    uint8_t channels = 0;  ///< 3 = RGB, 4 = RGBA (alpha is meaningful)
    WrapMode wrap = WrapMode::Wrap;
};

/// A texture image by reference, as readers add it. Pixels are not loaded at ingest.
struct TextureRef {
    std::string path;  ///< absolute, or relative to the current directory
    int width_px = 0;
    int height_px = 0;
    int channels = 0;  ///< 3 = RGB, 4 = RGBA (alpha is meaningful)
    WrapMode wrap = WrapMode::Wrap;
    operator TextureInfo() const { return {width_px, height_px, static_cast<uint8_t>(channels), wrap}; }
};

class TextureTable {
public:
    /// 64 MiB, or CITYATLAS_TABLE_MEMORY_MB (for measurements: the paged
    /// path on a city smaller than the default's 3.3 million textures).
    static size_t defaultMemoryBytes();
    /// Paths past the first MiB go to a scratch file in `scratch_dir`
    /// (empty, or by default: the system's temporary folder), and so do the
    /// entries past `memory_bytes` (their sizes and where their paths are).
    TextureTable() : TextureTable(std::filesystem::path()) {}
    explicit TextureTable(std::filesystem::path scratch_dir, size_t memory_bytes = defaultMemoryBytes());
    TextureTable(const TextureTable& other);
    TextureTable& operator=(const TextureTable& other);
    TextureTable(TextureTable&&) = default;
    TextureTable& operator=(TextureTable&&) = default;
    /// Where the paths go once they pass a MiB; for a table whose paths are
    /// all still in memory (a build names its folder before the read).
    void setScratchDir(const std::filesystem::path& scratch_dir);

    size_t size() const { return entries_.size(); }
    bool empty() const { return entries_.empty(); }
    void clear();
    void push_back(const TextureRef& texture);

    /// Texture i's size, channels and wrap (safe from many threads at once).
    TextureInfo operator[](size_t i) const { return entries_.get(i).info; }
    /// Texture i's path (read back from the scratch file for most of a
    /// city's: call it once per use, not in a loop over triangles). Throws
    /// std::runtime_error if the file cannot be read back (a failing disk).
    std::string path(size_t i) const;
    TextureRef ref(size_t i) const;
    /// Calls fn(t, first) for every texture t in ascending order, `first`
    /// the first texture with the same path (entries differ by wrap mode
    /// too, so a path can repeat). Sorts on disk beyond `memory_bytes` (twice:
    /// by path hash, then back by texture), in `scratch_dir` (empty: the
    /// system's temporary folder; one that cannot take the file: in memory,
    /// 8 bytes a texture). Until stop 55 this was a vector filled in hash
    /// order, 4 bytes a texture of the city in the read and the merge.
    void forEachFirstOfPath(const std::function<void(size_t t, size_t first)>& fn,
                            const std::filesystem::path& scratch_dir = {},
                            size_t memory_bytes = size_t{32} << 20) const;
    /// Replaces texture i (its old path's bytes stay where they were, unused).
    void set(size_t i, const TextureRef& texture);

    /// Bytes held in memory, spare room included (for memory budgets).
    size_t bytes() const;
    /// Bytes of paths and entries in scratch files (0: none, or no file could be made).
    uint64_t bytesOnDisk() const { return on_disk_ + entries_.bytesOnDisk(); }

private:
    // A path's place: its offset among all paths written (40 bits: 1 TiB)
    // and its length (24 bits: 16 MiB; a longer one, which no file system
    // can open, is cut there and reads as unreadable).
    static constexpr unsigned kLengthBits = 24;
    uint64_t append(std::string_view path);
    void seal();  // the paths in memory to the file (or kept in memory)

    // What the table keeps a texture: 20 bytes (the place in two halves,
    // so that the entry packs to 4-byte alignment).
    struct Entry {
        TextureInfo info;
        uint32_t at_low = 0, at_high = 0;
        uint64_t at() const { return uint64_t{at_high} << 32 | at_low; }
    };
    static_assert(sizeof(Entry) == 20);
    Entry entry(const TextureRef& texture);

    std::filesystem::path scratch_dir_;
    PagedColumn<Entry> entries_;  // paged beyond the budget: no doubling copies of a city's table
    std::string tail_;        ///< the newest paths, back to back, from offset tail_at_
    uint64_t tail_at_ = 0;    ///< bytes of paths before tail_ (in the file or kept_)
    uint64_t on_disk_ = 0;    ///< bytes of paths in file_, from offset 0
    ScratchFile file_;
    std::vector<std::string> kept_;  ///< sealed paths that the file could not take, from offset on_disk_
    std::vector<uint64_t> kept_at_;  ///< each kept_ chunk's first offset
};

}  // namespace cityatlas
