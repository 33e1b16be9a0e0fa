// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/charts.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <cstring>
#include <queue>
#include <tuple>
#include <unordered_map>

namespace cityatlas::atlas {
namespace {

// Disjoint sets whose representative is their smallest member, so the ids
// that come out do not depend on the order of the joins.
class SmallestRootSets {
public:
    explicit SmallestRootSets(size_t n) : parent_(n) {
        for (uint32_t k = 0; k < parent_.size(); ++k) parent_[k] = k;
    }
    uint32_t find(uint32_t k) {
        while (parent_[k] != k) k = parent_[k] = parent_[parent_[k]];
        return k;
    }
    void join(uint32_t a, uint32_t b) {
        const uint32_t p = find(a), q = find(b);
        if (p != q) parent_[std::max(p, q)] = std::min(p, q);
    }
    /// Every member's representative.
    std::vector<uint32_t> roots() {
        for (uint32_t k = 0; k < parent_.size(); ++k) parent_[k] = find(k);
        return parent_;
    }

private:
    std::vector<uint32_t> parent_;
};

bool overlaps1d(double alo, double ahi, double blo, double bhi) {
    const double lo = std::max(alo, blo), hi = std::min(ahi, bhi);
    return hi > lo || (hi == lo && (alo == ahi || blo == bhi));
}

struct Chart {
    double per_u_1m = 0, per_v_1m = 0;
    Vec2d lo{1e300, 1e300}, hi{-1e300, -1e300};
    void add(const ChartMember& c) {
        per_u_1m = std::max(per_u_1m, c.per_u_1m), per_v_1m = std::max(per_v_1m, c.per_v_1m);
        lo = {std::min(lo.x, c.uv_min.x), std::min(lo.y, c.uv_min.y)};
        hi = {std::max(hi.x, c.uv_max.x), std::max(hi.y, c.uv_max.y)};
    }
    void add(const Chart& c) {
        per_u_1m = std::max(per_u_1m, c.per_u_1m), per_v_1m = std::max(per_v_1m, c.per_v_1m);
        lo = {std::min(lo.x, c.lo.x), std::min(lo.y, c.lo.y)};
        hi = {std::max(hi.x, c.hi.x), std::max(hi.y, c.hi.y)};
    }
};

class Planner {
public:
    explicit Planner(const ChartSettings& s) : s_(s) {}

    RegionSize sizeOf(const Chart& c) const {
        const double f = s_.shrink / s_.d_min_m;
        double per_u = c.per_u_1m * f, per_v = c.per_v_1m * f;
        if (s_.promote && s_.shrink >= 1.0 && (c.per_u_1m > 0 || c.per_v_1m > 0)) {  // at least the texture's own density: regionSize caps it there
            if (s_.native.w > 0) per_u = std::max(per_u, 2.0 * s_.native.w);
            if (s_.native.h > 0) per_v = std::max(per_v, 2.0 * s_.native.h);
        }
        RegionSize r = regionSize(per_u, per_v, c.lo, c.hi, s_.border_px, s_.native);
        if (s_.shrink < 1.0) r.w = std::min(r.w, s_.atlas_size_px), r.h = std::min(r.h, s_.atlas_size_px);
        return r;
    }

