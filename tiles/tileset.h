// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The tiles stage: an AtlasTree (with its atlas PNGs) -> a static folder that
/// any web server can host and a client can stream node by node; and the
/// checker for such folders (`cityatlas inspect`).
///
/// The folder
/// ----------
///   tileset.json                 the index; schemas/tileset.schema.json (3D Tiles 1.1 conventions)
///   geometry/<layer>/<node>.glb  glTF 2.0 binary, one Draco primitive (tiles/glb_writer.h)
///   atlas/<layer>/<node>.dds     the node's atlas, BC1 (opaque) / BC3 (alpha), full mip chain; as large
///                                as its content (width_px x height_px in the index, at most A x A)
///   computed/<k>/<layer>/<node>.dds  computed texture k of the node layer (issue 19; tiles/computed_files.h):
///                                BC4, 1/scale of the atlas per axis, full mip chain; written by the shards
///   textures/<block>.bin         originals of the textures some leaf's atlas holds below their own
///                                resolution (all used textures with all_originals): DDS files back to back
///   features/<table>.json        feature attributes, `block_size` consecutive ids per table
///   features/bounds/<table>.bin  the same features' boxes, base heights and longest-wall azimuths,
///                                32 bytes each (format/feature_bounds.h)
///   blockmap/<node>.bin          with build --blockmaps: the node's buildings as a BlockMap
///                                (tiles/node_blockmaps.h, format/blockmap_file.h)
///   build_report.json            written by `cityatlas build` (schemas/build_report.schema.json)
/// <layer> is "opaque" or "alpha"; <node> the node index (depth-first preorder).
///
/// Every node can be drawn on its own: its geometry file holds ALL triangles of
/// its subtree for that layer (leaves: exactly the tree's triangles, with
/// original and atlas texture coordinates and texture ids; inner nodes: the
/// children's geometry merged, and simplified with meshoptimizer when it
/// exceeds `node_triangles`, at a measured geometric error below the node's
/// world texel size). Atlas coordinates in a node's file are local to that
/// node's atlas ([0,1]^2, no root-space scale), so float32 and Draco's
/// quantization never lose precision with depth.
///
/// A leaf lists the texture blocks of the originals it needs; a leaf that
/// lists none holds every texture exactly in its atlas and is drawn from it
/// at any distance. Textures no leaf needs have an entry (leaf geometry names
/// them) with block -1 and original "exact".
///
/// Vertex attributes: POSITION (relative to the node's `centre`), TEXCOORD_n
/// (named by the primitive's extras.cityatlas_texcoords: "original" in leaves,
/// "atlas" everywhere), _FEATURE_ID_0 (building index), _TEXTURE_ID (leaves;
/// index into tileset textures, -1 untextured), _MATERIAL_ID (index into
/// tileset materials for an untextured vertex; -1 for textured ones and for
/// untextured ones without a material).

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "atlas/atlas_tree.h"
#include "ingest/diagnostics.h"
#include "ingest/scene.h"
#include "core/status.h"
#include "format/feature_bounds.h"
#include "format/tileset_document.h"
#include "tiles/glb_writer.h"
#include "tiles/node_blockmaps.h"
#include "tiles/node_geometry.h"
#include "tiles/texture_blocks.h"
#include "tiles/texture_codec.h"

