// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Turns image references found in input files into Scene textures: resolves
/// the path against the referencing file's folder, reads only the image
/// header (OpenImageIO) for size and channels, never fetches remote URIs, and
/// warns once per image that is missing or unreadable. Caches by path.
///
/// Reading headers is a file open per image (10,000 images: ~0.4 s, 14 % of
/// ingesting the 10,000-building town), so a reader that knows the images
/// before it needs them (the CityGML reader's index pass) can prefetch():
/// one background thread reads the headers while the reader parses, and
/// resolve() takes the result. Indices, warnings and their order stay those
/// of the resolve() calls, so the Scene is the same with or without prefetch.

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "ingest/diagnostics.h"
#include "ingest/scene_sink.h"

namespace cityatlas {

/// What an image's header said, read once per path.
struct ImageHeader {
    enum class Kind { Ok, Missing, Unreadable };
    Kind kind = Kind::Missing;
    int width_px = 0, height_px = 0, channels = 0;
};

class TextureResolver {
public:
    TextureResolver(SceneSink& sink, Diagnostics& diagnostics);
    ~TextureResolver();
    TextureResolver(const TextureResolver&) = delete;
    TextureResolver& operator=(const TextureResolver&) = delete;

    /// Scene texture index for `uri` (relative to `base_dir`, or absolute), or
    /// -1 when it cannot be used (warned: texture_missing / texture_unreadable,
    /// with `where` as the example's place).
    int32_t resolve(const std::filesystem::path& base_dir, const std::string& uri, WrapMode wrap,
                    const DiagnosticExample& where);
    /// Starts reading the header of `uri` in the background (at most
    /// kMaxPrefetched waiting at a time; beyond that resolve() reads inline).
    void prefetch(const std::filesystem::path& base_dir, const std::string& uri);
    /// The image behind an index resolve() returned (path, size), or none.
    std::optional<TextureRef> info(int32_t index) const {
        const TextureTable& t = sink_.textures();
        if (index < 0 || static_cast<size_t>(index) >= t.size()) return std::nullopt;
        return t.ref(static_cast<size_t>(index));
    }
    uint64_t resolved() const { return ok_; }
    uint64_t failed() const { return failed_; }

    static constexpr size_t kMaxPrefetched = size_t{1} << 18;  // ~40 MB of paths at most

private:
    struct Prefetcher;
    SceneSink& sink_;
    Diagnostics& diagnostics_;
    std::unique_ptr<Prefetcher> prefetcher_;
    // What resolve() answered, by (path, wrap): the textures it added as
    // their indices alone, looked up through the sink's table (no second
    // copy of a city's paths), and the few that failed by their key. The
    // indices are an open-addressing table of (32 bits of the key's hash,
    // index + 1), 8 bytes a slot and at most 70 % full: 11 to 23 bytes a
    // texture of the file (a node-based set took ~40), grown without
    // reading a path back (the table keeps most of them on disk).
    struct Key {
        std::string_view path;
        WrapMode wrap;
    };
    static uint32_t hashOf(const Key& k);
    int32_t findResolved(const Key& k, uint32_t hash) const;
    void addResolved(int32_t index, uint32_t hash);
    std::vector<uint64_t> resolved_;
    size_t resolved_count_ = 0;
    std::unordered_map<std::string, int32_t> failed_keys_;
    uint64_t ok_ = 0, failed_ = 0;
};

}  // namespace cityatlas
