// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Triangulation of one planar (or nearly planar) 3D polygon with holes.
///
/// The polygon is projected onto its best-fit plane (Newell normal of the
/// exterior ring) and triangulated with CGAL's constrained Delaunay
/// triangulation using exact predicates; the holes are cut out by nesting
/// depth. No Steiner points are added, so every output corner is one of the
/// input vertices and per-vertex data (texture coordinates) carries over by
/// index. For a simple polygon with V distinct vertices and H holes the
/// result has exactly V + 2H - 2 triangles.

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "ingest/scene.h"

namespace cityatlas {

/// Rings without the closing duplicate point. Ring 0 is the exterior; its
/// orientation decides which way the output faces (counter-clockwise seen
/// from the front, right-hand rule). Hole orientation does not matter.
struct PolygonRings {
    std::vector<std::span<const Vec3d>> rings;
    /// Optional texture coordinates per ring (same sizes as `rings`), only
    /// used to give points added where rings cross a texture coordinate.
    std::vector<std::span<const Vec2d>> uv;
};

struct PolygonTriangulation {
    /// Corner indices into the rings concatenated in order (ring 0 first);
    /// indices >= the input vertex count refer to `added_points`.
    std::vector<std::array<uint32_t, 3>> triangles;
    /// Points CGAL inserted where constraint edges cross (self-intersecting
    /// rings), lifted back onto the plane, with texture coordinates from an
    /// affine fit of the input's (zero when no uv was given).
    std::vector<Vec3d> added_points;
    std::vector<Vec2d> added_uv;
    /// Input vertices that coincide with an earlier, non-adjacent vertex
    /// (a ring touching itself or a hole touching the exterior).
    uint32_t repeated_vertices = 0;
    Vec3d unit_normal;                 ///< Newell normal of the exterior ring
    double max_plane_deviation_m = 0;  ///< largest distance of a vertex from the fitted plane
    bool degenerate = false;           ///< zero area / collinear: no triangles produced
};

/// Newell's normal of a ring (not normalised; its length is twice the area of
/// the ring's projection onto the plane it defines).
Vec3d newellNormal(std::span<const Vec3d> ring);

/// Area of a planar polygon with holes: |exterior| - sum |holes| in m^2,
/// computed from Newell normals (independent of any triangulation).
double polygonArea(const PolygonRings& polygon);

PolygonTriangulation triangulatePolygon(const PolygonRings& polygon);

}  // namespace cityatlas
