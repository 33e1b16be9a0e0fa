// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// A plain glTF 2.0 binary (.glb) view of a Scene, for looking at what a reader
/// produced in any glTF viewer (and for checking it with the Khronos validator,
/// see tests/tools/gltf). Not a delivery format: no compression, no atlas, no
/// tiling, vertices unshared (3 per triangle).

#include <filesystem>

#include "ingest/scene.h"
#include "core/status.h"

namespace cityatlas {

/// Name of the per-vertex attribute that holds Triangle::feature (an
/// application-specific attribute, hence the leading underscore; the name
/// follows EXT_mesh_features' convention without declaring that extension).
inline constexpr const char* kGltfFeatureIdAttribute = "_FEATURE_ID_0";

/// Writes a plain, uncompressed glTF 2.0 binary (.glb) view of the Scene for
/// inspection in any glTF viewer.
///
/// * One mesh with one primitive per texture used (in texture index order),
///   then one per material used (untextured triangles, material index order),
///   then one for untextured triangles without a valid material (neutral grey).
///   A triangle whose texture index is out of range or whose texture has an
///   empty path counts as untextured. Primitives are non-indexed triangle lists.
/// * Positions are float32 in the Scene's local frame (east, north, up). The mesh
///   sits on the single root node, whose rotation (-90 degrees about x) turns the
///   Scene's z-up into glTF's y-up: glTF (x, y, z) = (east, up, -north).
/// * Texture coordinates: v is flipped (v' = 1 - v), since glTF's v = 0 is the
///   image top and the Scene's the bottom. Samplers follow TextureRef::wrap:
///   wrap -> REPEAT, mirror -> MIRRORED_REPEAT, clamp/border/none -> CLAMP_TO_EDGE.
/// * Images are referenced by URI relative to the .glb's folder (with ".."
///   segments when a texture lies elsewhere), '/' separated and percent-encoded,
///   never embedded and never read; no mimeType is claimed. Only textures that
///   some written triangle uses get an image.
/// * Materials: metallic 0, roughness 1, doubleSided false. RGBA textures
///   (channels == 4) and materials with transparency > 0 get alphaMode BLEND.
///   Untextured primitives carry the material's diffuse colour (clamped to
///   [0,1], alpha = 1 - transparency) as baseColorFactor.
/// * Per vertex, kGltfFeatureIdAttribute holds Triangle::feature as a FLOAT
///   SCALAR (exact up to 2^24). glTF forbids UNSIGNED_INT vertex attributes, so
///   when some written triangle's feature exceeds 2^24 the attribute becomes a
///   VEC2 UNSIGNED_SHORT (low 16 bits, high 16 bits) for the whole file;
///   asset.extras.feature_id_encoding says which ("float" or "uint16 pair (low, high)").
/// * asset.generator names cityatlas and its version; asset.extras records the
///   source CRS, the local origin and how many triangles were dropped.
/// * Triangles with a non-finite position, or one that does not fit a float32,
///   are dropped (counted in asset.extras.dropped_triangles); non-finite texture
///   coordinates are written as 0. Degenerate (zero-area) triangles are kept.
/// * An empty scene (or one whose triangles are all dropped) gives a valid .glb
///   with the root node and no mesh, no buffer.
///
/// The file is written to a temporary sibling ("<name>.partial") and renamed
/// into place, so a failure never leaves a partial .glb behind (nor the
/// temporary). Fails with a one-line Status naming the path and the reason:
/// missing folder, I/O error, or a scene too large for one GLB (4 GiB).
Status writeDebugGlb(const Scene& scene, const std::filesystem::path& glb_path);

/// The glTF sampler wrap (wrapS / wrapT) that samples a texture as CityGML's
/// wrapMode says: wrap -> REPEAT, mirror -> MIRRORED_REPEAT, else CLAMP_TO_EDGE
/// (border has no glTF equivalent; none means the coordinates stay inside).
int gltfSamplerWrap(WrapMode w);

}  // namespace cityatlas