    // Greedy merging by saving; returns the surviving chart of every input chart.
    std::vector<uint32_t> merge(std::vector<Chart>& charts, std::vector<RegionSize>& sizes) const {
        std::vector<uint32_t> into(charts.size());
        for (uint32_t k = 0; k < into.size(); ++k) into[k] = k;
        std::vector<bool> alive(charts.size(), true);
        // (saving, -i, -j): the largest saving first, then the lowest indices.
        using Candidate = std::tuple<int64_t, int64_t, int64_t>;
        std::priority_queue<Candidate> heap;
        auto touch = [&](uint32_t a, uint32_t b) {
            const RegionSize &x = sizes[a], &y = sizes[b];
            const bool bordered = x.uv_min.x <= y.uv_max.x && y.uv_min.x <= x.uv_max.x && x.uv_min.y <= y.uv_max.y &&
                                  y.uv_min.y <= x.uv_max.y;
            if (!bordered || !s_.unique) return bordered;
            // Unique charts: one region may hold two charts only where no
            // texel can lie inside both (their closed uv boxes are disjoint).
            const Chart &p = charts[a], &q = charts[b];
            return p.hi.x < q.lo.x || q.hi.x < p.lo.x || p.hi.y < q.lo.y || q.hi.y < p.lo.y;
        };
        auto consider = [&](uint32_t a, uint32_t b) {
            if (!touch(a, b)) return;
            Chart u = charts[a];
            u.add(charts[b]);
            const RegionSize r = sizeOf(u);
            if (r.w > s_.atlas_size_px || r.h > s_.atlas_size_px) return;  // a merged region must still fit an atlas
            const int64_t saving = area(sizes[a]) + area(sizes[b]) - area(r);
            if (saving > 0) heap.emplace(saving, -int64_t{std::min(a, b)}, -int64_t{std::max(a, b)});
        };
        // Initial pairs by a sweep over the bordered boxes' u extent.
        std::vector<uint32_t> order(charts.size());
        for (uint32_t k = 0; k < order.size(); ++k) order[k] = k;
        std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
            return sizes[a].uv_min.x != sizes[b].uv_min.x ? sizes[a].uv_min.x < sizes[b].uv_min.x : a < b;
        });
        std::vector<uint32_t> active;
        for (uint32_t k : order) {
            size_t kept = 0;
            for (uint32_t j : active) {
                if (sizes[j].uv_max.x < sizes[k].uv_min.x) continue;
                active[kept++] = j;
                consider(j, k);
            }
            active.resize(kept);
            active.push_back(k);
        }
        while (!heap.empty()) {
            const auto [saving, ni, nj] = heap.top();
            heap.pop();
            const auto a = static_cast<uint32_t>(-ni), b = static_cast<uint32_t>(-nj);
            if (!alive[a] || !alive[b]) continue;
            Chart u = charts[a];
            u.add(charts[b]);
            const auto k = static_cast<uint32_t>(charts.size());
            charts.push_back(u);
            sizes.push_back(sizeOf(u));
            alive[a] = alive[b] = false;
            alive.push_back(true);
            into[a] = into[b] = k;
            into.push_back(k);
            for (uint32_t m = 0; m < k; ++m)
                if (alive[m]) consider(m, k);
        }
        for (uint32_t k = static_cast<uint32_t>(into.size()); k-- > 0;)  // merged charts come later: one pass
            if (into[k] != k) into[k] = into[into[k]];
        return into;
    }

private:
    static int64_t area(const RegionSize& r) { return int64_t{r.w} * r.h; }
    const ChartSettings& s_;
};

}  // namespace

