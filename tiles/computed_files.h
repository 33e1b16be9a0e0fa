// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Computed textures as files (issue 19): each node layer's computed image
/// (atlas/computed_layers.h) as computed/<k>/<layer>/<node>.dds, single-
/// channel BC4 with its full mip chain, rows top-down like the atlases, and
/// what tileset.json lists of it.
///
/// Mips are means of the texels that hold a value (a 2 x 2 footprint, 3 on
/// the last row or column of an odd side, as the atlases' mips), so a
/// chart's edge is not darkened by the empty space around it; each level is
/// then quantized alone (atlas::quantizeUnit: round(255 v), empty as 0).

#include <filesystem>
#include <string>
#include <vector>

#include "atlas/computed_texture.h"
#include "core/status.h"
#include "format/tileset_document.h"
#include "tiles/texture_codec.h"

namespace cityatlas::tiles {

/// computed/<k>/<layer>/<node>.dds, relative to the folder.
std::string computedUri(size_t k, atlas::Layer layer, int32_t node);

/// The image's mip chain, level 0 first, down to 1 x 1.
std::vector<atlas::ScalarImage> computedMips(const atlas::ScalarImage& image);

/// Writes `image` (not empty) to out_dir/uri (its folder created), BC4 with
/// mips; `out` gets its entry. Thread-safe; the bytes depend on the image alone.
Status writeComputedImage(const atlas::ScalarImage& image, BcQuality quality, const std::filesystem::path& out_dir,
                          const std::string& uri, format::ComputedFileEntry* out);

}  // namespace cityatlas::tiles
