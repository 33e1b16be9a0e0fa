// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Procedural facades (issue 19 item 4; papers/000 §5.2, and §3.4.4's "large
/// uniform surfaces" problem): walls that come without a photo (most open
/// LOD2 data, all footprint data) get a facade texture made from the
/// building's attributes, and then go through the atlas tree like any photo.
///
/// A facade is one storey-high, one-bay-wide cell repeated over the wall
/// (the texture wraps): u = the distance along the wall / the window pitch,
/// v = (z - the building's lowest wall point) / the storey height. The
/// storey height is the building's own (a storey-height attribute), or its
/// wall height over its storey count (a storeys attribute), or the wall
/// height over round(wall height / the default storey height): so a wall
/// always shows exactly its storeys' rows of windows.
///
/// The cell (cell_px square, rows top-down as an image): a floor slab in the
/// bottom eighth, a window in the middle half of the width from 3/8 to 7/8 of
/// the height, wall elsewhere. Every edge lies on a multiple of 4 texels, and
/// every colour is exact in RGB565, so each 4 x 4 block is one colour that
/// BC1 stores exactly. The wall colour comes from a palette by a hash of the
/// building's id (the root building's, for its parts), so a building is one
/// colour and neighbours differ; slab and window colours follow the wall.
///
/// A wall is a triangle without a texture whose normal is within 15 degrees
/// of horizontal and whose surface is a wall or unclassified (footprint
/// extrusions, LOD1 solids).

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "ingest/scene.h"
#include "ingest/synth/facade_texture.h"

namespace cityatlas {

struct ProceduralFacadeParams {
    double storey_height_m = 3.0;  ///< when a building names neither storeys nor a storey height
    double window_pitch_m = 3.0;   ///< the width of one bay (one window)
    int cell_px = 32;              ///< a multiple of 8
};

struct FacadePalette {
    std::array<uint8_t, 3> wall, slab, window;  ///< sRGB, exact in RGB565
};
/// The palettes (wall colours of plaster, brick and stone), in order.
const std::vector<FacadePalette>& facadePalettes();
/// Which palette a building with this id gets (a hash of the id).
size_t paletteOf(const std::string& building_id);

/// The cell image of a palette (3 channels, rows top-down).
synth::Image8 facadeCell(const FacadePalette& palette, int cell_px);

/// A triangle procedural facades texture (see the file comment).
bool isBareWall(const Triangle& t);
/// A wall or unclassified surface within 15 degrees of vertical, textured or not.
bool isWall(const Triangle& t);

/// What a building's walls need: its palette, lowest wall point and storey height.
struct FacadeLayout {
    size_t palette = 0;
    Vec3d origin{0, 0, 0};  ///< u is measured from here (the building's walls' box corner: small uvs)
    double base_z = 0;
    double storey_height_m = 3;
    int storeys = 1;
};

/// The storey count and height attributes a feature names (footprint fields
/// such as levels, building:levels, storeys, storey_h; CityGML generic
/// attributes of those names), case-insensitive.
std::optional<double> storeysAttribute(const Feature& f);
std::optional<double> storeyHeightAttribute(const Feature& f);

/// A building's layout from its walls' z range and its attributes.
FacadeLayout facadeLayout(const std::string& building_id, double wall_min_z, double wall_max_z,
                          std::optional<double> storeys, std::optional<double> storey_height,
                          const ProceduralFacadeParams& params);

/// Gives a bare wall `texture` and its facade coordinates.
void applyFacade(const FacadeLayout& layout, const ProceduralFacadeParams& params, int32_t texture, Triangle* t);

}  // namespace cityatlas
