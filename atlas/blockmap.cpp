// SPDX-License-Identifier: GPL-3.0-or-later
// buildBlockMap: a node's buildings as the prisms of a BlockMap (passes in
// atlas/blockmap.h).
#include "atlas/blockmap.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include <fmt/format.h>

#include "atlas/raycast.h"

namespace cityatlas::atlas {
namespace {

using format::BlockMap;
using format::kBlockMapNone;

// The grid over the triangles' box: corner on multiples of the cell side.
void placeGrid(std::span<const Triangle> triangles, double cell_m, BlockMap* bm) {
    Box3d box;
    for (const Triangle& t : triangles)
        for (const Vec3d& p : t.position_local) box.extend(p);
    bm->cell_m = cell_m;
    bm->origin = {std::floor(box.min.x / cell_m) * cell_m, std::floor(box.min.y / cell_m) * cell_m, box.min.z};
    bm->nx = std::max(1, static_cast<int>(std::ceil((box.max.x - bm->origin.x) / cell_m)));
    bm->ny = std::max(1, static_cast<int>(std::ceil((box.max.y - bm->origin.y) / cell_m)));
    // A flat scene still gets a range (heights are quantized over it).
    bm->z_hi = box.max.z > box.min.z ? box.max.z : box.min.z + 1;
}

// Where the vertical line through (x, y) meets the plane of triangle `t`,
// in double (Embree's hit distance is single precision: 1.5 mm off at 20 km,
// a whole height quantum of a 100 m range); the ray's own answer for a
// vertical triangle (the line runs along a wall).
double heightOn(const Triangle& t, double x, double y, double ray_z) {
    const auto& p = t.position_local;
    const Vec3d n = cross(p[1] - p[0], p[2] - p[0]);
    if (std::abs(n.z) <= 1e-12 * length(n)) return ray_z;
    return p[0].z - (n.x * (x - p[0].x) + n.y * (y - p[0].y)) / n.z;
}

// Pass 1: top, base and building of every cell from two vertical rays
// through its centre.
void castCells(std::span<const Triangle> triangles, BlockMap* bm) {
    std::vector<std::array<Vec3d, 3>> corners(triangles.size());
    for (size_t i = 0; i < triangles.size(); ++i) corners[i] = triangles[i].position_local;
    const auto caster = RayCaster::build(corners);
    const double above = bm->z_hi + 1, below = bm->origin.z - 1;
    std::vector<uint32_t> hit_feature(static_cast<size_t>(bm->nx) * static_cast<size_t>(bm->ny), kBlockMapNone);
    bm->cells.assign(hit_feature.size(), format::BlockMapCell{});
    tbb::parallel_for(0, bm->ny, [&](int y) {
        for (int x = 0; x < bm->nx; ++x) {
            const double cx = bm->origin.x + (x + 0.5) * bm->cell_m, cy = bm->origin.y + (y + 0.5) * bm->cell_m;
            const RayHit down = caster->nearest({cx, cy, above}, {0, 0, -1});
            if (!down.hit) continue;
            const RayHit up = caster->nearest({cx, cy, below}, {0, 0, 1});
            const double top = heightOn(triangles[down.triangle], cx, cy, above - down.distance);
            const double base =
                up.hit ? std::min(top, heightOn(triangles[up.triangle], cx, cy, below + up.distance)) : bm->origin.z;
            format::BlockMapCell& c = bm->cells[bm->index(x, y)];
            c.top = std::max<uint16_t>(1, bm->quantize(top));
            c.base = std::min(c.top, bm->quantize(base));
            hit_feature[bm->index(x, y)] = triangles[down.triangle].feature;
        }
    });
    // Local feature numbers in order of first cell (row-major): deterministic.
    std::unordered_map<uint32_t, uint32_t> local;  // scene feature -> local
    for (size_t i = 0; i < hit_feature.size(); ++i) {
        if (hit_feature[i] == kBlockMapNone) continue;
        const auto [it, added] = local.try_emplace(hit_feature[i], static_cast<uint32_t>(bm->features.size()));
        if (added) bm->features.push_back(hit_feature[i]);
        bm->cells[i].feature = it->second;
    }
}

// Pass 2: a column per exposed side, then the wall image's shelves.
void makeColumns(const BlockMapParams& params, BlockMap* bm) {
    const double row_m = params.row_m > 0 ? params.row_m : params.cell_m;
    for (int y = 0; y < bm->ny; ++y)
        for (int x = 0; x < bm->nx; ++x) {
            const uint8_t mask = bm->exposedSides(x, y);
            if (!mask) continue;
            format::BlockMapCell& c = bm->cells[bm->index(x, y)];
            c.first_column = static_cast<uint32_t>(bm->columns.size());
            for (int k = 0; k < 4; ++k) {
                if (!(mask >> k & 1u)) continue;
                const int nx = x + format::kSideDx[static_cast<size_t>(k)], ny = y + format::kSideDy[static_cast<size_t>(k)];
                // The wall shows above a neighbour that stands on the same ground or lower; all of it otherwise.
                const bool on_top = bm->inside(nx, ny) && bm->cells[bm->index(nx, ny)].occupied() &&
                                    bm->cells[bm->index(nx, ny)].base <= c.base;
                format::BlockMapColumn col;
                col.cell = static_cast<uint32_t>(bm->index(x, y));
                col.side = static_cast<uint8_t>(k);
                col.base = on_top ? std::max(c.base, bm->topAt(nx, ny)) : c.base;
                const double span = bm->height(c.top) - bm->height(col.base);
                col.rows = static_cast<uint16_t>(std::clamp(std::ceil(span / row_m - 1e-9), 1.0, 65535.0));
                bm->columns.push_back(col);
            }
        }
    std::vector<uint32_t> order(bm->columns.size());
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(),
                     [&](uint32_t a, uint32_t b) { return bm->columns[a].rows > bm->columns[b].rows; });
    bm->wall_width = params.wall_width;
    int x = 0, y = 0, shelf = 0;
    for (uint32_t i : order) {
        format::BlockMapColumn& col = bm->columns[i];
        if (x == bm->wall_width) x = 0, y += shelf, shelf = 0;
        shelf = std::max<int>(shelf, col.rows);
        col.x = static_cast<uint16_t>(x++);
        col.y = static_cast<uint16_t>(y);
    }
    bm->wall_height = y + shelf;
}

// Pass 3: Chebyshev distance to the nearest occupied cell: a forward and a
// backward pass over the 8-neighbourhood with unit steps is exact for it.
void distanceTransform(BlockMap* bm) {
    const int nx = bm->nx, ny = bm->ny;
    std::vector<int> d(bm->cells.size());
    for (size_t i = 0; i < d.size(); ++i) d[i] = bm->cells[i].occupied() ? 0 : 1 << 24;
    auto relax = [&](int x, int y, int px, int py) {
        if (px >= 0 && py >= 0 && px < nx && py < ny)
            d[bm->index(x, y)] = std::min(d[bm->index(x, y)], d[bm->index(px, py)] + 1);
    };
    for (int y = 0; y < ny; ++y)
        for (int x = 0; x < nx; ++x) {
            relax(x, y, x - 1, y);
            relax(x, y, x - 1, y - 1);
            relax(x, y, x, y - 1);
            relax(x, y, x + 1, y - 1);
        }
    for (int y = ny - 1; y >= 0; --y)
        for (int x = nx - 1; x >= 0; --x) {
            relax(x, y, x + 1, y);
            relax(x, y, x + 1, y + 1);
            relax(x, y, x, y + 1);
            relax(x, y, x - 1, y + 1);
        }
    bm->dist.resize(d.size());
    for (size_t i = 0; i < d.size(); ++i) bm->dist[i] = static_cast<uint8_t>(std::min(d[i], 255));
}

}  // namespace

Status buildBlockMap(std::span<const Triangle> triangles, const BlockMapParams& params, format::BlockMap* out) {
    if (!(params.cell_m > 0) || !std::isfinite(params.cell_m) || params.row_m < 0 || params.wall_width < 1 ||
        params.wall_width > 65535)
        return Status::Usage(fmt::format("BlockMap: bad parameters (cell {} m, row {} m, wall width {})", params.cell_m,
                                         params.row_m, params.wall_width));
    *out = format::BlockMap{};
    if (triangles.empty()) return Status::Ok();
    placeGrid(triangles, params.cell_m, out);
    castCells(triangles, out);
    makeColumns(params, out);
    distanceTransform(out);
    return Status::Ok();
}

}  // namespace cityatlas::atlas
