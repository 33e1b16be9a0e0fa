// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Simplified geometry for the inner nodes of the atlas tree: an inner node's
/// content is the merged geometry of its subtree, reduced to a triangle budget
/// with a geometric error (metres) that must stay below the node's world-space
/// texel size, so that the simplification is invisible at the distances the
/// node is drawn from.
///
/// The reduction is meshoptimizer's topology-preserving edge-collapse
/// simplifier (meshopt_simplify, 0.18). Its own error is a quadric measure (an
/// area-weighted mean of squared plane distances), which can badly under-state
/// the largest deviation (a box corner moves by a storey while the mean stays
/// small); so the error reported here is MEASURED in double precision. meshopt
/// runs at a fixed, bound-independent ladder of relative targets (4 per
/// octave, from the bound converted to meshopt's relative units down to 0),
/// and the result is the first attempt, from the top, whose measured error
/// fits the bound (in the worst case the welded input itself, error 0): the
/// one with the fewest triangles, as a lower target collapses no more.
/// Since a looser bound only admits more attempts, the triangle count never
/// grows with the bound while the target does not bind.
///
/// What "error" means here (SimplifyResult::geometric_error_m): the largest of
///  * the distance from every vertex of the input to the simplified surface, and
///  * the distance from sample points of the simplified surface (its vertices,
///    edge midpoints and triangle centroids) to the input surface.
/// The simplified vertices are input vertices (meshopt moves none), so their
/// own distance is 0; the midpoints and centroids are what catches a new
/// triangle that spans empty space between input vertices. It is a
/// vertex-and-sample Hausdorff distance, not the exact continuous one: a
/// deviation that peaks strictly between samples is under-stated.
/// Every input vertex is measured (no sampling), with a uniform grid over the
/// triangles and TBB over the points: linear in the mesh size per measured
/// attempt. A call runs meshopt up to ~100 times (most attempts are not
/// measured): about 0.5 s for 65k triangles on two busy cores.

#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "ingest/scene.h"

namespace cityatlas::tiles {

struct SimplifyInput {
    std::vector<Vec3d> positions;      ///< welded vertices, local metres (double)
    std::vector<uint32_t> indices;     ///< triangles (3 per triangle), indices into positions
    std::vector<uint32_t> feature_id;  ///< per vertex (building index); optional (empty = absent)
    /// false: weld by position first (a triangle soup collapses freely; the
    /// result's vertices lose their own attributes). true: vertices stay as
    /// given (weld the soup by position AND attributes beforehand), and
    /// meshopt treats vertices sharing a position as an attribute seam, which
    /// it only collapses along: every kept corner keeps its uv and ids.
    bool keep_attribute_seams = false;
    /// When the input is above the target, whole features whose bounding box
    /// (over the input) has a diagonal below this are left out first,
    /// smallest first, until their input triangles left meet the target
    /// (never the last one), and the rest is simplified on its own. 0: never.
    /// A triangle belongs to its first corner's feature. The tiles stage
    /// passes the node's world texel: a building smaller than a texel is
    /// below a pixel wherever the node is drawn. Leaving out before
    /// simplifying (not after a first simplification of everything, which
    /// would keep a few more of them) costs one simplification instead of
    /// two, and the first one was over the whole merge exactly where most
    /// buildings go: a million-building city's 42 m level keeps 2.6 M of
    /// 19.7 M triangles.
    double drop_features_below_m = 0;
};

struct SimplifyResult {
    /// Triangles, indexing the INPUT's vertices (meshopt keeps vertices in
    /// place; vertices no triangle uses any more remain in the input array).
    /// Where the input had several vertices at one position, the first of them
    /// is the one referenced.
    std::vector<uint32_t> indices;
    /// Measured, symmetric over vertices and samples (see the file comment),
    /// over the features drawn; never above the caller's max_error_m.
    double geometric_error_m = 0;
    size_t triangles_in = 0, triangles_out = 0;
    /// Feature ids some input triangle references but no output triangle does,
    /// sorted ascending. Empty when the input has no feature ids.
    std::vector<uint32_t> features_dropped;
    /// The largest bounding-box diagonal among the features left out whole
    /// (SimplifyInput::drop_features_below_m); 0 when none was. It is their
    /// error in the 3D Tiles sense (what is missing when this is drawn
    /// instead of the input), not a distance to the remaining surface.
    double left_out_diagonal_m = 0;
    size_t features_left_out = 0;
};

/// Reduces `in` to at most `target_triangles` triangles while keeping the
/// geometric error at or below `max_error_m`, whichever binds first; the error
/// bound wins: when the target cannot be reached within it, the result has
/// more triangles than the target (triangles_out says how many).
/// Never empty while the input has a triangle of non-zero area.
///
/// Welds by position first (exact double equality) so the simplifier can
/// collapse across the seams of a triangle soup; triangles with two corners at
/// one position (zero area) are left out of the result. Works in float32
/// relative to the bounding-box centre (subtracted in double), measures in
/// double on the original positions.
///
/// Building features are not kept apart by the simplifier: a building small
/// against max_error_m may collapse away or be covered by a neighbour's
/// vertices. That is never silent: features_dropped lists every feature that
/// no longer appears. A building whose every vertex lies farther than
/// max_error_m from all other features' surfaces cannot vanish, since its
/// vertices would then be farther than the measured error from the result.
///
/// Preconditions (asserted): indices.size() % 3 == 0, every index <
/// positions.size(), feature_id empty or positions.size() long. Deterministic.
SimplifyResult simplifyMesh(const SimplifyInput& in, size_t target_triangles, double max_error_m);

/// Which features to leave out of a mesh whose features have these extents
/// and these triangle counts: those whose extent's diagonal is below
/// `below_m`, smallest first (ties by id), until the triangles left are at
/// most `target_triangles`, never the last one drawn.
/// `largest` gets the largest diagonal left out (unchanged when none is).
/// simplifyMesh's rule (SimplifyInput::drop_features_below_m), and the
/// merge's cap (tiles/node_geometry.h) with no size limit.
std::unordered_set<uint32_t> featuresToLeaveOut(const std::unordered_map<uint32_t, Box3d>& extent,
                                                const std::unordered_map<uint32_t, size_t>& drawn, double below_m,
                                                size_t target_triangles, double* largest);

/// Welds a triangle soup (3 vertices per triangle) by exact position equality
/// (+0 and -0 are one position); the vertex order is that of first
/// appearance, and the first feature id seen at a position is kept.
SimplifyInput weldTriangles(const std::vector<Triangle>& triangles);

}  // namespace cityatlas::tiles
