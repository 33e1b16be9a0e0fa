// SPDX-License-Identifier: GPL-3.0-or-later
#include "tiles/simplify.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <iterator>
#include <limits>
#include <numeric>
#include <optional>
#include <tuple>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include <meshoptimizer.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "core/memory_gate.h"

namespace cityatlas::tiles {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// meshopt_simplify holds ~55 bytes per input index while it runs (heaptrack:
// 278 MB for the 5.1 M indices of a 100,000-building town's root merge).
// Runs go side by side only while their estimates add up to at most this
// budget, over every simplification in the process (the rungs of one, and
// nodes merged at once); a run larger than the budget runs alone. Which runs
// share the cores changes the time, never the result (the ladder scan below).
constexpr size_t kMeshoptBytesPerIndex = 56;
// 1 GB: a 100,000-building root (2 runs of 286 MB) still runs both rungs side
// by side (a 320 MB budget saved 0.2 GB there and cost 20 % of the merge's
// time); the gate only bites above ~3 M triangles in one merge.
constexpr size_t kMeshoptBudgetBytes = size_t{1} << 30;

MemoryGate& meshoptGate() {
    static MemoryGate gate(kMeshoptBudgetBytes);
    return gate;
}

// --- Welding ------------------------------------------------------------------

// Hash agreeing with Vec3d's operator== (exact double equality): +0.0 and -0.0
// compare equal but differ in their bits, so both are hashed as +0.0.
struct PositionHash {
    size_t operator()(const Vec3d& p) const {
        auto bits = [](double v) { return std::bit_cast<uint64_t>(v == 0.0 ? 0.0 : v); };
        uint64_t h = bits(p.x) * 0x9E3779B97F4A7C15ull;
        h ^= bits(p.y) + 0x7F4A7C159E3779B9ull + (h << 6) + (h >> 2);
        h ^= bits(p.z) + 0x94D049BB133111EBull + (h << 6) + (h >> 2);
        return static_cast<size_t>(h ^ (h >> 29));
    }
};

// --- Distances ----------------------------------------------------------------

inline double norm2(const Vec3d& v) { return dot(v, v); }

double pointSegmentDist2(const Vec3d& p, const Vec3d& a, const Vec3d& b) {
    const Vec3d ab = b - a;
    const double len2 = norm2(ab);
    if (!(len2 > 0)) return norm2(p - a);
    const double t = std::clamp(dot(p - a, ab) / len2, 0.0, 1.0);
    return norm2(p - (a + t * ab));
}

// Squared distance from p to triangle abc: the Voronoi-region walk of Ericson,
// "Real-Time Collision Detection" 5.1.5. Inside the face region the distance
// is taken to the plane (|ap.n| / |n|) rather than to a reconstructed closest
// point, so a point lying on the face measures ~1e-16 relative, not the
// rounding of a barycentric reconstruction. Zero-area triangles are segments.
double pointTriangleDist2(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
    const Vec3d ab = b - a, ac = c - a;
    const Vec3d n = cross(ab, ac);
    const double n2 = norm2(n);
    if (!(n2 > 0))
        return std::min({pointSegmentDist2(p, a, b), pointSegmentDist2(p, b, c), pointSegmentDist2(p, c, a)});
    const Vec3d ap = p - a;
    const double d1 = dot(ab, ap), d2 = dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return norm2(ap);
    const Vec3d bp = p - b;
    const double d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return norm2(bp);
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return norm2(p - (a + (d1 / (d1 - d3)) * ab));
    const Vec3d cp = p - c;
    const double d5 = dot(ab, cp), d6 = dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return norm2(cp);
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return norm2(p - (a + (d2 / (d2 - d6)) * ac));
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
        return norm2(p - (b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b)));
    const double h = dot(ap, n);
    return h * h / n2;
}

