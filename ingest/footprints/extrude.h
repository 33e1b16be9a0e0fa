// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Attributed footprints -> 3D buildings: walls extruded from a 2D footprint
/// polygon (with holes) and a roof of a given type on top. This is what turns
/// "footprint + height + roof type + facade texture + projection width"
/// (Buchholz, thesis §3.1.2, "Attributed Footprint Polygons") into polygons.
///
/// Frame: local metres (see ingest/scene.h), z up. Output polygons are open
/// rings (no closing duplicate), exterior first, counter-clockwise seen from
/// outside the building; holes (flat and shed roofs over courtyards) run the
/// other way. Every corner shared by two output polygons is the SAME double
/// triple in both, so the walls, the roof and a ground polygon made from the
/// footprint at base_z close a watertight, consistently oriented solid
/// (no T-junctions; party walls deliberately open it).
///
/// Output order: walls first (ring 0's edges in order, then each hole's; an
/// edge whose wall is entirely covered is skipped), then the roof polygons. A
/// wall's ring starts with its two bottom corners (edge start, edge end) and
/// goes up the end side, back along the roof edge and down the start side.
///
/// Roof construction (H = ridge_z - eave_z):
/// * Flat: the footprint (with holes) at eave_z.
/// * Shed: one plane rising perpendicular to the longest outer edge (the first
///   one on ties), from eave_z at the footprint vertex lowest in that
///   direction (the edge itself when it lies on the convex hull, which is the
///   normal case) to ridge_z at the farthest vertex. Wall tops follow the plane.
/// * Gable: only for a rectangle (4 corners after ignoring exactly collinear
///   vertices, every corner within kGableRightAngleToleranceDeg of 90 degrees,
///   no holes): the ridge joins the midpoints of the short sides at ridge_z; the
///   two end walls get their gable triangle. When the rectangle is not exact
///   (long sides not parallel), each roof side is split along a diagonal into
///   two planar polygons. Anything else becomes Hip (see `fallback`).
/// * Hip: CGAL's interior straight skeleton of the polygon with holes; each
///   skeleton face (one per footprint edge) lifted with
///   z = eave_z + H * t / t_max (t = offset time of the skeleton node), i.e.
///   one equal pitch atan(H / t_max) everywhere. Works on any simple polygon
///   with holes. If CGAL fails, Flat.
/// * Pyramid: convex footprint without holes: a triangle per edge up to an
///   apex at the area centroid at ridge_z. Anything else becomes Hip.
///
/// Robustness: no NaN is ever produced. Invalid input (non-finite numbers,
/// fewer than 3 outer points, zero area, eave_z <= base_z) gives an empty
/// result whose `fallback` says why. Rings given in the wrong orientation are
/// reversed (wall_bottom_z keeps addressing the caller's edges). Holes with
/// fewer than 3 points or zero area are ignored (noted in `fallback`).
/// Collinear consecutive vertices are allowed (they get their own walls and
/// roof vertices, so the solid stays closed).

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ingest/scene.h"

namespace cityatlas::footprints {

enum class RoofShape : uint8_t { Flat, Shed, Gable, Hip, Pyramid };

/// "flat", "shed", "gable", "hip", "pyramid".
std::string_view roofShapeName(RoofShape shape);

/// Case-insensitive, surrounding blanks ignored. Accepts OSM roof:shape values
/// (flat, skillion, gabled, hipped, pyramidal), plain words (flat, shed,
/// mono-pitch / monopitch / mono_pitch, gable, hip, pyramid) and AdV/CityGML
/// roofType codes (1000 flat, 1010 shed, 1030 gable, 1040 hip, 1070 pyramid).
/// Empty or unknown -> nullopt (the caller counts and picks a default).
std::optional<RoofShape> parseRoofShape(std::string_view s);

/// Largest deviation of a corner from 90 degrees for which a quadrilateral
/// still counts as a rectangle for a gable roof.
inline constexpr double kGableRightAngleToleranceDeg = 2.0;

struct Footprint2d {                            ///< local metres, cleaned and valid
    std::vector<Vec2d> outer;                   ///< counter-clockwise, no closing duplicate
    std::vector<std::vector<Vec2d>> holes;      ///< clockwise, no closing duplicate
};

struct ExtrusionParams {
    double base_z = 0;    ///< bottom of the walls (local z)
    double eave_z = 10;   ///< top of the walls where the roof starts
    double ridge_z = 10;  ///< highest roof point; == eave_z means flat whatever `roof` says
    RoofShape roof = RoofShape::Flat;
    /// Width of one facade texture repeat on the wall (thesis: "projection
    /// width"); <= 0: walls get no texture coordinates. The image height is
    /// fitted to eave_z - base_z.
    double projection_width_m = 0;
    /// One roof texture repeat covers this many metres; <= 0: roofs get no uv.
    double roof_texture_size_m = 0;
    /// Optional, per ring (0 = outer, then holes, as given) per edge i (from
    /// vertex i to i+1): the wall starts at this z instead of base_z (a
    /// neighbour covers the wall below: party wall); values below base_z
    /// count as base_z; a value >= the wall's highest point removes the wall.
    /// Missing rings/edges or non-finite values mean base_z. Empty = none.
    std::vector<std::vector<double>> wall_bottom_z;
};

struct ExtrudedPolygon {
    SurfaceSemantic semantic = SurfaceSemantic::Wall;  ///< Wall or Roof (no Ground is made)
    std::vector<std::vector<Vec3d>> rings;  ///< open rings, exterior first, CCW seen from outside
    /// Same shape as `rings`, or empty. Walls: u = distance along the ring from
    /// its first vertex / projection_width_m, v = (z - base_z) / (eave_z - base_z)
    /// (so gable tops reach v > 1). Roofs: ((x - min_x), (y - min_y)) /
    /// roof_texture_size_m over the footprint's bounding box.
    std::vector<std::vector<Vec2d>> uv;
};

struct ExtrusionResult {
    std::vector<ExtrudedPolygon> polygons;
    RoofShape built = RoofShape::Flat;  ///< what was built after fallbacks
    /// Empty, or one line saying why the requested shape was replaced or the
    /// input was rejected / partly ignored (several reasons joined by "; ").
    std::string fallback;
    uint32_t walls_removed = 0;  ///< edges whose wall was entirely covered (party walls)
};

ExtrusionResult extrudeFootprint(const Footprint2d& footprint, const ExtrusionParams& params);

}  // namespace cityatlas::footprints
