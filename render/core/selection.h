// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Per-frame work on the atlas tree, GL-free (papers/000 §4.4, §4.6; papers/001 §4, §6):
///
/// - classifyBlocks(): the traversal "as if everything were loaded" that gives
///   every block a usage category — Needed, Culled, Parent needed, Unused —
///   and a priority (usage, then camera distance, then lower level), and the
///   candidate list in priority order from which the ideal block set is cut.
/// - selectDraws(): the rendering traversal with Fig. 30's modification: a
///   node whose atlas is not sharp enough is refined only when refinement is
///   possible (every child in the frustum drawable; for a leaf, its original
///   textures resident), so every visible triangle always has some texture.
///
/// BlockMaps (issue 20; ../shared/SEED-FEATURES.md §1.2 "Client selection"):
/// a node with one is drawn by it from its distance on, when resident, and
/// its subtree is not visited; its geometry and atlas stand in while it is
/// not. Its BlockMap is what the as-if-loaded traversal needs of it there,
/// and what it prefetches of its children (theirs, or their geometry and
/// atlases where they have none); a node refined past keeps its BlockMap
/// (rather than its geometry) resident as the fallback. The root's BlockMap
/// is pinned with the root's other blocks.
///
/// The selection threshold: a node's atlas is sharp enough at camera distance
/// d when d >= min_distance_m * scale, scale = (f * c) / (f_b * c_b) * tau_b / tau,
/// where f is the viewport's focal length in pixels and c its corner factor
/// (f_b, c_b, tau_b the build's): min distances scale with the actual
/// viewport width, height and fov, and tau (pixels per texel) relaxes them.

#include <cstdint>
#include <functional>
#include <vector>

#include "render/core/tileset_index.h"
#include "render/core/view.h"

