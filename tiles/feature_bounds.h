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
#include <filesystem>
#include <optional>
#include <vector>

#include "core/status.h"
#include "core/windowed_records.h"
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

/// A feature's 48 bytes stay in memory while its triangles come (the
/// newest `window` features); older ones wait in a scratch file in
/// `scratch_dir` (core/windowed_records.h): a city's worth is not held.
class FeatureBoundsAccumulator {
public:
    explicit FeatureBoundsAccumulator(std::filesystem::path scratch_dir = {}, size_t window = size_t{1} << 16)
        : acc_(std::move(scratch_dir), window) {}
    void add(const Triangle& t);
    /// Records for features 0 .. features - 1 (those no triangle named are
    /// all zero, without kHasGeometry).
    std::vector<format::FeatureBoundsRecord> finish(size_t features);
    /// Feature `f`'s record alone (all zero when no triangle named it);
    /// asking in id order reads the scratch file a block at a time.
    format::FeatureBoundsRecord record(size_t f);
    /// A failed write or read of the scratch file (disk full), if any.
    const Status& status() const { return acc_.status(); }
    /// Frees what add() gathered.
    void clear() { acc_.clear(); }

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
    WindowedRecords<Acc> acc_;
};

/// The records of a whole scene in memory.
std::vector<format::FeatureBoundsRecord> featureBounds(const Scene& scene);

}  // namespace cityatlas::tiles
