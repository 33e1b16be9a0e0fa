// SPDX-License-Identifier: GPL-3.0-or-later
// measureBlockMapError: the two-sided Hausdorff distance between a node's
// triangles and its BlockMap's prisms, by sampling both (blockmap.h).
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>

#include "atlas/blockmap.h"

namespace cityatlas::atlas {
namespace {

using K = CGAL::Simple_cartesian<double>;
using CgalTriangle = K::Triangle_3;
using Iterator = std::vector<CgalTriangle>::const_iterator;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, CGAL::AABB_triangle_primitive<K, Iterator>>>;

// An axis-aligned rectangle of the prisms' surface: corners a, b, c, d in
// order around it (a and c opposite: its box is [min(a, c), max(a, c)]).
struct Face {
    Vec3d a, b, c, d;
};
Face horizontal(double x0, double y0, double x1, double y1, double z) { return {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}}; }
Face vertical(const Vec3d& from, const Vec3d& to, double z0, double z1) {
    return {{from.x, from.y, z0}, {to.x, to.y, z0}, {to.x, to.y, z1}, {from.x, from.y, z1}};
}

double toBox(const Vec3d& p, const Vec3d& lo, const Vec3d& hi) {
    const double dx = std::max({lo.x - p.x, 0.0, p.x - hi.x});
    const double dy = std::max({lo.y - p.y, 0.0, p.y - hi.y});
    const double dz = std::max({lo.z - p.z, 0.0, p.z - hi.z});
    return std::sqrt(dx * dx + dy * dy + dz * dz);
}

// The visible surface of cell (x, y)'s prism: its roof, its exposed sides
// (the spans the columns cover) and its underside when it floats.
void facesOf(const format::BlockMap& bm, int x, int y, std::vector<Face>* out) {
    out->clear();
    const format::BlockMapCell& c = bm.cells[bm.index(x, y)];
    if (!c.occupied()) return;
    const double s = bm.cell_m, x0 = bm.origin.x + x * s, y0 = bm.origin.y + y * s;
    const double top = bm.height(c.top), base = bm.height(c.base);
    out->push_back(horizontal(x0, y0, x0 + s, y0 + s, top));
    if (c.base > 0) out->push_back(horizontal(x0, y0, x0 + s, y0 + s, base));
    for (int k = 0; k < 4; ++k) {
        const uint32_t col = bm.columnOf(x, y, k);
        if (col == format::kBlockMapNone) continue;
        const double zb = bm.height(bm.columns[col].base);
        const double fx = k == format::kPlusX ? x0 + s : x0, fy = k == format::kPlusY ? y0 + s : y0;
        if (k <= format::kMinusX) out->push_back(vertical({fx, y0, 0}, {fx, y0 + s, 0}, zb, top));
        else out->push_back(vertical({x0, fy, 0}, {x0 + s, fy, 0}, zb, top));
    }
}

// Distance from p to the prisms as solids: 0 inside one (a party wall
// between two buildings, a floor: hidden in the original too), else to
// their visible surface, over rings of cells around p's cell until no
// farther ring can hold anything nearer.
double toPrisms(const format::BlockMap& bm, const Vec3d& p) {
    const double s = bm.cell_m;
    const int cx = static_cast<int>(std::floor((p.x - bm.origin.x) / s)), cy = static_cast<int>(std::floor((p.y - bm.origin.y) / s));
    if (bm.inside(cx, cy)) {
        // Half a height quantum of slack: a floor exactly at the base is inside, whichever way the quantum rounded.
        const double slack = 0.5 * (bm.z_hi - bm.origin.z) / 65535;
        const format::BlockMapCell& c = bm.cells[bm.index(cx, cy)];
        if (c.occupied() && p.z >= bm.height(c.base) - slack && p.z <= bm.height(c.top) + slack) return 0;
    }
    double best = std::numeric_limits<double>::infinity();
    std::vector<Face> faces;
    const int max_r = bm.nx + bm.ny + std::abs(cx) + std::abs(cy);
    for (int r = 0; r <= max_r; ++r) {
        if ((r - 1) * s >= best) break;
        for (int y = cy - r; y <= cy + r; ++y)
            for (int x = cx - r; x <= cx + r; ++x) {
                if (std::max(std::abs(x - cx), std::abs(y - cy)) != r || !bm.inside(x, y)) continue;
                facesOf(bm, x, y, &faces);
                for (const Face& f : faces)
                    best = std::min(best, toBox(p, {std::min(f.a.x, f.c.x), std::min(f.a.y, f.c.y), std::min(f.a.z, f.c.z)},
                                                {std::max(f.a.x, f.c.x), std::max(f.a.y, f.c.y), std::max(f.a.z, f.c.z)}));
            }
    }
    return best;
}

// Points on a triangle no farther than `spacing` from the next: a
// barycentric grid of n steps (n from the longest edge), corners included.
void samplesOf(const std::array<Vec3d, 3>& t, double spacing, const std::function<void(const Vec3d&)>& fn) {
    const double longest = std::max({length(t[1] - t[0]), length(t[2] - t[1]), length(t[0] - t[2])});
    const int n = std::max(1, static_cast<int>(std::ceil(longest / spacing)));
    for (int i = 0; i <= n; ++i)
        for (int j = 0; i + j <= n; ++j) {
            const double b1 = static_cast<double>(i) / n, b2 = static_cast<double>(j) / n;
            fn((1 - b1 - b2) * t[0] + b1 * t[1] + b2 * t[2]);
        }
}

}  // namespace

