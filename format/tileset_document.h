// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// tileset.json as value types: everything the file says, field for field
/// (tiles/tileset.h is the contract, schemas/tileset.schema.json its schema).
/// One model of the folder's index for everyone: the writer fills a
/// TilesetDocument and serializes it with writeTilesetDocument, `inspect`
/// reads each tile with readTileEntry and checks it against the files, and
/// the client's TilesetIndex (format/tileset_index.h) is derived from the
/// document readTilesetDocument returns. writeTilesetDocument(read(text))
/// reproduces the writer's text byte for byte (tests/format).
///
/// The reader is strict about what the client needs (a missing or
/// ill-typed uri, byte size, box, centre, distance or build parameter is an
/// error naming the node or entry) and lenient about what only reports use:
/// a missing statistic takes its default (the schema check in `inspect`
/// reports it), an ill-typed one is an error.

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "core/geometry.h"
#include "core/status.h"

namespace cityatlas::format {

inline constexpr int kTileLayers = 2;  ///< 0: opaque, 1: alpha (as format::kLayerCount)

struct FileEntry {
    std::string uri;     ///< relative to the folder, never leaving it
    uint64_t bytes = 0;  ///< the file's size
};

struct AtlasEntry {
    FileEntry file;
    std::string format = "BC1";       ///< "BC1" (opaque) or "BC3" (alpha)
    int width_px = 0, height_px = 0;
    std::array<int64_t, 2> offset{};  ///< texels, in the level's virtual atlas (atlas/atlas_tree.h)
    int mips = 0;
    double psnr_db = 0;               ///< level 0 against the PNG atlas, 0.01 dB steps; +inf (null in the file): exact
};

/// One computed texture of a node layer (issue 19): single-channel BC4 over
/// the layer's atlas coordinates, 1/scale of its atlas's texels per axis.
struct ComputedFileEntry {
    FileEntry file;
    int width_px = 0, height_px = 0;
    int mips = 0;
};

struct LayerEntry {
    uint64_t triangles = 0, triangles_source = 0;
    FileEntry geometry;
    double geometric_error_m = 0, position_error_mm = 0;
    int position_bits = 0;
    double uv_atlas_error_texels = 0;
    bool simplified = false;
    uint64_t left_out_over_cap = 0;  ///< buildings the merge left out over its cap (written when > 0)
    std::optional<AtlasEntry> atlas;                  ///< absent: the layer draws with material colours
    std::optional<double> uv_original_error_texels;   ///< leaves with original uvs only
    int uv_original_bits = 0;                         ///< with uv_original_error_texels
    /// Aligned with TilesetDocument::computed; an empty uri: none for this layer.
    std::vector<ComputedFileEntry> computed;
};

/// A node's BlockMap (issue 20; format/blockmap_file.h): its buildings, in
/// full, as prisms on a grid of the node's own texel size, for the client to
/// ray-cast from `min_distance_m` on instead of the node's geometry.
struct BlockMapEntry {
    FileEntry file;                    ///< blockmap/<node>.bin
    uint64_t gpu_bytes = 0;            ///< its planes as uploaded (cells 16 B, columns 16 B, ids 4 B, colour RGB8)
    std::array<int64_t, 2> grid{};     ///< cells along x and y
    double texel_m = 0;                ///< the cell's side
    Vec3d origin;                      ///< local frame: the grid's corner (x, y) and the bottom of the height range
    double z_top_m = 0;                ///< top of the height range (local frame)
    uint64_t columns = 0;              ///< wall columns (one per exposed side)
    std::array<int64_t, 2> wall_px{};  ///< the wall image
    double hausdorff_m = 0;            ///< measured two-sided distance to the buildings it holds (a quarter-cell sampling)
    double voxel_bound_m = 0;          ///< half the diagonal of a cell and a height quantum: the error of flat prisms
    double min_distance_m = 0;         ///< drawn from this distance on (the node's own)
    uint64_t features = 0;             ///< buildings holding at least one cell
    /// The node's buildings holding no cell (smaller than a cell, or covered
    /// by a neighbour): below a pixel from min_distance_m on.
    std::vector<uint32_t> features_missing;
};

/// One tile (= one atlas-tree node); tiles are stored in depth-first preorder.
struct TileEntry {
    // 3D Tiles
    std::array<double, 12> box{};      ///< boundingVolume.box: centre, then three half axes
    double geometric_error = 0;        ///< min_distance_m / focal_px
    std::string refine = "REPLACE";
    std::optional<std::array<double, 16>> transform;  ///< root only: local_to_ecef
    std::vector<std::string> contents;  ///< content uris: the present layers' geometry, opaque first
    int32_t parent = -1;
    std::vector<int32_t> children;     ///< preorder indices, quadrant order
    // extras.cityatlas
    int32_t id = 0;
    int level = 0, quadrant = -1;      ///< quadrant in the parent; -1 for the root
    double min_distance_m = 0, sharp_from_m = 0, world_texel_m = 0;
    Vec3d centre;                      ///< geometry positions are relative to it
    std::array<std::optional<LayerEntry>, kTileLayers> layers;
    uint64_t feature_count = 0;
    std::vector<uint32_t> features_dropped;  ///< features of the subtree this node's geometry lost
    std::vector<uint32_t> feature_tables;    ///< indices of the tables holding its features
    std::vector<int64_t> texture_blocks;     ///< leaves: texture block indices
    uint64_t bytes = 0;                      ///< geometry + atlases of both layers
    std::optional<BlockMapEntry> blockmap;   ///< absent: none (build --blockmaps off, or the node's rule said no)
    bool leaf() const { return children.empty(); }
};

struct TextureEntry {
    int32_t block = -1;  ///< -1: not written (the leaf's atlas stands in)
    uint64_t offset = 0, bytes = 0;
    int width = 1, height = 1;
    std::string format = "BC1";
    int mips = 1;
    std::string wrap = "repeat";    ///< "repeat" or "clamp"
    std::string original;           ///< "written", "exact" or "unreadable"
};

struct MaterialEntry {
    std::array<double, 3> diffuse{0.8, 0.8, 0.8};
    double transparency = 0;
};

struct GeoreferenceEntry {
    std::string source_crs;
    Vec3d origin_source;
    bool grid_frame = false;
    std::optional<std::array<double, 16>> local_to_ecef, enu_to_ecef;  ///< column-major; absent: null
};

struct BuildEntry {
    double d_min_m = 0, d_min_requested_m = 0;
    int atlas_size_px = 0, border_px = 0;
    double tau = 1;
    int screen_width_px = 0, screen_height_px = 0;
    double vertical_fov_deg = 60, focal_px = 0, corner_factor = 1;
    std::string filter, packing;
    bool unique_charts = false;  ///< --unique-charts (absent: off)
    int position_bits = 0;
    double position_error_target_mm = 0;
    int uv_bits = 0;
    std::string bc_quality, originals, d_min_chosen_by;
    uint64_t node_triangles = 0;
    std::string geometry_encoder, texture_encoder;
    std::string blockmaps = "off";  ///< --blockmaps: "off" (absent from the file) or "complement"
};

/// A computed texture the folder carries (`build --computed`): its model and
/// parameters, the range of its values and statistics over the leaves' texels.
struct ComputedTextureEntry {
    std::string name;             ///< "sky_view", "sun_hours", "shadow"
    std::string parameters_json;  ///< the model's parameters, a JSON object (atlas/computed_spec.h)
    int scale = 4;                ///< computed texels per atlas texel, per axis: 1 / scale
    std::string format = "BC4";
    std::array<double, 2> range{0, 1};  ///< value = range[0] + code / 255 * (range[1] - range[0])
    uint64_t texels = 0;          ///< leaf texels holding a value
    double min = 0, max = 0, mean = 0;
    uint64_t bytes = 0;           ///< of all its files
};

struct TotalsEntry {
    uint64_t nodes = 0, leaves = 0, depth = 0;
    uint64_t bytes_geometry = 0, bytes_atlases = 0, bytes_textures = 0, bytes_features = 0, bytes_originals_as_bc = 0;
    double texture_ratio = 0;
    uint64_t bytes_blockmaps = 0;  ///< absent from the file when 0
};

struct TilesetDocument {
    // asset
    std::string version = "1.1", generator, tileset_version, gltf_up_axis = "Z";
    double geometric_error = 0;
    std::vector<TileEntry> tiles;  ///< preorder; 0 = root
    // extras.cityatlas
    int64_t format_version = 1;
    GeoreferenceEntry georeference;
    BuildEntry build;
    std::vector<MaterialEntry> materials;
    std::vector<TextureEntry> textures;
    /// For writers, in place of `textures`: their number and entry i, made as
    /// the text goes out (as a vector a city's textures took ~200 bytes each;
    /// readers fill `textures`).
    size_t texture_count = 0;
    std::function<TextureEntry(size_t)> texture_at;
    std::vector<FileEntry> texture_blocks;
    uint64_t feature_count = 0;
    int64_t feature_block_size = 1;
    std::vector<FileEntry> feature_tables;
    /// features/bounds/<k>.bin, one per table (format/feature_bounds.h);
    /// empty for folders written before them (tables[k].bounds absent).
    std::vector<FileEntry> feature_bounds;
    std::vector<ComputedTextureEntry> computed;  ///< absent from the file when empty
    TotalsEntry totals;
};

/// Parses tileset.json text; errors are one line starting with `where`.
/// Tiles nested deeper than 64 levels are refused (the recursion is bounded).
Status readTilesetDocument(const std::string& text, const std::string& where, TilesetDocument* out);

/// The text of tileset.json (one space of indent per level, newline at the end).
std::string writeTilesetDocument(const TilesetDocument& doc);
/// The same text written to `out` as it is made (a city's tileset.json is
/// hundreds of megabytes: never held whole, nor its tiles as one DOM: each
/// tile's JSON is made as it goes out, its children spliced in after it).
void writeTilesetDocument(const TilesetDocument& doc, std::ostream& out);

}  // namespace cityatlas::format