// A uniform grid over a triangle set for nearest-surface queries. Each triangle
// is listed in every cell its bounding box touches; a query visits cells in
// growing Chebyshev shells around the point's cell and stops once no unvisited
// cell can hold anything nearer. The cell size is the mean triangle box size,
// widened until there are at most ~4 cells per triangle, which bounds memory
// for meshes with a few huge triangles among many small ones.
class TriangleGrid {
public:
    TriangleGrid(const std::vector<Vec3d>& pos, const std::vector<uint32_t>& idx) : pos_(pos), idx_(idx) {
        const size_t tris = idx.size() / 3;
        if (tris == 0) return;
        Box3d box;
        double size_sum = 0;
        for (size_t t = 0; t < tris; ++t) {
            Box3d tb;
            for (int k = 0; k < 3; ++k) tb.extend(pos[idx[3 * t + k]]);
            box.extend(tb.min);
            box.extend(tb.max);
            size_sum += std::max({tb.max.x - tb.min.x, tb.max.y - tb.min.y, tb.max.z - tb.min.z});
        }
        lo_ = box.min;
        const double ext[3] = {box.max.x - box.min.x, box.max.y - box.min.y, box.max.z - box.min.z};
        const double max_ext = std::max({ext[0], ext[1], ext[2]});
        cell_ = std::max({size_sum / static_cast<double>(tris), max_ext * 1e-6, 1e-9});
        const double max_cells = std::max(64.0, 4.0 * static_cast<double>(tris));
        for (;;) {
            double total = 1;
            for (int a = 0; a < 3; ++a) total *= std::max(1.0, std::ceil(ext[a] / cell_));
            if (total <= max_cells) break;
            cell_ *= 1.01 * std::cbrt(total / max_cells);
        }
        for (int a = 0; a < 3; ++a) n_[a] = std::max<int64_t>(1, static_cast<int64_t>(std::ceil(ext[a] / cell_)));

        // Counting sort of (cell, triangle) pairs into a CSR layout.
        start_.assign(static_cast<size_t>(n_[0] * n_[1] * n_[2]) + 1, 0);
        auto forCells = [&](size_t t, auto&& fn) {
            Box3d tb;
            for (int k = 0; k < 3; ++k) tb.extend(pos[idx[3 * t + k]]);
            int64_t c0[3], c1[3];
            cellOf(tb.min, c0);
            cellOf(tb.max, c1);
            for (int64_t x = c0[0]; x <= c1[0]; ++x)
                for (int64_t y = c0[1]; y <= c1[1]; ++y)
                    for (int64_t z = c0[2]; z <= c1[2]; ++z) fn(static_cast<size_t>((x * n_[1] + y) * n_[2] + z));
        };
        for (size_t t = 0; t < tris; ++t) forCells(t, [&](size_t c) { ++start_[c + 1]; });
        for (size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
        tris_.resize(start_.back());
        std::vector<size_t> fill(start_.begin(), start_.end() - 1);
        for (size_t t = 0; t < tris; ++t) forCells(t, [&](size_t c) { tris_[fill[c]++] = static_cast<uint32_t>(t); });
    }

    /// Distance from p to the nearest triangle: exact when it is at most `cap`;
    /// otherwise some value above cap (the search stops early). +inf when the
    /// grid holds no triangle.
    double distance(const Vec3d& p, double cap) const {
        if (tris_.empty()) return kInf;
        int64_t c[3];
        cellOf(p, c);
        const int64_t k_max = std::max({n_[0], n_[1], n_[2]});
        double best2 = kInf;
        for (int64_t k = 0;; ++k) {
            visitShell(c, k, [&](size_t cell) {
                for (size_t i = start_[cell]; i < start_[cell + 1]; ++i) {
                    const uint32_t t = tris_[i];
                    best2 = std::min(best2, pointTriangleDist2(p, pos_[idx_[3 * t]], pos_[idx_[3 * t + 1]],
                                                               pos_[idx_[3 * t + 2]]));
                }
            });
            // Cells of shell k+1 and beyond are at least k cells away from p
            // along some axis (also for points outside the grid, whose cell
            // coordinates are clamped: clamping only brings them nearer). The
            // factor absorbs the rounding of the cell assignment.
            const double reach = static_cast<double>(k) * cell_ * (1 - 1e-9);
            if (best2 <= reach * reach || reach > cap || k >= k_max) break;
        }
        return std::sqrt(best2);
    }

private:
    void cellOf(const Vec3d& p, int64_t c[3]) const {
        const double v[3] = {p.x - lo_.x, p.y - lo_.y, p.z - lo_.z};
        for (int a = 0; a < 3; ++a) {
            const double f = std::floor(v[a] / cell_);
            c[a] = f < 0 ? 0 : f >= static_cast<double>(n_[a]) ? n_[a] - 1 : static_cast<int64_t>(f);
        }
    }

    // Calls fn for every cell whose Chebyshev distance from c is exactly k.
    template <class Fn>
    void visitShell(const int64_t c[3], int64_t k, Fn&& fn) const {
        const int64_t x0 = std::max<int64_t>(0, c[0] - k), x1 = std::min(n_[0] - 1, c[0] + k);
        const int64_t y0 = std::max<int64_t>(0, c[1] - k), y1 = std::min(n_[1] - 1, c[1] + k);
        const int64_t z0 = std::max<int64_t>(0, c[2] - k), z1 = std::min(n_[2] - 1, c[2] + k);
        for (int64_t x = x0; x <= x1; ++x)
            for (int64_t y = y0; y <= y1; ++y) {
                const size_t base = static_cast<size_t>((x * n_[1] + y) * n_[2]);
                if (std::abs(x - c[0]) == k || std::abs(y - c[1]) == k) {
                    for (int64_t z = z0; z <= z1; ++z) fn(base + static_cast<size_t>(z));
                } else {
                    // Interior column of the shell: only its two z faces.
                    if (c[2] - k >= 0) fn(base + static_cast<size_t>(c[2] - k));
                    if (k > 0 && c[2] + k < n_[2]) fn(base + static_cast<size_t>(c[2] + k));
                }
            }
    }

    const std::vector<Vec3d>& pos_;
    const std::vector<uint32_t>& idx_;
    Vec3d lo_;
    double cell_ = 1;
    int64_t n_[3] = {1, 1, 1};
    std::vector<size_t> start_;
    std::vector<uint32_t> tris_;
};

// Largest distance from `points` to the grid's surface; +inf as soon as one
// point is farther than `cap` (the caller only needs to know the attempt
// failed). The maximum does not depend on the order TBB visits points in, so
// the value is deterministic.
// `point(i)` gives point i of `count`.
template <typename PointAt>
double maxDistance(size_t count, const PointAt& point, const TriangleGrid& grid, double cap) {
    std::atomic<double> worst{0.0};
    std::atomic<bool> over{false};
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 512), [&](const tbb::blocked_range<size_t>& r) {
        double local = 0;
        for (size_t i = r.begin(); i != r.end(); ++i) {
            if (over.load(std::memory_order_relaxed)) return;
            const double d = grid.distance(point(i), cap);
            if (!(d <= cap)) {
                over.store(true, std::memory_order_relaxed);
                return;
            }
            local = std::max(local, d);
        }
        double cur = worst.load();
        while (local > cur && !worst.compare_exchange_weak(cur, local)) {
        }
    });
    return over.load() ? kInf : worst.load();
}

}  // namespace

