// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// The atlas images of a finished tree structure: leaves resampled from the
/// original textures, inner nodes as their children's atlases halved and
/// packed at the offsets placement.h gives.
/// Internal to the atlas stage (buildAtlasTree calls it); exposed for tests.

#include <filesystem>
#include <functional>
#include <map>
#include <set>
#include <vector>

#include "atlas/atlas_tree.h"
#include "core/srgb.h"

namespace cityatlas::atlas {

struct RenderResult {
    std::set<int32_t> unreadable_textures;  ///< their regions were filled with mid grey
    uint64_t original_texture_bytes = 0;    ///< of the textures read, 8 bits per channel
    AtlasHalves root_halves;                ///< with keep_root_halves: the root's atlases halved
};

/// Nodes whose atlases were rendered elsewhere (a sharded build's shard
/// roots). renderAtlases places their halves and does not descend below
/// them; `load` reads a node's halves when the level above is drawn, so a
/// few are held at a time, not every shard's (their number grows with the city).
struct GivenHalves {
    std::set<int32_t> nodes;
    std::function<Status(int32_t node, AtlasHalves* out)> load;
};

/// Renders and writes `tree`'s atlases (node.layers[l].atlas_path must be set
/// for every present layer) under `output_dir`, in parallel on the current
/// TBB arena. Memory in flight is a few atlases per tree level and thread;
/// decoded source textures are kept within `params.cache_mb`.
/// With a `sink`, each image goes there instead of to a PNG file.
Status renderAtlases(const Scene& scene, const AtlasTree& tree, const std::filesystem::path& output_dir,
                     const AtlasProgressFn& progress, RenderResult* result, const AtlasImageSink& sink = {},
                     const GivenHalves* given = nullptr, bool keep_root_halves = false);

/// A w x h image of `channels` floats per texel as a file of its own
/// (little-endian: int32 w, h, then the floats), exact: what a shard hands
/// the merge (root canvases, computed images). Reading checks the size
/// (0 allowed with `allow_empty`) and the length; errors name the file as `what`.
Status writeFloatImage(const std::filesystem::path& path, int w, int h, const std::vector<float>& values);
Status readFloatImage(const std::filesystem::path& path, int channels, bool allow_empty, const char* what, int* w,
                      int* h, std::vector<float>* values);

/// A canvas as a float image (above).
Status writeCanvas(const AtlasCanvas& canvas, const std::filesystem::path& path);
Status readCanvas(const std::filesystem::path& path, AtlasCanvas* canvas);

}  // namespace cityatlas::atlas
