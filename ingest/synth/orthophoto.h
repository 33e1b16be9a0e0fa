// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// The synthetic town's orthophoto: one north-up image over the whole town,
/// applied to every roof as a CityGML GeoreferencedTexture (the way real
/// cities deliver roof textures), with exact ground truth: each pixel whose
/// centre lies in a roof's ground plan has the colour that encodes that
/// building's number (a bijection on 24-bit RGB), every other pixel the
/// ground colour.
///
/// Exactness: the pixel size is a power of two in metres and the grid's edges
/// are multiples of it, so a roof vertex's texture coordinates are exact
/// quotients of exact binary values.

#include <cstdint>
#include <filesystem>
#include <string>

#include "ingest/scene.h"
#include "core/status.h"
#include "ingest/synth/facade_texture.h"

namespace cityatlas::synth {

struct Town;

/// North-up grid in the source CRS: pixel (col, row), counted from the upper
/// left, covers x in [west + col p, west + (col + 1) p), y in (north - (row + 1) p, north - row p].
struct OrthophotoGrid {
    double west_m = 0, north_m = 0;  ///< outer edges, source CRS
    double pixel_m = 0.25;
    int width_px = 0, height_px = 0;
    /// CityGML texture coordinates (t up) of a source-CRS ground position.
    Vec2d uv(double x, double y) const {
        return {(x - west_m) / (width_px * pixel_m), (y - (north_m - height_px * pixel_m)) / (height_px * pixel_m)};
    }
};

/// The grid over the town's roofs with a 2 m margin: `pixel_m` at most, doubled
/// until neither side exceeds `max_side_px`.
OrthophotoGrid orthophotoGrid(const Town& town, double pixel_m = 0.25, int max_side_px = 8192);

/// 24-bit RGB (0xRRGGBB) of building `number`, and back (numbers < 2^24 - 1).
uint32_t orthophotoColour(uint32_t number);
uint32_t orthophotoNumber(uint32_t rgb);
inline constexpr uint32_t kOrthophotoGroundNumber = 0xFFFFFF;  ///< decodes the ground colour

/// The image (RGB, town.orthophoto's grid).
Image8 drawOrthophoto(const Town& town);

/// World file text for the grid (six lines: A D B E C F, pixel centres).
std::string worldFileText(const OrthophotoGrid& grid);

}  // namespace cityatlas::synth