std::unordered_set<uint32_t> featuresToLeaveOut(const std::unordered_map<uint32_t, Box3d>& extent,
                                                const std::unordered_map<uint32_t, size_t>& drawn, double below_m,
                                                size_t target_triangles, double* largest) {
    std::vector<std::pair<double, uint32_t>> candidates;  // (diagonal, feature)
    size_t left = 0;
    for (const auto& [f, count] : drawn) {
        left += count;
        const Box3d& b = extent.at(f);
        const double diagonal = std::sqrt(norm2(b.max - b.min));
        if (diagonal < below_m) candidates.emplace_back(diagonal, f);
    }
    std::sort(candidates.begin(), candidates.end());
    std::unordered_set<uint32_t> out;
    for (const auto& [diagonal, f] : candidates) {
        if (left <= target_triangles) break;
        const size_t count = drawn.at(f);
        if (count >= left) continue;  // a node must show something
        out.insert(f);
        left -= count;
        *largest = diagonal;
    }
    return out;
}

SimplifyInput weldTriangles(const std::vector<Triangle>& triangles) {
    SimplifyInput out;
    std::unordered_map<Vec3d, uint32_t, PositionHash> index_of;
    index_of.reserve(triangles.size() * 2);
    out.indices.reserve(triangles.size() * 3);
    for (const Triangle& t : triangles) {
        for (const Vec3d& p : t.position_local) {
            auto [it, inserted] = index_of.emplace(p, static_cast<uint32_t>(out.positions.size()));
            if (inserted) {
                out.positions.push_back(p);
                out.feature_id.push_back(t.feature);
            }
            out.indices.push_back(it->second);
        }
    }
    return out;
}

