// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The reader of the tile GLB (one Draco-compressed primitive,
/// KHR_draco_mesh_compression; see tiles/glb_writer.h for the layout), for the
/// client, `inspect` and the writer's own check. Bytes may come from anywhere:
/// every count, offset and index is checked before use, and nothing throws.

#include <cstdint>
#include <vector>

#include "core/geometry.h"
#include "core/status.h"
#include "format/tile_mesh.h"

namespace cityatlas::format {

/// Reads a GLB written by encodeTileGlb: checks the GLB framing, parses the
/// JSON chunk, finds the primitive's KHR_draco_mesh_compression blob in the BIN
/// chunk and decodes it with draco::Decoder. Positions come back as the file's
/// float32 + `centre` in double, uvs flipped back to v = 0 at the bottom,
/// feature ids as integers. Decoded counts must match the accessors.
///
/// Fails with a one-line reason (truncated file, bad magic or version, no JSON
/// chunk, JSON not parsable, no Draco primitive, blob outside the BIN chunk,
/// Draco error, attribute of the wrong shape, ...) and never crashes or throws
/// on arbitrary bytes; *out is only written on success.
Status decodeTileGlb(const std::vector<uint8_t>& bytes, const Vec3d& centre, TileMesh* out);

}  // namespace cityatlas::format
