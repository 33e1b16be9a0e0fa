// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The BlockMaps of a tree's nodes (issue 20; papers/002;
/// ../shared/SEED-FEATURES.md §1.2): which nodes get one, built, measured and
/// written as `blockmap/<node>.bin` beside the node's geometry and atlases.
///
/// A node's BlockMap holds every building with a triangle in the node, in
/// full (so a sibling drawn as geometry next to it leaves no hole), on a grid
/// whose cell is the node's own world texel: it is as sharp as the node's
/// atlas and is drawn from the node's min_distance_m on. Buildings narrower
/// than a cell may hold no cell centre; they are listed as missing (below a
/// pixel from that distance on, by construction).
///
/// Which nodes (the spec's stopping rule, top-down, a branch stops at its
/// first "no"): the root, then the children of every node that got one,
/// down to level `max_level`, while the BlockMap is no larger than the
/// node's geometry and atlases together, or the node's geometry left
/// buildings out (then the BlockMap keeps what the geometry lost, at any
/// size). The level cap bounds the build: where textures are small a
/// BlockMap stays smaller than its node far down the tree, and every level
/// holds four times the BlockMaps of the one above. Rule 1 of the spec (the
/// BlockMap's distance below the parent's) holds by construction: the
/// BlockMap switches at the node's own distance. A node whose grid would
/// exceed the file's limits gets none (counted).
///
/// The nodes of one level are built in parallel (they are independent; the
/// next level follows from this one's results).
///
/// Passes per node: its buildings; their planes (atlas/blockmap.h); the rule
/// on the file's size; colours and the file (tiles/blockmap_writer.h); the
/// measured error; the write.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "atlas/atlas_tree.h"
#include "atlas/blockmap.h"
#include "core/status.h"
#include "format/tileset_document.h"
#include "ingest/scene.h"
#include "tiles/texture_codec.h"

namespace cityatlas::tiles {

/// `build --blockmaps`: none; BlockMaps beside every node's geometry and
/// atlases (standard 3D Tiles clients ignore them); or `replace`: the levels
/// BlockMaps cover completely lose their geometry and atlases (replacedLevels),
/// a folder for cityatlas clients only (a standard client draws nothing there).
enum class BlockMapMode : uint8_t { Off, Complement, Replace };
std::string_view blockMapModeName(BlockMapMode mode);  ///< "off", "complement", "replace"

/// What the rule weighs of a node as written.
struct NodeCost {
    uint64_t bytes = 0;     ///< its geometry and atlases, both layers
    bool dropped = false;   ///< its geometry left buildings out
};

/// The rule for one node: a BlockMap of `blockmap_bytes` pays against the node's cost.
bool blockMapPays(uint64_t blockmap_bytes, const NodeCost& node);

/// `build --blockmap-levels`: the deepest level that gets BlockMaps by
/// default (levels 0-3: at most 85 BlockMaps). Measured (issue 20's note):
/// the 10,000-building town's stop by bytes at level 3 by itself; the
/// 100,000-building town's (32 px facades) would go on to level 5.
inline constexpr int kDefaultBlockMapLevels = 3;

/// One level of the tree, as the BlockMap pass saw it.
struct BlockMapLevelStats {
    uint64_t tried = 0, built = 0;
    uint64_t bytes = 0;        ///< the BlockMaps written
    uint64_t node_bytes = 0;   ///< the geometry and atlases of the nodes that got one
    double worst_hausdorff_m = 0;
    uint64_t missing = 0;      ///< buildings no BlockMap of the level holds (features_missing)
    double seconds = 0;        ///< wall time of the level
};

struct NodeBlockMapStats {
    uint64_t tried = 0, built = 0;
    uint64_t declined_bytes = 0;  ///< larger than the node, which dropped nothing
    uint64_t declined_grid = 0;   ///< a grid beyond the file's limits
    uint64_t bytes = 0, gpu_bytes = 0;
    uint64_t unreadable_samples = 0;  ///< colour samples of textures that could not be read (grey)
    /// `replace`: the levels replaced (replacedLevels), their nodes, and the
    /// geometry and atlas bytes they no longer write.
    int replaced_levels = -1;
    uint64_t nodes_replaced = 0, bytes_omitted = 0;
    std::vector<BlockMapLevelStats> levels;  ///< by level, from the root
    double seconds = 0;
    /// Of which, summed over the nodes (which run in parallel): gathering and
    /// planes (all nodes tried), colours, measured error, encoding and writing.
    double seconds_planes = 0, seconds_colours = 0, seconds_error = 0, seconds_encode = 0;
};

/// `replace`: the deepest level L such that every node of levels 0..L is an
/// inner node with a BlockMap (-1: none, e.g. the root got none). Those
/// nodes' BlockMaps stand for them at every distance: from their own
/// BlockMap's distance on, and closer their children are drawn. A leaf keeps
/// its geometry (nothing finer stands for it close by).
int replacedLevels(const atlas::AtlasTree& tree, std::span<const std::optional<format::BlockMapEntry>> entries);

using BlockMapProgressFn = std::function<void(uint64_t done, uint64_t total)>;

/// Builds, measures and writes the BlockMaps of `tree`'s nodes as the file
/// comment says into out_dir/blockmap/, with each node's entry in `entries`
/// (resized to the tree; nullopt: none). `costs`: per node. `max_level`: the
/// deepest level tried (-1: no cap); `sample`: how cells are sampled. Colours come from
/// the scene's textures and materials (read through an OpenImageIO cache of
/// `cache_mb`). Deterministic.
Status writeNodeBlockMaps(const Scene& scene, const atlas::AtlasTree& tree, std::span<const NodeCost> costs,
                          int max_level, atlas::BlockMapSample sample, BcQuality quality, size_t cache_mb, const std::filesystem::path& out_dir,
                          const BlockMapProgressFn& progress, std::vector<std::optional<format::BlockMapEntry>>* entries,
                          NodeBlockMapStats* stats);

}  // namespace cityatlas::tiles
