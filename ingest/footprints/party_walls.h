// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Party walls between touching footprints, found without holding the
/// footprints: a wall shared by two buildings (the same edge, run in
/// opposite directions, endpoints equal to 1 mm) starts at the lower
/// building's eave, since below it nobody can see it.
///
/// The reader goes over its layer twice. The first pass gives every kept
/// footprint (a "record", numbered 0, 1, ... in order) to `add`: its edges go
/// into a sorted table, 20 bytes an edge, and its eave 8 bytes. The second
/// pass reads each footprint again and asks `wallBottoms` for its walls'
/// bottoms just before extruding it. The result is what one map over every
/// footprint's edges gave: an edge met twice (two records, or twice in one)
/// is the first one's, and only that one is raised.

#include <cstdint>
#include <deque>
#include <vector>

#include "ingest/footprints/extrude.h"

namespace cityatlas::footprints {

/// Per part, ring (outer first, then the holes) and edge: its wall's bottom.
using WallBottoms = std::vector<std::vector<std::vector<double>>>;

class PartyWallIndex {
public:
    /// Snap of the shared-edge test: endpoints equal when they round to the
    /// same millimetre.
    static constexpr double kSnap_m = 1e-3;

    /// Pass one: the next record's parts and eave (local z).
    void add(const std::vector<Footprint2d>& parts, double eave_z);
    /// Between the passes: sorts the table, keeps each edge's first record.
    void finish();
    /// Pass two: record `record`'s wall bottoms, given the same parts as to
    /// `add` and its base: `base_z` for a free wall, for a shared one the
    /// lower eave of the two (never below the base). `pairs` counts the
    /// shared edges once per pair (on the record with the smaller number).
    WallBottoms wallBottoms(uint32_t record, const std::vector<Footprint2d>& parts, double base_z, double eave_z,
                            uint64_t* pairs) const;
    uint64_t edges() const { return edges_.size(); }

private:
    // Endpoints in whole millimetres of the local frame: an int32 spans
    // +-2,147 km around the local origin, more than a city or a state. An edge
    // with a corner beyond is not indexed (it is built from its base).
    struct Edge {
        int32_t ax, ay, bx, by;
        uint32_t record;
    };
    static bool key(const Vec2d& a, const Vec2d& b, Edge* out);
    const Edge* find(const Edge& k) const;
    std::deque<Edge> edges_;     // a block at a time: no doubling copy of a city's edges
    std::deque<double> eave_;    // per record
    bool finished_ = false;
};

}  // namespace cityatlas::footprints