BlockMapError measureBlockMapError(std::span<const Triangle> triangles, const format::BlockMap& bm, double spacing_m) {
    BlockMapError e;
    if (triangles.empty() || bm.nx <= 0) return e;
    double spacing = spacing_m;
    if (!(spacing > 0)) {
        // A quarter cell, or coarser where that would take more than
        // kMaxErrorSamples points of the triangles (a fine node of a large
        // textured building: the cost grows with area over spacing squared).
        double area = 0;
        for (const Triangle& t : triangles) {
            const auto& q = t.position_local;
            area += 0.5 * length(cross(q[1] - q[0], q[2] - q[0]));
        }
        spacing = std::max(bm.cell_m / 4, std::sqrt(area / static_cast<double>(kMaxErrorSamples)));
    }
    // Triangles -> prisms.
    e.triangles_to_prisms_m = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, triangles.size()), 0.0,
        [&](const tbb::blocked_range<size_t>& r, double worst) {
            for (size_t i = r.begin(); i != r.end(); ++i)
                samplesOf(triangles[i].position_local, spacing, [&](const Vec3d& p) { worst = std::max(worst, toPrisms(bm, p)); });
            return worst;
        },
        [](double a, double b) { return std::max(a, b); });
    // Prisms -> triangles: the visible faces sampled, each point's nearest triangle (CGAL's AABB tree).
    std::vector<CgalTriangle> cgal;
    cgal.reserve(triangles.size());
    for (const Triangle& t : triangles) {
        const auto& q = t.position_local;
        const CgalTriangle c({q[0].x, q[0].y, q[0].z}, {q[1].x, q[1].y, q[1].z}, {q[2].x, q[2].y, q[2].z});
        if (!c.is_degenerate()) cgal.push_back(c);
    }
    if (cgal.empty()) return e;
    Tree tree(cgal.begin(), cgal.end());
    tree.accelerate_distance_queries();
    e.prisms_to_triangles_m = tbb::parallel_reduce(
        tbb::blocked_range<int>(0, bm.ny), 0.0,
        [&](const tbb::blocked_range<int>& rows, double worst) {
            std::vector<Face> faces;
            // The last nearest point found: a point of the triangles, so its
            // distance bounds the next sample's from above. A sample within
            // `worst` of it cannot raise the maximum and needs no query (most
            // do not: neighbouring samples have neighbouring nearest points);
            // the others start the tree's search from it. The result is exact.
            std::optional<K::Point_3> hint;
            for (int y = rows.begin(); y != rows.end(); ++y)
                for (int x = 0; x < bm.nx; ++x) {
                    facesOf(bm, x, y, &faces);
                    for (const Face& f : faces) {
                        // The rectangle as two triangles, sampled like the originals.
                        for (const std::array<Vec3d, 3>& t : {std::array<Vec3d, 3>{f.a, f.b, f.c}, std::array<Vec3d, 3>{f.a, f.c, f.d}})
                            samplesOf(t, spacing, [&](const Vec3d& p) {
                                const K::Point_3 q(p.x, p.y, p.z);
                                if (hint && CGAL::squared_distance(q, *hint) <= worst * worst) return;
                                hint = hint ? tree.closest_point(q, *hint) : tree.closest_point(q);
                                worst = std::max(worst, std::sqrt(CGAL::squared_distance(q, *hint)));
                            });
                    }
                }
            return worst;
        },
        [](double a, double b) { return std::max(a, b); });
    e.hausdorff_m = std::max(e.triangles_to_prisms_m, e.prisms_to_triangles_m);
    return e;
}

}  // namespace cityatlas::atlas