namespace cityatlas::tiles {

/// Bumped whenever the writer's output changes for the same inputs and
/// parameters, so `cityatlas build` does not take an older folder as up to date.
inline constexpr int kWriterRevision = 11;  // 11: a merge above mergeMaxTriangles leaves whole buildings out first (10: originals of more than two atlases split into overlapping tiles (9: sub-texel buildings left out before simplifying, features/bounds/<k>.bin (8: position bits no finer than float32 resolves at the node (7: above the node budget, buildings smaller than a texel left out; 6: tileset textures numbered by scene order))

struct TilesParams {
    DracoSettings draco;                  ///< position_bits 14 (the minimum), uv_bits 12 by default
    /// Largest position error allowed per node, metres: a node whose extent
    /// needs more than draco.position_bits for it gets more (up to 30). 0:
    /// exactly draco.position_bits everywhere.
    double position_error_target_m = 0.002;
    /// Largest error of a leaf's original texture coordinates, in texels of
    /// the leaf's largest texture (so at most that in any triangle's own
    /// texture): leaves get more than draco.uv_bits for their
    /// original uvs where the uv extent (repeating textures) needs it. 0:
    /// draco.uv_bits everywhere.
    double uv_original_error_target_texels = 0.125;
    BcQuality bc_quality = BcQuality::Fast;
    size_t node_triangles = 32768;        ///< per inner node and layer; above it the merge is simplified
    int feature_block_size = 4096;        ///< feature ids per features/<table>.json
    int threads = 0;                      ///< 0 = all cores
    /// false: only the originals some leaf holds below their own resolution
    /// (AtlasNode::originals); true: every used texture's, listed by every
    /// leaf that uses it (reference renderings, other clients).
    bool all_originals = false;
    /// Originals of more than two atlases of texels as overlapping tiles,
    /// each its own tileset texture, the leaves' triangles cut at the tile
    /// lines (texture_blocks.h, texture_tiles.h). Off by default until the
    /// client loads tiles by what it sees: today a leaf loads every tile it
    /// uses, so only textures spread over many leaves (an orthophoto) gain.
    bool split_originals = false;
    /// Also every atlas as PNG, under the hand-off's PNG folder: what the 3D
    /// Tiles export embeds (`build --format 3dtiles|both`), a sharded build's
    /// shards and merge included.
    bool atlas_png = false;
    /// BlockMaps for the far field (tiles/node_blockmaps.h): single-process
    /// builds only for now (a sharded build refuses them).
    BlockMapMode blockmaps = BlockMapMode::Off;
    int blockmap_levels = kDefaultBlockMapLevels;  ///< the deepest level tried (-1: all)
    /// How a BlockMap's cells are sampled (atlas/blockmap.h): centre (the
    /// paper's) or max of 4 x 4 (conservative: silhouettes up to a cell
    /// wider).
    atlas::BlockMapSample blockmap_sample = atlas::BlockMapSample::Centre;
};

struct TilesStepStats {
    std::string name;
    double seconds = 0;
    double peak_rss_mb = 0;
    double cpu_seconds = 0;  ///< user + system over all threads and helper processes (core/resource_usage.h)
};

struct TilesStats {
    uint64_t nodes = 0, leaves = 0, depth = 0;
    uint64_t geometry_files = 0, atlas_files = 0, texture_blocks = 0, feature_tables = 0;
    uint64_t bytes_geometry = 0, bytes_atlases = 0, bytes_textures = 0, bytes_features = 0, bytes_tileset = 0;
    uint64_t triangles_written = 0;        ///< over all geometry files
    uint64_t nodes_simplified = 0;         ///< node layers whose geometry was simplified
    uint64_t nodes_capped = 0;             ///< node layers whose merge left buildings out over its cap
    uint64_t buildings_left_out_over_cap = 0;  ///< over those node layers (a building once per node layer)
    uint64_t merge_triangles_max = 0;      ///< the cap: mergeMaxTriangles(node_triangles)
    double max_position_error_m = 0;       ///< Draco quantization, measured, over all nodes
    int position_bits_min = 0, position_bits_max = 0;  ///< as used over node layers
    double max_geometric_error_m = 0;      ///< simplification, measured, over all nodes
    double max_geometric_error_fraction = 0;  ///< geometric_error / world_texel, largest over nodes (< 1 but where a merge was capped)
    double max_uv_atlas_error_texels = 0;  ///< quantization of atlas coordinates, in atlas texels
    double max_uv_original_error_texels = 0;  ///< leaves' original coordinates, in texels of their textures
    int uv_original_bits_max = 0;             ///< most bits given to a leaf's original coordinates
    uint64_t root_features = 0;            ///< distinct feature ids in the root's geometry
    std::vector<uint32_t> root_features_dropped;  ///< subtree features absent from the root's geometry
    uint64_t textures_written = 0, textures_unreadable = 0;
    uint64_t textures_exact = 0;           ///< held exactly by the atlases: no original written
    uint64_t bytes_originals_bc = 0;       ///< every used texture as BC with mips (written or not): the ratio's base
    double atlas_psnr_min_db = 0, atlas_psnr_mean_db = 0;  ///< BC level 0 vs the atlas PNG, RGB, over inexact atlases
    uint64_t atlas_files_exact = 0;  ///< atlases whose BC level 0 equals the PNG (infinite PSNR, psnr_db null)
    double atlas_encode_mpix_per_s = 0;    ///< BC encoding of atlas mip chains (all levels), per second of encoding
    NodeBlockMapStats blockmaps;           ///< with TilesParams::blockmaps
    std::vector<TilesStepStats> steps;
};

/// (atlas bytes + original-block bytes) / (every used texture as BC with mips): what
/// the folder's textures cost over the data's own; 0 without textures.
double textureRatio(const TilesStats& s);

/// Writes a whole file; a failure (a full disk often shows only at fclose) is
/// one line naming the file and the errno's reason.
Status writeBytes(const std::filesystem::path& path, const void* data, size_t size);
/// Reads a whole file into `out`; a failure is one line naming the file.
Status readBytes(const std::filesystem::path& path, std::vector<uint8_t>* out);

using TilesProgressFn = std::function<void(const char* step, uint64_t done, uint64_t total)>;

/// One node layer's atlas as written: a DDS with its full mip chain.
struct EncodedAtlas {
    std::string uri;            ///< atlas/<layer>/<node>.dds, relative to the output folder; empty: none
    uint64_t bytes = 0;
    int mips = 0;
    double psnr_db = 0;         ///< level 0 decoded against the image; +inf when BC reproduces it exactly
    double encode_seconds = 0;  ///< mips + BC, without the PSNR and the write
    uint64_t texels = 0;        ///< of all mip levels
};

/// Encodes one atlas image as the atlas stage renders it (atlas::AtlasImageSink:
/// sRGB, rows top-down, straight alpha) to out_dir/atlas/<layer>/<node>.dds,
/// BC1 for 3 channels and BC3 for 4; creates the folder if needed.
/// Thread-safe; the bytes depend only on the image and `quality`.
Status encodeAtlas(const format::Image8& image, int32_t node, atlas::Layer layer, BcQuality quality,
                   const std::filesystem::path& out_dir, EncodedAtlas* out);

/// Atlases encoded while the atlas stage rendered them, by node and layer.
using EncodedAtlases = std::vector<std::array<EncodedAtlas, atlas::kLayerCount>>;

/// The build's in-memory hand-off from the atlas stage to this one: a sink
/// (atlas::buildAtlasTree) that encodes each atlas to out_dir as soon as it is
/// rendered, and the record of what it wrote, for writeTileset. With a
/// `png_dir`, each atlas is also written there as the PNG the atlas stage
/// would have written (the 3D Tiles export reads those).
class AtlasHandOff {
public:
    AtlasHandOff(BcQuality quality, std::filesystem::path out_dir, std::filesystem::path png_dir = {});
    atlas::AtlasImageSink sink();
    /// What was encoded, for a tree of `nodes` nodes; call after the atlas stage.
    EncodedAtlases take(size_t nodes);

private:
    BcQuality quality_;
    std::filesystem::path out_dir_, png_dir_;
    std::mutex mutex_;
    std::map<int32_t, std::array<EncodedAtlas, atlas::kLayerCount>> by_node_;
};

/// What the tileset records of one layer of one node (tileset.json fields, before the index is written).
struct LayerRecord {
    bool present = false;
    size_t triangles = 0, triangles_source = 0;
    std::string geometry_uri;
    uint64_t geometry_bytes = 0;
    double geometric_error_m = 0, position_error_m = 0, uv_atlas_error_texels = 0;
    double uv_original_error_texels = -1;  // -1: no original uvs (inner nodes)
    int position_bits = 0, uv_original_bits = 0;
    bool simplified = false;
    size_t left_out_over_cap = 0;  // buildings the merge left out over its cap (node_geometry.h)
    std::string atlas_uri;  // empty: no atlas
    uint64_t atlas_bytes = 0;
    int atlas_mips = 0;
    double atlas_psnr_db = 0;
    double atlas_encode_seconds = 0;
    uint64_t atlas_texels = 0;  // all mip levels
};

struct NodeRecord {
    std::array<LayerRecord, atlas::kLayerCount> layers;
    std::vector<uint32_t> features;  // in the geometry, after encoding
    std::vector<uint32_t> dropped;
    std::string error;               ///< first failure in this node
};

/// A shard's part of the tiles stage (cli/shards.h): its subtree's files and
/// what the levels above it need from it.
struct SubtreeFiles {
    std::vector<NodeRecord> records;  ///< per node of the subtree
    std::array<std::unique_ptr<NodeGeometry>, atlas::kLayerCount> root_geometry;  ///< the root's, per layer
    std::vector<uint32_t> root_subtree_features;  ///< every feature of the subtree, ascending
};

/// Writes the geometry and atlas files of every node of `tree` (the shard's
/// subtree, numbered from 0 at its root) into out_dir, naming tileset
/// textures through `texture_index` (the whole build's); no index, no feature
/// tables, no original textures: the merge writes those.
Status writeSubtreeFiles(const Scene& scene, const atlas::AtlasTree& tree, const std::filesystem::path& atlas_dir,
                         const TilesParams& params, const TextureIndex& texture_index,
                         const std::filesystem::path& out_dir, const TilesProgressFn& progress,
                         const EncodedAtlases* encoded, SubtreeFiles* out);

/// The feature tables as written: features/<k>.json (attributes) and
/// features/bounds/<k>.bin (format/feature_bounds.h), `block_size` features each.
struct FeatureTables {
    std::vector<format::FileEntry> tables;
    std::vector<format::FileEntry> bounds;  ///< one per table, the same features
    uint64_t features = 0;
};
/// `bounds` has one record per feature (tiles/feature_bounds.h).
Status writeFeatureTables(const std::vector<Feature>& features, std::span<const format::FeatureBoundsRecord> bounds,
                          int block_size, const std::filesystem::path& out_dir, FeatureTables* out);

/// The same tables written as the features come, in id order, one block in
/// memory at a time (a city's features never all at once; ingest/feature_spill.h).
class FeatureTablesWriter {
public:
    FeatureTablesWriter(std::filesystem::path out_dir, int block_size);
    Status add(Feature&& f, const format::FeatureBoundsRecord& bounds);  ///< writes a block when it is full
    Status finish(FeatureTables* out);                                   ///< writes the last block

private:
    Status flush();
    std::filesystem::path out_dir_;
    size_t block_size_;
    bool created_ = false;
    std::vector<Feature> block_;
    std::vector<format::FeatureBoundsRecord> boxes_;
    FeatureTables tables_;
};

/// The features of the tables `tables` (uris relative to `folder`, in
/// table order) appended to `out`, as FeatureTablesWriter wrote them; ids
/// must follow on (table k's "first" = the features read before it).
Status readFeatureTables(const std::filesystem::path& folder, const std::vector<format::FileEntry>& tables,
                         std::vector<Feature>* out);

/// The parts of a tree whose files shards wrote (cli/shards.h): writeTileset
/// then builds only the nodes above them, from their root geometry, and
/// indexes everything.
struct BuiltSubtrees {
    std::vector<uint8_t> built;                  ///< per node: 1 when a shard wrote its files
    std::vector<NodeRecord> records;             ///< per node; those of built nodes as the shards wrote them
    /// A shard root's geometry, per layer (null: none), read when the levels
    /// above merge it and freed once they have: a few shards' at a time, not
    /// every shard's (their number grows with the city).
    std::function<Status(int32_t shard_root, std::array<std::unique_ptr<NodeGeometry>, atlas::kLayerCount>* out)>
        root_geometry;
    std::map<int32_t, std::vector<uint32_t>> subtree_features;  ///< by shard root
    TextureIndex texture_index;                  ///< scene -> tileset texture (the plan's; writeTileset moves it into its TextureBlocks and back)
    std::vector<std::vector<int32_t>> leaf_textures;  ///< per node, for --originals all (texture_blocks.h)
    std::vector<std::vector<int32_t>> leaf_tiles;     ///< per node: the tiles of split textures it uses (leafTiles)
    std::optional<FeatureTables> feature_tables;  ///< written already (by the plan); else from the scene's features
    BlockCache* block_cache = nullptr;            ///< original-texture blocks kept between builds (texture_blocks.h)
    /// Computed textures (issue 19), written already (tiles/computed_files.h):
    /// their entries, and per node and layer their files, aligned with them.
    std::vector<format::ComputedTextureEntry> computed;
    std::vector<std::array<std::vector<format::ComputedFileEntry>, atlas::kLayerCount>> computed_files;
};

/// Writes the folder for `tree` (built from `scene`, its atlas PNGs under
/// `atlas_dir/atlas/<layer>/<node>.png`) into `out_dir` (which must exist;
/// files are created inside it). `build_hash` (16 hex digits) becomes
/// asset.tilesetVersion. An original texture that cannot be read is a counted
/// warning (its entry gets block -1); any write failure is an error naming the
/// file. Deterministic for any thread count.
/// Atlases: with `encoded` (the build's in-memory hand-off) they are already
/// in out_dir (a layer the geometry step leaves empty has its DDS removed);
/// without, they are read from the atlas stage's PNGs under `atlas_dir` and
/// encoded here. The folder is byte-identical either way.
Status writeTileset(const Scene& scene, const atlas::AtlasTree& tree, const std::filesystem::path& atlas_dir,
                    const TilesParams& params, const std::filesystem::path& out_dir, const std::string& build_hash,
                    Diagnostics& diagnostics, const TilesProgressFn& progress, TilesStats* stats,
                    const EncodedAtlases* encoded = nullptr, BuiltSubtrees* built = nullptr,
                    const FeatureTables* feature_tables = nullptr);

/// The schema of tileset.json (schemas/tileset.schema.json, compiled in).
const nlohmann::json& tilesetSchema();

}  // namespace cityatlas::tiles
