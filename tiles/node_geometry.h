// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// What one node of the atlas tree draws for one layer: leaves their exact
/// triangles, inner nodes their children's geometry merged and, above a
/// triangle budget, simplified under a geometric-error bound (tiles/tileset.h).
///
/// Built bottom-up: an inner node merges its children's NodeGeometry, not the
/// whole subtree, so each simplification sees at most 4 x budget triangles.
/// Errors then add up along the path (Hausdorff distances obey the triangle
/// inequality): a node's geometric_error_m is its children's largest error
/// plus what its own simplification measured, and its own bound is its world
/// texel size minus the children's error. Since world texels double per level
/// and a child's error stays below its own texel, at least half of the node's
/// texel is left for its own simplification.
///
/// Above the budget (where atlas seams lock every corner where charts meet,
/// meshopt cannot collapse a box building), whole buildings smaller than the
/// node's world texel are left out first, smallest first, until the budget
/// is met, and the rest is simplified (tiles/simplify.h): such a building
/// covers less than a pixel wherever the node is drawn. Its error is its
/// bounding-box diagonal (below the texel), so a node's error is the larger
/// of that and the drawn buildings' accumulated error; the tileset lists it
/// as dropped. This is what
/// keeps the levels above a whole city's shards small (a 100,000-building
/// root: 32,767 instead of 984,421 triangles).
///
/// What a merge holds grows with what it merges (~0.5 kB a triangle while
/// it is simplified), and where a node's texel is near its buildings' size
/// (the levels just above the shards at the default d_min) most buildings
/// are larger than the texel and stay. So a merge takes at most
/// mergeMaxTriangles(budget) triangles: above that, whole buildings are left
/// out before the merge is built, smallest first, whatever their size (the
/// same rule without the texel), until the rest fits. Its error covers
/// their largest diagonal and the tileset says so (the layer's
/// `left_out_over_cap`). Where that is below the texel (the texel rule
/// would have left them out anyway: the 400,000-building town's root, the
/// one merge of these towns over the default cap) nothing shows; where it
/// is above, the node misses buildings of a few pixels, its tile's
/// geometricError is raised to cover them, a client refines it sooner and
/// the children draw them. At the default budget the cap is 2,097,152
/// triangles (~1 GB to simplify).

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "atlas/atlas_tree.h"
#include "core/memory_gate.h"
#include "ingest/scene.h"
#include "tiles/glb_writer.h"
#include "tiles/texture_index.h"

namespace cityatlas::tiles {

struct NodeGeometry {
    /// Welded: one vertex per distinct (position, uvs, ids). Positions in the
    /// scene's local frame (double). uv_atlas is local to THIS node's atlas
    /// (0 for untextured vertices); uv_original and texture_id are kept by
    /// leaves (inner nodes keep texture_id only to tell textured vertices).
    TileMesh mesh;
    size_t triangles_source = 0;    ///< tree triangles of the subtree this stands for
    double geometric_error_m = 0;   ///< bound on the distance to the original surface
    bool simplified = false;        ///< this node's own merge was simplified
    /// Buildings this node's merge left out over its cap (mergeMaxTriangles),
    /// not for their size; 0 for almost every node.
    size_t left_out_over_cap = 0;
    bool empty() const { return mesh.indices.empty(); }
};

/// The leaf's triangles of `layer`, exact. Texture ids are mapped through
/// `texture_index` (scene texture -> tileset texture). Original uvs of a
/// repeating (wrap) texture are shifted per triangle by whole periods towards
/// 0, which changes nothing on screen with GL_REPEAT and keeps Draco's uv
/// quantization range (and so its step) small. With `split`, a triangle of a
/// texture of more than two atlases is cut at its tile lines, each piece
/// naming its tile (texture_index + 1 + tile) in the tile's coordinates
/// (tiles/texture_tiles.h, texture_blocks.h).
NodeGeometry leafGeometry(const Scene& scene, const atlas::AtlasTree& tree, int32_t node, atlas::Layer layer,
                          const TextureIndex& texture_index, bool split = false);

/// The node's children's geometry of one layer (null: no child there, or an
/// empty layer), merged into this node's atlas space and simplified to
/// `budget` triangles when larger, at a bound of `world_texel_m` minus the
/// children's error. uv_original is dropped. The children's geometry is
/// taken and freed once merged, before the simplification (near the root
/// they are the build's largest meshes). Children of more than
/// mergeMaxTriangles(budget) triangles together lose whole buildings,
/// smallest first, before they are merged (the file comment).
NodeGeometry innerGeometry(const atlas::AtlasTree& tree, int32_t node, atlas::Layer layer,
                           std::array<std::unique_ptr<NodeGeometry>, 4> children, size_t budget, double world_texel_m);
/// The most triangles one merge takes: 64 budgets (2,097,152 at the default
/// 32,768: about 1 GB while simplified, the gate's budget below), never
/// more than 2,097,152 (a larger --node-triangles keeps the memory bound)
/// nor less than the budget itself.
size_t mergeMaxTriangles(size_t budget);
/// What merging these children (innerGeometry), simplifying and encoding the
/// result holds at most, bytes; 0 when there is nothing to simplify (at most
/// `budget` triangles: a small merge).
size_t mergeEstimateBytes(const std::array<std::unique_ptr<NodeGeometry>, 4>& children, size_t budget);
/// The gate merges to simplify wait on, with their estimates: side by side
/// only within a fixed budget (1 GB), a larger one alone, over the process.
MemoryGate& mergeGate();
/// Distinct feature ids of a mesh, ascending.
std::vector<uint32_t> distinctFeatures(const TileMesh& mesh);

}  // namespace cityatlas::tiles
