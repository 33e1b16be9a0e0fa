// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Turns image references found in input files into Scene textures: resolves
/// the path against the referencing file's folder, reads only the image
/// header (OpenImageIO) for size and channels, never fetches remote URIs, and
/// warns once per image that is missing or unreadable. Caches by path.

#include <filesystem>
#include <string>
#include <unordered_map>

#include "ingest/diagnostics.h"
#include "ingest/scene_sink.h"

namespace cityatlas {

class TextureResolver {
public:
    TextureResolver(SceneSink& sink, Diagnostics& diagnostics) : sink_(sink), diagnostics_(diagnostics) {}

    /// Scene texture index for `uri` (relative to `base_dir`, or absolute), or
    /// -1 when it cannot be used (warned: texture_missing / texture_unreadable,
    /// with `where` as the example's place).
    int32_t resolve(const std::filesystem::path& base_dir, const std::string& uri, WrapMode wrap,
                    const DiagnosticExample& where);
    /// The image behind an index resolve() returned (path, size), or null.
    const TextureRef* info(int32_t index) const {
        auto it = refs_.find(index);
        return it == refs_.end() ? nullptr : &it->second;
    }
    uint64_t resolved() const { return ok_; }
    uint64_t failed() const { return failed_; }

private:
    SceneSink& sink_;
    Diagnostics& diagnostics_;
    std::unordered_map<std::string, int32_t> cache_;
    std::unordered_map<int32_t, TextureRef> refs_;
    uint64_t ok_ = 0, failed_ = 0;
};

}  // namespace cityatlas
