// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Per-feature bounds (format/feature_bounds.h) gathered one triangle at a
/// time, so a streaming read (cli/shards.h PlanSink) and a scene in memory
/// give the same records: in double until the records are made.
///
/// The longest wall: among a feature's wall triangles (semantic Wall, or
/// unclassified and within ~6 degrees of vertical, as LOD1 blocks without
/// semantics have them), the one whose corners lie farthest apart
/// horizontally. A wall polygon triangulated from a rectangle has two
/// triangles that each span its whole length, so that is the longest wall's
/// length, whatever the wall's height (a gable end is high but short). Its
/// outward normal is the triangle's (corners counter-clockwise seen from
/// outside, ingest/scene.h). Equal spans keep the smaller azimuth, so the
/// records do not depend on the order the triangles come in.
///
/// What a feature holds while triangles come is what its record needs, 48
/// bytes: the box already rounded outwards to float and the lowest z's
/// already rounded to float (rounding is monotone: the rounded minimum is
/// the minimum of the rounded values, so the records are those of the
/// double box), the longest span in double (which wall is longest is
/// decided exactly) and its azimuth in float.

#include <cmath>
#include <cstddef>
#include <deque>
#include <optional>
#include <vector>

#include "format/feature_bounds.h"
#include "ingest/scene.h"

namespace cityatlas::tiles {

/// A wall triangle's horizontal span (its corners' farthest apart) and the
/// azimuth of its outward normal, degrees clockwise from +y in [0, 360).
struct WallSpan {
    double span_m = 0;
    double azimuth_deg = 0;
};
/// `t`'s span and azimuth when it counts as a wall (above), else nothing.
std::optional<WallSpan> wallSpan(const Triangle& t);

class FeatureBoundsAccumulator {
public:
    void add(const Triangle& t);
    /// Records for features 0 .. features - 1 (those no triangle named are
    /// all zero, without kHasGeometry).
    std::vector<format::FeatureBoundsRecord> finish(size_t features) const;
    /// Feature `f`'s record alone (all zero when no triangle named it).
    format::FeatureBoundsRecord record(size_t f) const;
    /// Frees what add() gathered.
    void clear() { std::deque<Acc>().swap(acc_); }

private:
    struct Acc {
        float lo[3] = {INFINITY, INFINITY, INFINITY};     ///< the box, rounded down
        float hi[3] = {-INFINITY, -INFINITY, -INFINITY};  ///< rounded up
        float ground_min_z = INFINITY;  ///< lowest ground corner, rounded to nearest; inf: none
        float min_z = INFINITY;         ///< lowest corner, rounded to nearest (the base without ground)
        double wall_span_m = -1;        ///< horizontal span of the longest wall triangle so far; < 0: none
        float azimuth_deg = 0;          ///< its azimuth, rounded to nearest
        bool textured = false;
        bool empty() const { return !(lo[0] <= hi[0]); }
    };
    static_assert(sizeof(Acc) == 48);
    std::deque<Acc> acc_;  // grows a block at a time: no doubling, no copy while a city's worth moves
};

/// The records of a whole scene in memory.
std::vector<format::FeatureBoundsRecord> featureBounds(const Scene& scene);

}  // namespace cityatlas::tiles