std::vector<uint32_t> surfaceComponents(std::span<const SurfaceTriangle> t) {
    using K = CGAL::Exact_predicates_inexact_constructions_kernel;
    SmallestRootSets sets(t.size());
    auto uvPoint = [](const Vec2d& p) { return K::Point_2(p.x, p.y); };
    // Which side of its edge (a, b) the third corner lies on in uv, exactly.
    auto side = [&](const SurfaceTriangle& tri, int a, int b) {
        return CGAL::orientation(uvPoint(tri.uv[a]), uvPoint(tri.uv[b]), uvPoint(tri.uv[3 - a - b]));
    };
    // An edge's key: its two endpoints (position and uv, bit for bit) in a
    // fixed order, so both triangles along it give the same key.
    struct Corner {
        double v[5];
        bool operator<(const Corner& o) const { return std::memcmp(v, o.v, sizeof v) < 0; }
        bool operator==(const Corner& o) const { return std::memcmp(v, o.v, sizeof v) == 0; }
    };
    struct Edge {
        Corner lo, hi;
        uint32_t triangle;
        int a, b;  // the corners of the triangle along the edge, as (lo, hi)
    };
    auto cornerOf = [&](uint32_t i, int c) {
        return Corner{{t[i].position[c].x, t[i].position[c].y, t[i].position[c].z, t[i].uv[c].x, t[i].uv[c].y}};
    };
    // Copies of one triangle (the same surface written twice, as a solid's
    // member and in a multi-surface) are one place: they join first, and
    // count as one triangle along their edges.
    {
        std::vector<std::pair<std::array<Corner, 3>, uint32_t>> keyed(t.size());
        for (uint32_t i = 0; i < t.size(); ++i) {
            std::array<Corner, 3> k{cornerOf(i, 0), cornerOf(i, 1), cornerOf(i, 2)};
            std::sort(k.begin(), k.end());
            keyed[i] = {k, i};
        }
        std::sort(keyed.begin(), keyed.end(), [](const auto& x, const auto& y) {
            for (int c = 0; c < 3; ++c)
                if (!(x.first[c] == y.first[c])) return x.first[c] < y.first[c];
            return x.second < y.second;
        });
        for (size_t k = 1; k < keyed.size(); ++k)
            if (keyed[k].first == keyed[k - 1].first) sets.join(keyed[k].second, keyed[k - 1].second);
    }
    std::vector<uint32_t> copy_of(t.size());  // the copy class of each triangle, before any edge joins
    for (uint32_t k = 0; k < t.size(); ++k) copy_of[k] = sets.find(k);
    std::vector<Edge> edges;
    edges.reserve(3 * t.size());
    for (uint32_t i = 0; i < t.size(); ++i) {
        if (side(t[i], 0, 1) == CGAL::COLLINEAR) continue;  // zero uv area: joins nothing
        for (int e = 0; e < 3; ++e) {
            int a = e, b = (e + 1) % 3;
            Corner ca = cornerOf(i, a), cb = cornerOf(i, b);
            if (ca == cb) continue;
            if (cb < ca) std::swap(ca, cb), std::swap(a, b);
            edges.push_back({ca, cb, i, a, b});
        }
    }
    std::sort(edges.begin(), edges.end(), [](const Edge& x, const Edge& y) {
        if (!(x.lo == y.lo)) return x.lo < y.lo;
        if (!(x.hi == y.hi)) return x.hi < y.hi;
        return x.triangle < y.triangle;
    });
    for (size_t s = 0; s < edges.size();) {
        size_t e = s + 1;
        while (e < edges.size() && edges[e].lo == edges[s].lo && edges[e].hi == edges[s].hi) ++e;
        // Exactly two triangles along it (copies counting once), their third
        // corners on opposite sides in uv. More than two (a non-manifold
        // edge) join nothing: two of them on opposite sides of a third could
        // fold over each other.
        size_t other = e;
        bool two = true;
        for (size_t k = s + 1; k < e && two; ++k) {
            if (copy_of[edges[k].triangle] == copy_of[edges[s].triangle]) continue;
            if (other == e) {
                other = k;
            } else if (copy_of[edges[k].triangle] != copy_of[edges[other].triangle]) {
                two = false;
            }
        }
        if (two && other != e) {
            const Edge &x = edges[s], &y = edges[other];
            if (side(t[x.triangle], x.a, x.b) == -side(t[y.triangle], y.a, y.b)) sets.join(x.triangle, y.triangle);
        }
        s = e;
    }
    return sets.roots();
}