SimplifyResult simplifyMesh(const SimplifyInput& in, size_t target_triangles, double max_error_m) {
    assert(in.indices.size() % 3 == 0);
    assert(in.feature_id.empty() || in.feature_id.size() == in.positions.size());
    SimplifyResult result;
    result.triangles_in = in.indices.size() / 3;
    const size_t nv = in.positions.size();
    const double bound = max_error_m >= 0 ? max_error_m : 0.0;  // NaN and negative: only exact collapses

    // Weld the referenced vertices by exact position into a compact local
    // array (the lowest input index of each position represents it), so that
    // meshopt sees one vertex per position: a triangle soup's polygons are
    // otherwise separate islands whose borders it will not collapse across.
    std::vector<uint8_t> used(nv, 0);
    for (uint32_t i : in.indices) {
        assert(i < nv);
        used[i] = 1;
    }
    std::unordered_map<Vec3d, uint32_t, PositionHash> local_at;
    std::vector<uint32_t> local_of(nv, UINT32_MAX), input_of;
    std::vector<Vec3d> local_pos;
    for (size_t v = 0; v < nv; ++v) {
        if (!used[v]) continue;
        if (in.keep_attribute_seams) {  // every vertex stays itself; meshopt finds the seams by position
            local_of[v] = static_cast<uint32_t>(local_pos.size());
            local_pos.push_back(in.positions[v]);
            input_of.push_back(static_cast<uint32_t>(v));
            continue;
        }
        auto [it, inserted] = local_at.emplace(in.positions[v], static_cast<uint32_t>(local_pos.size()));
        if (inserted) {
            local_pos.push_back(in.positions[v]);
            input_of.push_back(static_cast<uint32_t>(v));
        }
        local_of[v] = it->second;
    }
    std::vector<uint32_t> all_local(in.indices.size()), kept;
    for (size_t i = 0; i < in.indices.size(); ++i) all_local[i] = local_of[in.indices[i]];
    kept.reserve(all_local.size());
    for (size_t t = 0; t < all_local.size(); t += 3) {
        const uint32_t a = all_local[t], b = all_local[t + 1], c = all_local[t + 2];
        // Zero area after welding: covers no pixel, and meshopt would drop it.
        if (local_pos[a] == local_pos[b] || local_pos[b] == local_pos[c] || local_pos[c] == local_pos[a]) continue;
        kept.insert(kept.end(), {a, b, c});
    }

    // Centre in double, then float for meshopt: float32 has 1 mm spacing at
    // 8 km, so raw local coordinates of a large city would already be lossy.
    // The measurement uses the centred doubles too (better conditioned cross
    // products than at large offsets; the shift itself is exact or 1 ulp).
    Box3d box;
    for (const Vec3d& p : local_pos) box.extend(p);
    const Vec3d centre = box.empty() ? Vec3d{} : 0.5 * (box.min + box.max);
    std::vector<Vec3d> centred(local_pos.size());
    std::vector<float> fpos(local_pos.size() * 3);
    for (size_t v = 0; v < local_pos.size(); ++v) {
        centred[v] = local_pos[v] - centre;
        fpos[3 * v] = static_cast<float>(centred[v].x);
        fpos[3 * v + 1] = static_cast<float>(centred[v].y);
        fpos[3 * v + 2] = static_cast<float>(centred[v].z);
    }
    const size_t n_local = local_pos.size();
    std::vector<Vec3d>().swap(local_pos);  // centred stands for it from here
    std::vector<uint8_t>().swap(used);

    const size_t target_indices = std::min(target_triangles, (std::numeric_limits<size_t>::max() / 3) - 1) * 3;
    // The fewest triangles over `kept_l` (triangles of `kept`) whose error fits
    // the bound, measured against the input triangles `input_l` (zero-area
    // ones included) from the input vertices `from`; and that error.
    auto fit = [&](const std::vector<uint32_t>& kept_l, const std::vector<uint32_t>& input_l,
                   const std::vector<uint32_t>& from) -> std::pair<std::vector<uint32_t>, double> {
        const TriangleGrid input_grid(centred, input_l);
        // The input triangles by their corner set, to recognise an output
        // triangle that meshopt left as it was (near the root, most of them:
        // the children were already simplified as far as their seams allow).
        std::vector<std::pair<std::array<uint32_t, 3>, uint32_t>> input_by_corners;  // (sorted corners, first index)
        input_by_corners.reserve(input_l.size() / 3);
        for (size_t t = 0; t < input_l.size(); t += 3) {
            std::array<uint32_t, 3> corners{input_l[t], input_l[t + 1], input_l[t + 2]};
            std::sort(corners.begin(), corners.end());
            input_by_corners.emplace_back(corners, static_cast<uint32_t>(t));
        }
        std::sort(input_by_corners.begin(), input_by_corners.end());
        auto inputTriangleOf = [&](const uint32_t* tri) -> std::optional<uint32_t> {
            std::array<uint32_t, 3> corners{tri[0], tri[1], tri[2]};
            std::sort(corners.begin(), corners.end());
            const auto it = std::lower_bound(input_by_corners.begin(), input_by_corners.end(),
                                             std::make_pair(corners, uint32_t{0}));
            if (it == input_by_corners.end() || it->first != corners) return std::nullopt;
            return it->second;
        };
        // Measures an output index list (local vertices) as simplify.h defines
        // the error; +inf when it exceeds the bound. What meshopt left in
        // place is not searched for: an input vertex the output still has
        // is at distance 0 from it, and the samples of an output triangle
        // that is an input triangle lie on that triangle, so their distance
        // to the input is at most the distance to it (rounding, ~1e-16 m).
        // That bound stands in for them only when the rest measure at least
        // as much, so the maximum is the one a full search finds.
        auto measure = [&](const std::vector<uint32_t>& out) {
            if (out.empty()) return kInf;
            std::vector<uint8_t> on_output(n_local, 0);
            for (uint32_t v : out) on_output[v] = 1;
            std::vector<uint32_t> moved;  // input vertices the output no longer has
            for (uint32_t v : from)
                if (!on_output[v]) moved.push_back(v);
            double to_output = 0;
            if (!moved.empty()) {
                const TriangleGrid out_grid(centred, out);
                to_output = maxDistance(moved.size(), [&](size_t i) { return centred[moved[i]]; }, out_grid, bound);
                if (!(to_output <= bound)) return kInf;
            }
            // Seven samples per output triangle (corners, edge midpoints,
            // centroid), made as they are measured.
            auto sampleOf = [&](size_t t, size_t k) {
                const Vec3d& a = centred[out[t]];
                const Vec3d& b = centred[out[t + 1]];
                const Vec3d& c = centred[out[t + 2]];
                switch (k) {
                    case 0: return a;
                    case 1: return b;
                    case 2: return c;
                    case 3: return 0.5 * (a + b);
                    case 4: return 0.5 * (b + c);
                    case 5: return 0.5 * (c + a);
                    default: return (1.0 / 3.0) * (a + b + c);
                }
            };
            std::vector<uint32_t> changed;  // output triangles (first index) that are no input triangle
            double unchanged_bound = 0;     // at least every sample distance of the others
            for (size_t t = 0; t < out.size(); t += 3) {
                const std::optional<uint32_t> same = inputTriangleOf(&out[t]);
                if (!same) {
                    changed.push_back(static_cast<uint32_t>(t));
                    continue;
                }
                const Vec3d& a = centred[input_l[*same]];
                const Vec3d& b = centred[input_l[*same + 1]];
                const Vec3d& c = centred[input_l[*same + 2]];
                for (size_t k = 0; k < 7; ++k)
                    unchanged_bound = std::max(unchanged_bound, std::sqrt(pointTriangleDist2(sampleOf(t, k), a, b, c)));
            }
            const double from_changed = maxDistance(
                changed.size() * 7, [&](size_t i) { return sampleOf(changed[i / 7], i % 7); }, input_grid, bound);
            if (!(from_changed <= bound)) return kInf;
            if (unchanged_bound <= from_changed) return std::max(to_output, from_changed);
            // Everything else measured ~0: search for every sample.
            return std::max(to_output, maxDistance(out.size() / 3 * 7,
                                                   [&](size_t i) { return sampleOf(3 * (i / 7), i % 7); }, input_grid,
                                                   bound));
        };

        // meshopt's target_error is relative to the mesh extent; the scale is
        // the one meshopt derives from the same buffer (its largest side).
        const float scale = meshopt_simplifyScale(fpos.data(), n_local, sizeof(float) * 3);
        // Capped at 16 extents (everything can collapse long before), which
        // also keeps log2 finite for an infinite bound.
        const double rel0 = scale > 0 ? std::min(bound / static_cast<double>(scale), 16.0) : 0.0;

        // The error of the welded input itself: 0, but for vertices that only
        // zero-area triangles used (they are not on the kept surface).
        auto identityError = [&] {
            std::vector<uint8_t> on_kept(n_local, 0);
            for (uint32_t v : kept_l) on_kept[v] = 1;
            std::vector<Vec3d> loose;
            for (uint32_t v : from)
                if (!on_kept[v]) loose.push_back(centred[v]);
            if (loose.empty()) return 0.0;
            const TriangleGrid kept_grid(centred, kept_l);
            return maxDistance(loose.size(), [&](size_t i) { return loose[i]; }, kept_grid, kInf);
        };

        // Why a ladder and a measurement per rung: meshopt's error is an
        // area-weighted MEAN of squared plane distances at a vertex, so a
        // collapse it accepts at rel0 can move a corner much farther than
        // the bound (a box corner: one of its three planes barely weighs),
        // and the measured error is not even monotone in meshopt's target
        // (a slightly larger target can take a collapse that costs a whole
        // storey). So meshopt is run at a FIXED ladder of relative targets
        // 2^(-k/4) (independent of the bound), from the highest rung <= rel0
        // down to 2^-24 and then 0, and the result is the first attempt
        // whose measured error fits. It is also the one with the fewest
        // triangles: meshopt takes collapses in order of their error while
        // under its target, so a lower rung collapses no more (and an
        // attempt with no collapse at all ends the scan too). A looser bound
        // only adds rungs above and admits more attempts, so the triangle
        // count never grows with the bound (while the target does not bind).
        // Stopping at the first fit matters for the cost at city scale:
        // near the root, nodes merge children that are already simplified as
        // far as their atlas seams allow, the top rung fits, and scanning on
        // to the rung where nothing collapses was ~60 meshopt runs over the
        // whole merge for nothing (a 50,000-building town: 62 -> 45 s, the
        // same folder byte for byte).
        // Cost: up to ~100 meshopt runs for a small bound; 4 rungs per octave
        // instead of 2 cost 1.5x the time and kept ~15% fewer triangles on a
        // 3000-building town at 10 m (41k instead of 48k of 65k).
        constexpr int kRungsPerOctave = 4;
        constexpr int kLowestRung = 24 * kRungsPerOctave;  // 2^-24: below float32 resolution of the extent
        std::vector<double> ladder;
        if (rel0 > 0) {
            auto rung = [](int i) { return std::exp2(-static_cast<double>(i) / kRungsPerOctave); };
            int k = std::max(-4 * kRungsPerOctave,  // rung(-16) = 16 >= rel0
                             static_cast<int>(std::floor(-kRungsPerOctave * std::log2(rel0))) - 1);
            while (k <= kLowestRung && rung(k) > rel0) ++k;
            for (; k <= kLowestRung; ++k) ladder.push_back(rung(k));
        }
        ladder.push_back(0.0);

        // Already within the target (what is left after features are left
        // out may be): the target binds before anything collapses.
        if (kept_l.size() <= target_indices) return {kept_l, identityError()};

        std::optional<std::vector<uint32_t>> best;
        double best_error = kInf;
        // meshopt runs one thread per call, and near the root of a large
        // tree one merge is all the work left: the rungs' meshopt runs go in
        // batches, side by side, and the scan above goes over each batch's
        // results in ladder order, so the result is the one-at-a-time
        // result for any batch size; a batch costs at most its size - 1
        // runs past the stopping rung.
        const size_t run_bytes = kept_l.size() * kMeshoptBytesPerIndex;
        const size_t batch = std::clamp<size_t>(
            std::min<size_t>(static_cast<size_t>(tbb::this_task_arena::max_concurrency()),
                             kMeshoptBudgetBytes / std::max<size_t>(run_bytes, 1)),
            1, 8);
        std::vector<std::vector<uint32_t>> outs(batch, std::vector<uint32_t>(kept_l.size()));
        std::vector<size_t> counts(batch);
        bool stop = false;
        for (size_t first = 0; first < ladder.size() && !stop; first += batch) {
            const size_t in_batch = std::min(batch, ladder.size() - first);
            tbb::parallel_for(size_t{0}, in_batch, [&](size_t b) {
                meshoptGate().acquire(run_bytes);
                counts[b] = meshopt_simplify(outs[b].data(), kept_l.data(), kept_l.size(), fpos.data(), n_local,
                                             sizeof(float) * 3, target_indices, static_cast<float>(ladder[first + b]), 0,
                                             nullptr);
                meshoptGate().release(run_bytes);
            });
            for (size_t b = 0; b < in_batch && !stop; ++b) {
                const std::vector<uint32_t>& out = outs[b];
                const size_t n = counts[b];
                const bool identity = n == kept_l.size() && std::equal(kept_l.begin(), kept_l.end(), out.begin());
                // An empty result fits no finite bound (its error is infinite);
                // at an infinite bound it would, but a node must show something.
                if (n > 0 && (!best || n < best->size())) {
                    const std::vector<uint32_t> attempt(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n));
                    const double error = identity ? identityError() : measure(attempt);
                    if (error <= bound) {
                        best = attempt;
                        best_error = error;
                        stop = true;  // lower rungs keep at least as many triangles
                    }
                }
                if (identity) stop = true;
            }
        }
        if (best) return {std::move(*best), best_error};
        // Nothing fitted, not even the welded input: only possible when
        // vertices of zero-area triangles lie off the kept surface by more
        // than the bound. The welded input and its error.
        return {kept_l, identityError()};
    };

    std::vector<uint32_t> chosen;
    double chosen_error = 0;
    if (!kept.empty()) {
        std::unordered_set<uint32_t> dropped;
        double largest_dropped = 0;
        auto featureOf = [&](uint32_t local) { return in.feature_id[input_of[local]]; };
        if (in.drop_features_below_m > 0 && !in.feature_id.empty() && kept.size() > target_indices) {
            // Above the target: whole features out first, smallest first,
            // counting their input triangles (simplify.h).
            std::unordered_map<uint32_t, Box3d> extent;  // over the input surface
            for (size_t i = 0; i < in.indices.size(); ++i)
                extent[in.feature_id[in.indices[i]]].extend(centred[all_local[i]]);
            std::unordered_map<uint32_t, size_t> drawn;  // triangles of the input, by feature
            for (size_t t = 0; t < kept.size(); t += 3) ++drawn[featureOf(kept[t])];
            dropped = featuresToLeaveOut(extent, drawn, in.drop_features_below_m, target_indices / 3, &largest_dropped);
        }
        if (dropped.empty()) {
            std::vector<uint32_t> all_vertices(n_local);
            std::iota(all_vertices.begin(), all_vertices.end(), 0u);
            std::tie(chosen, chosen_error) = fit(kept, all_local, all_vertices);
        } else {
            // The rest simplified on its own, and measured against the rest
            // only: what is left out is not there to be near.
            auto without = [&](const std::vector<uint32_t>& tris) {
                std::vector<uint32_t> out;
                for (size_t t = 0; t < tris.size(); t += 3)
                    if (!dropped.count(featureOf(tris[t])))
                        out.insert(out.end(), tris.begin() + static_cast<std::ptrdiff_t>(t),
                                   tris.begin() + static_cast<std::ptrdiff_t>(t + 3));
                return out;
            };
            std::vector<uint32_t> from;
            for (uint32_t v = 0; v < n_local; ++v)
                if (!dropped.count(featureOf(v))) from.push_back(v);
            std::tie(chosen, chosen_error) = fit(without(kept), without(all_local), from);
            result.left_out_diagonal_m = largest_dropped;
            result.features_left_out = dropped.size();
        }
    }
    // else: every triangle has zero area; the result is empty and its error
    // is reported as 0 (there is no surface to measure against).

    result.indices.resize(chosen.size());
    for (size_t i = 0; i < chosen.size(); ++i) result.indices[i] = input_of[chosen[i]];
    result.triangles_out = result.indices.size() / 3;
    result.geometric_error_m = chosen_error;

    if (!in.feature_id.empty()) {
        std::vector<uint32_t> before, after;
        before.reserve(in.indices.size());
        for (uint32_t i : in.indices) before.push_back(in.feature_id[i]);
        for (uint32_t i : result.indices) after.push_back(in.feature_id[i]);
        for (auto* v : {&before, &after}) {
            std::sort(v->begin(), v->end());
            v->erase(std::unique(v->begin(), v->end()), v->end());
        }
        std::set_difference(before.begin(), before.end(), after.begin(), after.end(),
                            std::back_inserter(result.features_dropped));
    }
    return result;
}

}  // namespace cityatlas::tiles
