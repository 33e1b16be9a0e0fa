// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/footprints/party_walls.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <tuple>

namespace cityatlas::footprints {

namespace {

const std::vector<Vec2d>& ring(const Footprint2d& p, size_t k) { return k == 0 ? p.outer : p.holes[k - 1]; }

bool snapped(double v, int32_t* out) {
    const double q = std::round(v / PartyWallIndex::kSnap_m);
    // NaN fails both comparisons.
    if (!(q >= std::numeric_limits<int32_t>::min() && q <= std::numeric_limits<int32_t>::max())) return false;
    *out = static_cast<int32_t>(q);
    return true;
}

}  // namespace

bool PartyWallIndex::key(const Vec2d& a, const Vec2d& b, Edge* out) {
    return snapped(a.x, &out->ax) && snapped(a.y, &out->ay) && snapped(b.x, &out->bx) && snapped(b.y, &out->by);
}

void PartyWallIndex::add(const std::vector<Footprint2d>& parts, double eave_z) {
    const auto record = static_cast<uint32_t>(eave_.size());
    eave_.push_back(eave_z);
    for (const Footprint2d& p : parts)
        for (size_t k = 0; k <= p.holes.size(); ++k) {
            const std::vector<Vec2d>& r = ring(p, k);
            for (size_t e = 0; e < r.size(); ++e) {
                Edge edge{};
                if (!key(r[e], r[(e + 1) % r.size()], &edge)) continue;
                edge.record = record;
                edges_.push_back(edge);
            }
        }
}

namespace {
auto ordered(const auto& e) { return std::tie(e.ax, e.ay, e.bx, e.by, e.record); }
auto keyOf(const auto& e) { return std::tie(e.ax, e.ay, e.bx, e.by); }
}  // namespace

void PartyWallIndex::finish() {
    // By key, then record: an edge's first entry is its first record's.
    std::sort(edges_.begin(), edges_.end(), [](const Edge& x, const Edge& y) { return ordered(x) < ordered(y); });
    const auto end = std::unique(edges_.begin(), edges_.end(), [](const Edge& x, const Edge& y) { return keyOf(x) == keyOf(y); });
    edges_.erase(end, edges_.end());  // a deque frees the blocks it no longer uses
    finished_ = true;
}

const PartyWallIndex::Edge* PartyWallIndex::find(const Edge& k) const {
    const auto it = std::lower_bound(edges_.begin(), edges_.end(), k,
                                     [](const Edge& x, const Edge& y) { return keyOf(x) < keyOf(y); });
    return it != edges_.end() && keyOf(*it) == keyOf(k) ? &*it : nullptr;
}

WallBottoms PartyWallIndex::wallBottoms(uint32_t record, const std::vector<Footprint2d>& parts, double base_z,
                                        double eave_z, uint64_t* pairs) const {
    WallBottoms bottoms(parts.size());
    std::set<std::tuple<int32_t, int32_t, int32_t, int32_t>> seen;  // this record's edges so far: only an edge's first occurrence is raised
    for (size_t p = 0; p < parts.size(); ++p) {
        bottoms[p].resize(1 + parts[p].holes.size());
        for (size_t k = 0; k <= parts[p].holes.size(); ++k) {
            const std::vector<Vec2d>& r = ring(parts[p], k);
            bottoms[p][k].assign(r.size(), base_z);
            for (size_t e = 0; e < r.size(); ++e) {
                Edge mine{};
                if (!finished_ || !key(r[e], r[(e + 1) % r.size()], &mine)) continue;
                const bool repeat = !seen.insert(keyOf(mine)).second;
                const Edge* first = find(mine);
                if (repeat || !first || first->record != record) continue;  // another's edge, or met before
                const Edge* other = find(Edge{mine.bx, mine.by, mine.ax, mine.ay, 0});
                if (!other || other->record == record) continue;
                if (record < other->record && pairs) ++*pairs;
                bottoms[p][k][e] = std::max(base_z, std::min(eave_z, eave_[other->record]));
            }
        }
    }
    return bottoms;
}

}  // namespace cityatlas::footprints