// Charts: the members whose uv boxes overlap, transitively. Each chart becomes
// its own region, so the two opposite walls of a building sharing a wrapped
// facade texture do not pay for the walls between them in texture space (the
// papers take one box per texture and node). Returns a chart id per member
// (the smallest member position in it).
std::vector<uint32_t> uvCharts(std::span<const ChartMember> m) {
    SmallestRootSets sets(m.size());
    std::vector<uint32_t> order(m.size());
    for (uint32_t k = 0; k < order.size(); ++k) order[k] = k;
    std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
        return m[a].uv_min.x != m[b].uv_min.x ? m[a].uv_min.x < m[b].uv_min.x : a < b;
    });
    // A sweep along u over the boxes still open. When very many are open at
    // once (one texture mapped 0..1 on thousands of walls), the open boxes of
    // one chart are replaced by their union: the sweep stays linear, and a box
    // touching only that union's gaps joins the chart (charts may then come
    // out coarser, never split wrongly).
    struct Open {
        Vec2d lo, hi;
        uint32_t member;
        uint32_t surface;
    };
    std::vector<Open> active;
    size_t compress_at = 256;
    for (uint32_t k : order) {
        size_t kept = 0;
        for (const Open& o : active) {
            if (o.hi.x < m[k].uv_min.x) continue;  // ends before this one starts: never overlaps a later one
            active[kept++] = o;
            if (o.surface == m[k].surface && overlaps1d(o.lo.x, o.hi.x, m[k].uv_min.x, m[k].uv_max.x) &&
                overlaps1d(o.lo.y, o.hi.y, m[k].uv_min.y, m[k].uv_max.y))
                sets.join(o.member, k);
        }
        active.resize(kept);
        active.push_back({m[k].uv_min, m[k].uv_max, k, m[k].surface});
        if (active.size() > compress_at) {
            std::vector<Open> merged;
            std::unordered_map<uint32_t, size_t> slot;
            for (const Open& o : active) {
                const auto [it, fresh] = slot.emplace(sets.find(o.member), merged.size());
                if (fresh) {
                    merged.push_back(o);
                    continue;
                }
                Open& u = merged[it->second];
                u.lo = {std::min(u.lo.x, o.lo.x), std::min(u.lo.y, o.lo.y)};
                u.hi = {std::max(u.hi.x, o.hi.x), std::max(u.hi.y, o.hi.y)};
            }
            active = std::move(merged);
            compress_at = std::max<size_t>(256, 2 * active.size());
        }
    }
    return sets.roots();
}

TextureRegions planTextureRegions(std::span<const ChartMember> members, const ChartSettings& settings) {
    TextureRegions out;
    const std::vector<uint32_t> chart_of = uvCharts(members);
    std::vector<uint32_t> index_of(members.size(), UINT32_MAX);  // chart id -> position in `charts`
    std::vector<Chart> charts;
    std::vector<uint32_t> member_chart(members.size());
    for (size_t k = 0; k < members.size(); ++k) {
        uint32_t& idx = index_of[chart_of[k]];
        if (idx == UINT32_MAX) idx = static_cast<uint32_t>(charts.size()), charts.emplace_back();
        charts[idx].add(members[k]);
        member_chart[k] = idx;
    }
    const Planner planner(settings);
    std::vector<RegionSize> sizes;
    sizes.reserve(charts.size());
    for (const Chart& c : charts) sizes.push_back(planner.sizeOf(c));
    std::vector<uint32_t> into(charts.size());
    for (uint32_t k = 0; k < into.size(); ++k) into[k] = k;
    if (settings.merge && charts.size() > 1) into = planner.merge(charts, sizes);
    std::vector<uint32_t> region_of_chart(charts.size(), UINT32_MAX);
    for (uint32_t k = 0; k < charts.size(); ++k) {
        if (into[k] != k) continue;
        region_of_chart[k] = static_cast<uint32_t>(out.regions.size());
        PlannedRegion r;
        r.size = sizes[k];
        r.per_u_1m = charts[k].per_u_1m, r.per_v_1m = charts[k].per_v_1m;
        r.uv_min = charts[k].lo, r.uv_max = charts[k].hi;
        r.single_colour = charts[k].per_u_1m == 0 && charts[k].per_v_1m == 0;
        out.regions.push_back(r);
    }
    out.region_of.resize(members.size());
    for (size_t k = 0; k < members.size(); ++k) out.region_of[k] = region_of_chart[into[member_chart[k]]];
    return out;
}

double sharpFrom(const PlannedRegion& r) {
    double d = 0;
    if (r.size.density_u > 0) d = std::max(d, r.per_u_1m / r.size.density_u);
    if (r.size.density_v > 0) d = std::max(d, r.per_v_1m / r.size.density_v);
    return d;
}

}  // namespace cityatlas::atlas