namespace cityatlas::render {

enum class Usage : uint8_t { Needed = 0, Culled = 1, ParentNeeded = 2, Unused = 3 };
const char* usageName(Usage usage);  ///< "needed", "culled", "parent_needed", "unused"

/// How blocks of one usage category are ordered among themselves.
enum class PriorityMode : uint8_t {
    Distance,      ///< the papers: camera distance to the node's box, then lower level
    ViewWeighted,  ///< cesium-native's: distance * (1 - cos(angle between view direction and box centre))
};
const char* priorityModeName(PriorityMode mode);  ///< "distance", "view"

/// Where a leaf samples one of its texture blocks: the box (local frame) of
/// its triangles whose original textures that block holds.
struct BlockBox {
    BlockId block = kNoBlock;
    Box3d bounds;
};
/// Per block, for leaves' geometry blocks: the texture blocks its triangles
/// sample and where (from the decoded mesh's texture ranges). A leaf whose
/// geometry blocks are all `known` loads only the texture blocks seen from
/// the camera (in the frustum, closer than the leaf's min distance; papers/004
/// §2: "a street-level view loads only the tiles it sees"); otherwise each of
/// its blocks counts over the leaf's whole box.
struct TextureUse {
    bool known = false;
    std::vector<BlockBox> boxes;
};
using TextureUseMap = std::vector<TextureUse>;

struct SelectionParams {
    double tau = 1.0;                 ///< pixels per texel: > 1 accepts coarser atlases (fewer loads)
    bool originals = true;            ///< leaves closer than their min distance draw original textures
    PriorityMode priority = PriorityMode::Distance;
    /// Where leaves sample their texture blocks (not owned; null: unknown, a
    /// leaf's blocks count over its whole box).
    const TextureUseMap* texture_use = nullptr;
    /// The computed texture shown (TilesetIndex::computed), -1: none. Its
    /// blocks share their node's usage and priority; every other computed
    /// texture's blocks are Unused, so never requested (papers/000 §5.1.3).
    /// Drawability does not wait for them: a node draws with the photo
    /// until its computed block is resident.
    int computed = -1;
    /// Draw a node's BlockMap (TileNode::blockmap) from its distance on,
    /// instead of its geometry and atlas (issue 20): the BlockMap is then the
    /// block Needed, and a node whose geometry is not resident is drawable by
    /// its BlockMap (coarse when closer than its distance).
    bool blockmaps = true;
};

/// min_distance_m multiplier for this viewport (see the file comment).
double distanceScale(const BuildInfo& build, const Camera& camera, const SelectionParams& params);

struct BlockPriority {
    Usage usage = Usage::Unused;
    double key = 0;   ///< distance (or the view-weighted distance); smaller first
    int level = 0;    ///< node level (texture blocks: their leaf's level + 1); smaller first
};

/// True when block a (with priority pa) comes before block b.
bool before(const BlockPriority& pa, BlockId a, const BlockPriority& pb, BlockId b);

struct Classification {
    std::vector<BlockPriority> priority;  ///< per block
    /// Every block that is not Unused, highest priority first: the ideal block
    /// set is a prefix of it (BlockManager). The root's blocks are pinned: they
    /// lead the list whatever their usage.
    std::vector<BlockId> candidates;
    uint32_t nodes_needed = 0, nodes_culled = 0, nodes_parent_needed = 0;
};

Classification classifyBlocks(const TilesetIndex& index, const Camera& camera, const SelectionParams& params);

/// Fills `c->candidates` from `c->priority`: the root's blocks first (pinned),
/// then every block that is not Unused, highest priority first. classifyBlocks
/// ends with it; a client with its own usage rule (a reference mode) calls it too.
void orderCandidates(const TilesetIndex& index, Classification* c);

/// A node's layers' geometry and atlas blocks, and those of computed texture
/// `computed` (>= 0).
template <typename Fn>
void forEachNodeBlock(const TileNode& node, Fn&& fn, int computed = -1) {
    for (const NodeLayer& layer : node.layers) {
        if (!layer.present) continue;
        if (layer.geometry != kNoBlock) fn(layer.geometry);
        if (layer.atlas != kNoBlock) fn(layer.atlas);
        if (computed >= 0 && static_cast<size_t>(computed) < layer.computed.size() &&
            layer.computed[static_cast<size_t>(computed)] != kNoBlock)
            fn(layer.computed[static_cast<size_t>(computed)]);
    }
}

/// Whether node `n` is drawn by its BlockMap where its distance allows: it
/// has one, and BlockMaps are on (`blockmaps`) or it has nothing else
/// (`--blockmaps replace`; the client refuses BlockMaps off on such a folder).
inline bool drawsBlockMap(const TileNode& n, bool blockmaps) {
    return n.blockmap != kNoBlock && (blockmaps || n.blockmap_only);
}

/// What stands for a node that is not drawn with its own atlas at this
/// distance (a fallback on the path, the next step prefetched, a preloaded
/// level): its BlockMap where drawsBlockMap, else forEachNodeBlock's blocks.
template <typename Fn>
void forEachStandInBlock(const TileNode& n, bool blockmaps, Fn&& fn, int computed = -1) {
    if (drawsBlockMap(n, blockmaps))
        fn(n.blockmap);
    else
        forEachNodeBlock(n, fn, computed);
}

/// The root's blocks that every frame needs, always resident: its layers'
/// geometry and atlases, or its BlockMap where that is all it has.
template <typename Fn>
void forEachRootBlock(const TilesetIndex& index, Fn&& fn) {
    if (index.nodes.empty()) return;
    forEachNodeBlock(index.nodes[0], fn);
    if (index.nodes[0].blockmap_only) fn(index.nodes[0].blockmap);
}

/// All blocks of a node (both layers' geometry and atlases; not its computed
/// textures, for which the photo stands in) are resident. Never for a node
/// that has only its BlockMap (TileNode::blockmap_only).
bool nodeDrawable(const TilesetIndex& index, int32_t node, const std::function<bool(BlockId)>& resident);

/// Fig. 30's refinementPossible: an inner node's children are each drawable
/// (nodeDrawable, or with `blockmaps` or alone their BlockMap resident) or outside the
/// frustum; a leaf's original textures are all resident (selectDraws asks
/// only for those its camera sees, SelectionParams::texture_use).
bool refinementPossible(const TilesetIndex& index, int32_t node, const Frustum& frustum,
                        const std::function<bool(BlockId)>& resident, bool blockmaps = false);

/// Atlas: the node's geometry with its atlas; Originals: a leaf's geometry
/// with its original textures; BlockMap: the node's BlockMap, ray-cast.
enum class DrawMode : uint8_t { Atlas, Originals, BlockMap };

struct DrawItem {
    int32_t node = 0;
    DrawMode mode = DrawMode::Atlas;
    /// Drawn with its atlas although the camera is closer than its min distance
    /// (refinement impossible: blocks missing). The frame is still fully textured.
    bool coarse = false;
    double distance_m = 0;
};

struct Selection {
    std::vector<DrawItem> draws;     ///< depth-first order
    bool root_missing = false;       ///< the root is not drawable yet: nothing can be drawn
    uint32_t nodes_visited = 0, nodes_culled = 0, coarse_draws = 0;
    double nearest_m = 0, farthest_m = 0;  ///< over the drawn boxes (for near/far planes)
};

Selection selectDraws(const TilesetIndex& index, const Camera& camera, const SelectionParams& params,
                      const std::function<bool(BlockId)>& resident);

}  // namespace cityatlas::render
