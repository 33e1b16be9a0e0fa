// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// What the client knows of a tile folder before it loads anything: the tree
/// of tileset.json (tiles/tileset.h is the contract) flattened into arrays,
/// and every loadable file as a *block* with the byte size the index gives,
/// so the memory budget can be planned before a byte is downloaded.
///
/// Blocks (papers/000 §4.6, extended to geometry): a node layer's geometry
/// (geometry/<layer>/<node>.glb), a node layer's atlas (atlas/<layer>/<node>.dds)
/// a texture block of leaves' original textures (textures/<k>.bin), and a
/// node layer's computed texture (computed/<k>/<layer>/<node>.dds, BC4; issue
/// 19) and a node's BlockMap (blockmap/<node>.bin, build --blockmaps; issue
/// 20). A node is drawable when the geometry and atlas of each of its layers
/// are resident, or, from its BlockMap's distance on, its BlockMap; computed
/// textures draw where resident (the photo stands in until they are).

#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "core/geometry.h"
#include "core/status.h"

namespace cityatlas::format {

inline constexpr int kLayerCount = 2;  ///< 0: opaque (BC1 atlas), 1: alpha (BC3 atlas, blended)
const char* layerName(int layer);      ///< "opaque", "alpha"

enum class BlockKind : uint8_t { Geometry, Atlas, Textures, Computed, BlockMap };
inline constexpr int kBlockKinds = 5;
const char* blockKindName(BlockKind kind);  ///< "geometry", "atlas", "textures", "computed", "blockmap"

using BlockId = uint32_t;  ///< index into TilesetIndex::blocks
inline constexpr BlockId kNoBlock = std::numeric_limits<BlockId>::max();

struct BlockInfo {
    BlockKind kind = BlockKind::Geometry;
    int32_t node = -1;           ///< Geometry, Atlas, Computed, BlockMap: the node; Textures: -1
    int layer = -1;              ///< Geometry, Atlas: 0 opaque, 1 alpha
    int32_t texture_block = -1;  ///< Textures: index of textures/<k>.bin; Computed: which computed texture
    std::string uri;             ///< relative to the folder / base URL
    uint64_t bytes = 0;          ///< the file's size, from tileset.json
};

struct NodeLayer {
    bool present = false;        ///< the node has triangles in this layer
    BlockId geometry = kNoBlock, atlas = kNoBlock;
    uint32_t triangles = 0;
    int atlas_width_px = 0, atlas_height_px = 0;  ///< at most BuildInfo::atlas_size_px each
    int atlas_channels = 3;      ///< 3: BC1, 4: BC3
    double geometric_error_m = 0;
    double position_error_mm = 0;
    /// Per computed texture (TilesetIndex::computed): its block, kNoBlock where none.
    std::vector<BlockId> computed;
};

struct TileNode {
    int32_t id = 0;
    int32_t parent = -1;
    int level = 0;
    std::vector<int32_t> children;   ///< node indices, quadrant order
    Box3d bounds;                    ///< local frame, metres (3D Tiles boundingVolume.box, axis-aligned)
    Vec3d centre;                    ///< geometry positions are relative to it
    double min_distance_m = 0;       ///< at the build's screen, fov and tau
    double world_texel_m = 0;
    std::array<NodeLayer, kLayerCount> layers;
    std::vector<BlockId> texture_blocks;  ///< leaves: the blocks holding their original textures
    uint64_t features = 0;
    /// The node's BlockMap (kNoBlock: none), drawn instead of its geometry
    /// from blockmap_min_distance_m on (scaled as min_distance_m is), over
    /// blockmap_bounds (its buildings in full: may reach past `bounds`).
    BlockId blockmap = kNoBlock;
    double blockmap_min_distance_m = 0;
    Box3d blockmap_bounds;
    /// `build --blockmaps replace`: the node has no layer, its BlockMap alone
    /// stands for it (drawn from its distance on; closer, its children).
    bool blockmap_only = false;
    bool leaf() const { return children.empty(); }
};

/// A leaf's original texture: a DDS inside a texture block.
struct TextureInfo {
    int32_t block = -1;          ///< texture block index; -1: not written (the leaf's atlas stands in)
    uint64_t offset = 0, bytes = 0;
    int width = 0, height = 0, channels = 3, mips = 1;
    bool wrap = true;            ///< repeat (true) or clamp to edge
};

struct MaterialInfo {
    std::array<float, 3> diffuse{0.8F, 0.8F, 0.8F};  ///< linear RGB
    float transparency = 0;
};

/// The build parameters the selection needs to scale min distances to the
/// actual viewport: a node's atlas is sharp enough at `min_distance_m *
/// (focal * corner_factor) / (build focal * build corner_factor) * build tau / tau`.
struct BuildInfo {
    double d_min_m = 0;
    int atlas_size_px = 0;
    int screen_width_px = 0, screen_height_px = 0;
    double vertical_fov_deg = 60;
    double focal_px = 0;       ///< (height / 2) / tan(fov / 2)
    double corner_factor = 1;  ///< 1 + tan^2 of the corner ray's angle
    double tau = 1;            ///< pixels per texel the build assumed
};

struct FeatureTableInfo {
    std::string uri;
    uint64_t bytes = 0;
    std::string bounds_uri;     ///< features/bounds/<k>.bin; empty in folders written before them
    uint64_t bounds_bytes = 0;
};

struct TilesetIndex {
    std::string tileset_version;       ///< asset.tilesetVersion (the build hash)
    BuildInfo build;
    std::vector<TileNode> nodes;       ///< index = node id (depth-first preorder; 0 = root)
    std::vector<BlockInfo> blocks;
    std::vector<BlockId> texture_block_ids;  ///< texture block index -> its BlockId
    std::vector<TextureInfo> textures;       ///< index = a leaf vertex's _TEXTURE_ID
    std::vector<MaterialInfo> materials;     ///< index = _MATERIAL_ID
    std::vector<FeatureTableInfo> feature_tables;
    uint64_t feature_count = 0;
    int feature_block_size = 0;
    std::optional<std::array<double, 16>> local_to_ecef;  ///< column-major; absent: no georeference
    std::string source_crs;
    uint64_t bytes_total = 0;          ///< every block
    uint64_t bytes_by_kind[kBlockKinds] = {0, 0, 0, 0, 0};  ///< indexed by BlockKind
    std::vector<std::string> computed;  ///< the computed textures' names (extras.cityatlas.computed)
    int depth = 0;                     ///< deepest level
};

/// Parses tileset.json text. Structural problems are one line naming
/// `where` (the file or URL) and the node or entry; the full schema check is
/// `cityatlas inspect`'s job, this only refuses what the client cannot use.
Status parseTilesetIndex(const std::string& text, const std::string& where, TilesetIndex* out);

}  // namespace cityatlas::format
