// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// One tile node's geometry as a glTF 2.0 binary (.glb) whose single primitive
/// is compressed with KHR_draco_mesh_compression, and the reader for it.
///
/// The GLB is written by hand on nlohmann::json (like ingest/gltf_debug.cpp),
/// never through tinygltf or Draco's own glTF IO: Draco embeds a copy of
/// tinygltf and the two crash each other in one process (../shared/STACK.md).
///
/// Frame and precision
/// -------------------
/// * Positions are written relative to a caller-given centre as float32, then
///   quantized by Draco over the mesh's extent. Subtracting the centre in
///   double first is what keeps millimetres at ECEF magnitudes: float32 alone
///   has a spacing of 0.5 m at 6.4e6 m and 1 m at 9.9e6 m.
/// * The centre is NOT written as a node translation (a client would add it in
///   float32 and lose exactly that precision); the client adds it in double
///   (3D Tiles: the tile transform). Callers may record it in asset.extras.
/// * Positions are written in the caller's axes, unrotated (glTF's y-up
///   convention is the tileset writer's business, as is the 3D Tiles y-up to
///   z-up rule).
/// * Worst-case position error per axis: step/2 + float32 rounding, with
///   step = extent / (2^position_bits - 1) and extent the largest side of the
///   mesh's bounding box. At 14 bits: 1.8 mm step for a 30 m lot, 5.5 mm for a
///   90 m block. GlbResult reports the error measured on the file.
///
/// Texture coordinates
/// -------------------
/// TileMesh uvs follow the project convention (v = 0 at the BOTTOM of the
/// image, ingest/scene.h and atlas/atlas_tree.h); the file holds glTF's
/// (u, 1 - v) and decodeTileGlb flips them back. With both sets present,
/// uv_original is TEXCOORD_0 and uv_atlas TEXCOORD_1; glTF forbids a
/// TEXCOORD_1 without TEXCOORD_0, so a lone set is TEXCOORD_0. The primitive's
/// extras {"cityatlas_texcoords": ["original", "atlas"]} name the sets in
/// TEXCOORD order (a material's texCoord must follow it). Each uv set is quantized over
/// its own extent (Draco's TEX_COORD quantization), so original uvs that
/// repeat a texture 1000 times get a 1000 / 4095 step at 12 bits; they have
/// their own bit count (DracoSettings::uv_original_bits) for that reason.

#include <cstddef>
#include <cstdint>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/geometry.h"
#include "core/status.h"
#include "format/glb_reader.h"
#include "format/tile_mesh.h"

namespace cityatlas::tiles {

// The mesh, its attribute names and the reader live in the format library
// (format/tile_mesh.h, format/glb_reader.h), which the client links alone.
using format::kMaxTileFeatureId;
using format::kTileFeatureIdAttribute;
using format::kTileMaterialIdAttribute;
using format::kTileTextureIdAttribute;
using format::TileMesh;
using format::decodeTileGlb;

struct DracoSettings {
    int position_bits = 14;  ///< 1..30
    int uv_bits = 12;        ///< 1..30: the atlas uvs, and the original uvs unless uv_original_bits says otherwise
    int uv_original_bits = 0; ///< 0: uv_bits; else 1..30 for the original uvs alone
    int speed = 5;           ///< 0 (smallest) .. 10 (fastest, sequential); encoding and decoding speed
    /// Draco's sequential connectivity instead of edgebreaker: vertex i and
    /// triangle t of the file are the i-th referenced input vertex and the t-th
    /// kept input triangle. Files are larger (about 2x); for tests and callers
    /// that index vertices. Edgebreaker (the default) reorders both.
    bool preserve_order = false;
};

struct GlbResult {
    std::vector<uint8_t> bytes;  ///< the .glb file
    Vec3d centre;                ///< positions in the file are relative to it
    /// Largest distance between an input position and its decoded position
    /// (file float + centre, in double): quantization and float32 together.
    double max_position_error_m = 0;
    /// Largest |du| or |dv| between an input uv and its decoded value, per set
    /// (0 when the set is absent).
    double max_uv_original_error = 0;
    double max_uv_atlas_error = 0;
    /// Quantization steps Draco used (extent / (2^bits - 1)); 0 for absent uvs.
    double position_step_m = 0;
    double uv_original_step = 0;
    double uv_atlas_step = 0;
    size_t triangles = 0, vertices = 0;  ///< as decoded from the file (what the accessors say)
    /// Input triangles left out: two corners at the same float32 position
    /// (relative to the centre). They cover no pixel, and Draco's edgebreaker
    /// would drop them anyway; dropping them first keeps both codecs equal.
    size_t degenerate_triangles_dropped = 0;
    size_t draco_bytes = 0;  ///< size of the Draco blob inside `bytes`
};

/// Encodes `mesh` relative to `centre` with Draco: positions and uvs quantized
/// to the given bits, feature ids stored losslessly (unquantized float32).
///
/// The glTF: asset (version 2.0, generator "cityatlas", `extras` as
/// asset.extras unless it is null), one scene with one node with one mesh with
/// one primitive (mode TRIANGLES) whose KHR_draco_mesh_compression extension
/// points at bufferView 0 (the Draco blob, all of the BIN chunk). Accessors
/// (no bufferView, as the extension says) carry count, componentType, type and
/// min/max equal to the decoded extremes; indices are UNSIGNED_SHORT up to
/// 65535 vertices, UNSIGNED_INT above. The extension is in extensionsUsed and
/// extensionsRequired.
///
/// The blob is decoded again before returning: counts and min/max come from
/// that decode, and the errors in GlbResult are measured against the input
/// (see glb_writer.cpp for how vertices are matched when Draco reorders).
///
/// Fails (one line, nothing in *out changed) on: no triangles, an index out of
/// range, index count not a multiple of 3, an optional array whose size is not
/// positions.size(), a non-finite coordinate or centre, a position that does
/// not fit float32 relative to the centre, a feature id above 2^24, settings
/// out of range, a file over 4 GiB, or a Draco error.
/// Triangles encodeTileGlb() would keep: those not degenerate once in float32
/// relative to `centre` (0: there is nothing to encode for this mesh). A mesh
/// encodeTileGlb() refuses for another reason counts as drawable, so that its
/// error is reported.
size_t drawableTriangles(const TileMesh& mesh, const Vec3d& centre);

Status encodeTileGlb(const TileMesh& mesh, const Vec3d& centre, const DracoSettings& settings, GlbResult* out,
                     const nlohmann::json& extras = {});

/// The most position bits that can still lower the error of `mesh` written
/// relative to `centre` (1..30): the bits whose Draco step is at most the
/// float32 spacing at the mesh's farthest coordinate. A glb stores float32
/// positions relative to the centre and a decoder dequantizes in float32, so
/// finer steps only move which float a position rounds to; 20 km from the
/// centre (a 2 mm spacing) a 2 mm target cannot be met, and raising the bits
/// to 30 there cost ~0.7 GB of Draco tables per try and bought nothing.
int usefulPositionBits(const TileMesh& mesh, const Vec3d& centre);

}  // namespace cityatlas::tiles
