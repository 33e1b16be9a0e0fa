// SPDX-License-Identifier: GPL-3.0-or-later
// castBlockMapRay: the shader's DDA over a BlockMap's cells (blockmap_ray.h).
#include "render/core/blockmap_ray.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace cityatlas::render {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The slab test per axis; +-inf for a zero component (the ray never crosses that slab).
void slab(double o, double inv, double lo, double hi, double* tnear, double* tfar) {
    if (std::isinf(inv)) {
        *tnear = o >= lo && o <= hi ? -kInf : kInf;
        *tfar = o >= lo && o <= hi ? kInf : -kInf;
        return;
    }
    const double a = (lo - o) * inv, b = (hi - o) * inv;
    *tnear = std::min(a, b);
    *tfar = std::max(a, b);
}

// floor(v) (or round(v) - shift) as a cell index clamped into [0, n), in
// double first: no out-of-range conversion whatever v is (NaN: 0).
int cellIndex(double v, int n) { return v >= 0 ? static_cast<int>(std::min(v, n - 1.0)) : 0; }

}  // namespace

double sideSkirt(const Vec3d& d, int face) {
    const double horizontal = std::hypot(d.x, d.y);
    return d.z < 0 && face < kBlockMapRoof && horizontal > 0 ? 0.5 * -d.z / horizontal : 0;
}

BlockMapHit castBlockMapRay(const format::BlockMap& bm, const Vec3d& origin, const Vec3d& direction, bool leap) {
    BlockMapHit out;
    if (bm.nx <= 0 || bm.ny <= 0) return out;
    for (double v : {origin.x, origin.y, origin.z, direction.x, direction.y, direction.z})
        if (!std::isfinite(v)) return out;
    const double s = bm.cell_m;
    // Grid units; t is the same parameter as the caller's (the direction is scaled too).
    const Vec3d o = (1.0 / s) * (origin - bm.origin);
    const Vec3d d = (1.0 / s) * direction;
    const double height = (bm.z_hi - bm.origin.z) / s;
    auto heightOf = [&](uint16_t q) { return (bm.height(q) - bm.origin.z) / s; };
    const Vec3d inv{1.0 / d.x, 1.0 / d.y, 1.0 / d.z};
    double nx0, nx1, ny0, ny1, nz0, nz1;
    slab(o.x, inv.x, 0, bm.nx, &nx0, &nx1);
    slab(o.y, inv.y, 0, bm.ny, &ny0, &ny1);
    slab(o.z, inv.z, 0, height, &nz0, &nz1);
    const double t_exit = std::min({nx1, ny1, nz1});
    double t = std::max({nx0, ny0, nz0, 0.0});
    if (!(t < t_exit) || !std::isfinite(t)) return out;  // a miss (NaN from a degenerate grid too)
    // The face of the cell the ray enters through (as the shader's `face`).
    int face = kBlockMapRoof;
    if (t > 0) {
        if (nz0 >= std::max(nx0, ny0)) face = d.z < 0 ? kBlockMapRoof : kBlockMapUnderside;
        else if (nx0 >= ny0) face = d.x > 0 ? format::kMinusX : format::kPlusX;
        else face = d.y > 0 ? format::kMinusY : format::kPlusY;
    }
    const int step_x = d.x > 0 ? 1 : -1, step_y = d.y > 0 ? 1 : -1;
    int cx = 0, cy = 0;
    double tmax_x = kInf, tmax_y = kInf;
    const double tdelta_x = std::abs(inv.x), tdelta_y = std::abs(inv.y);
    // Cell of the point at t, the entered side deciding on a boundary.
    auto enter = [&](double at) {
        const double px = o.x + d.x * at, py = o.y + d.y * at;
        cx = cellIndex(std::floor(px), bm.nx);
        cy = cellIndex(std::floor(py), bm.ny);
        if (face == format::kMinusX) cx = cellIndex(std::round(px), bm.nx);
        if (face == format::kPlusX) cx = cellIndex(std::round(px) - 1, bm.nx);
        if (face == format::kMinusY) cy = cellIndex(std::round(py), bm.ny);
        if (face == format::kPlusY) cy = cellIndex(std::round(py) - 1, bm.ny);
        tmax_x = std::isinf(inv.x) ? kInf : (cx + (step_x > 0 ? 1 : 0) - o.x) * inv.x;
        tmax_y = std::isinf(inv.y) ? kInf : (cy + (step_y > 0 ? 1 : 0) - o.y) * inv.y;
    };
    enter(t);
    const int max_steps = bm.nx + bm.ny + 8;
    for (; out.steps < max_steps; ++out.steps) {
        const uint8_t dist = bm.dist[bm.index(cx, cy)];
        if (leap && dist >= 2) {
            // Every cell within dist - 1 of (cx, cy) is empty: leave that square.
            const double lo_x = cx - (dist - 1.0), hi_x = cx + static_cast<double>(dist);
            const double lo_y = cy - (dist - 1.0), hi_y = cy + static_cast<double>(dist);
            const double tx = std::isinf(inv.x) ? kInf : ((d.x > 0 ? hi_x : lo_x) - o.x) * inv.x;
            const double ty = std::isinf(inv.y) ? kInf : ((d.y > 0 ? hi_y : lo_y) - o.y) * inv.y;
            const double tl = std::min(tx, ty);
            if (tl >= t_exit) return out;
            face = tx < ty ? (d.x > 0 ? format::kMinusX : format::kPlusX) : (d.y > 0 ? format::kMinusY : format::kPlusY);
            t = tl;
            const double px = o.x + d.x * t, py = o.y + d.y * t;
            if ((face == format::kMinusX && std::round(px) >= bm.nx) || (face == format::kPlusX && std::round(px) <= 0) ||
                (face == format::kMinusY && std::round(py) >= bm.ny) || (face == format::kPlusY && std::round(py) <= 0))
                return out;
            enter(t);
            continue;
        }
        const double t_out = std::min({tmax_x, tmax_y, t_exit});
        const format::BlockMapCell& cell = bm.cells[bm.index(cx, cy)];
        if (cell.occupied()) {
            const double h = heightOf(cell.top), b = heightOf(cell.base);
            const double z_in = o.z + d.z * t, z_out = o.z + d.z * t_out;
            double hit_t = -1;
            int hit_face = face;
            if (z_in >= std::max(b - sideSkirt(d, face), 0.0) && z_in <= h) {  // never below the grid's box
                hit_t = t;  // a side (or the roof/underside the walk entered the box through)
            } else if (z_in > h && z_out <= h) {
                hit_t = t + (h - z_in) / d.z, hit_face = kBlockMapRoof;
            } else if (z_in < b && z_out >= b) {
                hit_t = t + (b - z_in) / d.z, hit_face = kBlockMapUnderside;
            }
            if (hit_t >= 0) {
                out.hit = true, out.t = hit_t, out.x = cx, out.y = cy, out.face = hit_face;
                return out;
            }
        }
        if (t_out >= t_exit) return out;
        t = t_out;
        if (tmax_x < tmax_y) {
            cx += step_x, tmax_x += tdelta_x, face = step_x > 0 ? format::kMinusX : format::kPlusX;
        } else {
            cy += step_y, tmax_y += tdelta_y, face = step_y > 0 ? format::kMinusY : format::kPlusY;
        }
        if (!bm.inside(cx, cy)) return out;
    }
    return out;
}

}  // namespace cityatlas::render
