// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Where an image lies on the ground: the affine map from its pixel grid to
/// world (CRS) coordinates, as a GeoreferencedTexture needs it when the
/// CityGML file gives no referencePoint/orientation. Read by GDAL, which knows
/// every place a producer puts it: a world file beside the image (.tfw, .jgw,
/// .pgw, .wld or .<ext>w, upper or lower case) and the image's own tags
/// (GeoTIFF, GDAL's .aux.xml).

#include <array>
#include <filesystem>
#include <optional>

namespace cityatlas {

/// x = a0 col + a1 row + a2, y = a3 col + a4 row + a5, with (col, row) the
/// centre of a pixel counted from the upper left one (a world file's own
/// convention). Nothing when the image has no usable georeference.
/// `prefer_world_file`: a world file before the image's tags (CityGML's
/// preferWorldFile, true by default), else the other way round.
std::optional<std::array<double, 6>> readImageGeoreference(const std::filesystem::path& image, bool prefer_world_file);

}  // namespace cityatlas
