// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The scene's textures, by reference: a path and what the stages read of the
/// image per triangle (size, channels, wrap).
///
/// A city has millions of textures (a textured LOD2 model writes one image per
/// wall: 15 to 25 a building), and every process of a build holds the table.
/// As `std::vector<TextureRef>` a texture took ~130 bytes: the struct, the
/// vector's spare room and its path on the heap. `TextureTable` keeps the
/// per-triangle fields inline (12 bytes), each folder once, and the file names
/// packed in 1 MiB chunks: ~43 bytes a texture for 48-character paths. Paths
/// are therefore built on request (`path(i)`), not stored as strings.

#include <cstdint>
#include <deque>
#include <filesystem>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

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
    size_t size() const { return info_.size(); }
    bool empty() const { return info_.empty(); }
    void clear();
    void push_back(const TextureRef& texture);

    const TextureInfo& operator[](size_t i) const { return info_[i]; }
    std::string path(size_t i) const;
    TextureRef ref(size_t i) const;
    /// Per texture, the first texture with the same path (entries differ by
    /// wrap mode too, so a path can repeat). Sorts on disk beyond
    /// `memory_bytes`, in `scratch_dir` (empty: the system's temporary
    /// folder; one that cannot take the file: in memory).
    std::vector<uint32_t> firstOfPath(const std::filesystem::path& scratch_dir = {},
                                      size_t memory_bytes = size_t{32} << 20) const;
    /// Replaces texture i (its old file name's bytes stay in the buffer, unused).
    void set(size_t i, const TextureRef& texture);

    /// Bytes held, spare room included (for memory budgets).
    size_t bytes() const;

private:
    struct Name {
        uint32_t folder = 0;  ///< index into folders_
        uint32_t chunk = 0;   ///< index into chunks_
        uint32_t offset = 0;  ///< in the chunk
        uint32_t length = 0;
    };
    uint32_t folderId(std::string_view folder);
    Name store(std::string_view path);

    // Deques and fixed chunks: a city's table grows without the copies (and
    // the twice-the-size moments) of a doubling vector.
    std::deque<TextureInfo> info_;
    std::deque<Name> names_at_;
    std::vector<std::string> chunks_;  ///< file names, back to back, kChunk bytes each (or one longer name)
    std::vector<std::string> folders_;
    std::unordered_map<std::string, uint32_t> folder_ids_;
};

}  // namespace cityatlas
