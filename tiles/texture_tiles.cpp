// SPDX-License-Identifier: GPL-3.0-or-later
#include "tiles/texture_tiles.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace cityatlas::tiles {

TexelRect TileGrid::coreOf(int index) const {
    const int c = index % columns(), r = index / columns();
    return {c * core, r * core, std::min(width, (c + 1) * core), std::min(height, (r + 1) * core)};
}

TexelRect TileGrid::rectOf(int index) const {
    const TexelRect k = coreOf(index);
    TexelRect t{k.x0 - overlap, k.y0 - overlap, k.x1 + overlap, k.y1 + overlap};
    if (!wraps) t = {std::max(0, t.x0), std::max(0, t.y0), std::min(width, t.x1), std::min(height, t.y1)};
    return t;
}

bool splitsTexture(int width, int height, int atlas_size_px) {
    const auto atlas = static_cast<int64_t>(atlas_size_px) * atlas_size_px;
    return atlas > 0 && static_cast<int64_t>(width) * height > 2 * atlas;
}

TileGrid tileGridFor(int width, int height, WrapMode wrap, int atlas_size_px, int overlap) {
    // Tiles are sampled clamped; so is every texture that does not repeat
    // (the client draws None, Clamp, Border and Mirror clamped to the edge).
    return {width, height, atlas_size_px, overlap, wrap == WrapMode::Wrap};
}

TileGrid splitGridOf(const TextureInfo& texture, int atlas_size_px, bool split) {
    if (!split || !splitsTexture(texture.width_px, texture.height_px, atlas_size_px)) return {};
    return tileGridFor(texture.width_px, texture.height_px, texture.wrap, atlas_size_px);
}

std::vector<TexelRect> tilesetEntries(const TextureInfo& texture, int atlas_size_px, bool split) {
    const TileGrid grid = splitGridOf(texture, atlas_size_px, split);
    std::vector<TexelRect> out{TexelRect{0, 0, texture.width_px, texture.height_px}};
    for (int k = 0; k < grid.count(); ++k) out.push_back(grid.rectOf(k));
    return out;
}

format::Image8 cropTile(const format::Image8& image, const TexelRect& rect, bool wraps) {
    if (image.width < 1 || image.height < 1 || rect.width() < 1 || rect.height() < 1)
        throw std::invalid_argument("cropTile: empty image or rect");
    format::Image8 out{rect.width(), rect.height(), image.channels, {}};
    const auto ch = static_cast<size_t>(image.channels);
    out.pixels.resize(static_cast<size_t>(out.width) * static_cast<size_t>(out.height) * ch);
    auto source = [&](int v, int size) {
        if (wraps) return ((v % size) + size) % size;
        return std::clamp(v, 0, size - 1);
    };
    for (int y = 0; y < out.height; ++y) {
        const auto sy = static_cast<size_t>(source(rect.y0 + y, image.height));
        for (int x = 0; x < out.width; ++x) {
            const auto sx = static_cast<size_t>(source(rect.x0 + x, image.width));
            std::copy_n(image.pixels.data() + (sy * static_cast<size_t>(image.width) + sx) * ch, ch,
                        out.pixels.data() + (static_cast<size_t>(y) * static_cast<size_t>(out.width) + static_cast<size_t>(x)) * ch);
        }
    }
    return out;
}

namespace {

// A corner in texel space: s = u * W (right), t = (1 - v) * H (down from the
// top row), so the core lines are s = n W + k A and t = n H + k A.
struct Corner {
    double s = 0, t = 0;
    Vec3d position;
    Vec2d uv_atlas;
};

double along(const Corner& c, int axis) { return axis == 0 ? c.s : c.t; }

bool before(const Corner& a, const Corner& b) { return a.s < b.s || (a.s == b.s && a.t < b.t); }

// The point of edge a-b on the line `axis` = L, from the endpoints in a fixed
// order (so both triangles of a shared edge compute the same point).
Corner cut(Corner a, Corner b, int axis, double line) {
    if (before(b, a)) std::swap(a, b);
    const double f = (line - along(a, axis)) / (along(b, axis) - along(a, axis));
    Corner p;
    p.s = axis == 0 ? line : a.s + f * (b.s - a.s);
    p.t = axis == 1 ? line : a.t + f * (b.t - a.t);
    p.position = a.position + f * (b.position - a.position);
    p.uv_atlas = {a.uv_atlas.x + f * (b.uv_atlas.x - a.uv_atlas.x), a.uv_atlas.y + f * (b.uv_atlas.y - a.uv_atlas.y)};
    return p;
}

// Sutherland-Hodgman against one line: the parts of the convex polygon with
// `axis` <= line and >= line.
void split(const std::vector<Corner>& poly, int axis, double line, std::vector<Corner>* low, std::vector<Corner>* high) {
    low->clear();
    high->clear();
    for (size_t i = 0; i < poly.size(); ++i) {
        const Corner& a = poly[i];
        const Corner& b = poly[(i + 1) % poly.size()];
        const double da = along(a, axis) - line, db = along(b, axis) - line;
        if (da <= 0) low->push_back(a);
        if (da >= 0) high->push_back(a);
        if ((da < 0 && db > 0) || (da > 0 && db < 0)) {
            const Corner p = cut(a, b, axis, line);
            low->push_back(p);
            high->push_back(p);
        }
    }
}

// The core lines strictly inside (lo, hi) on one axis: every period's for a
// repeating texture, the inner ones for a clamped one.
std::vector<double> linesWithin(double lo, double hi, int size, int core, bool wraps) {
    std::vector<double> out;
    if (wraps) {
        const auto first = static_cast<int64_t>(std::floor(lo / size));
        const auto last = static_cast<int64_t>(std::floor(hi / size));
        for (int64_t n = first; n <= last; ++n)
            for (int k = 0; k < size; k += core) {
                const double l = static_cast<double>(n) * size + k;
                if (l > lo && l < hi) out.push_back(l);
            }
    } else {
        for (int k = core; k < size; k += core)
            if (k > lo && k < hi) out.push_back(k);
    }
    return out;
}

// Cuts each polygon of `polys` at the core lines of one axis.
std::vector<std::vector<Corner>> slice(std::vector<std::vector<Corner>> polys, int axis, int size, int core, bool wraps) {
    std::vector<std::vector<Corner>> out;
    std::vector<Corner> low, high;
    for (std::vector<Corner>& rest : polys) {
        double lo = along(rest[0], axis), hi = lo;
        for (const Corner& c : rest) lo = std::min(lo, along(c, axis)), hi = std::max(hi, along(c, axis));
        for (const double line : linesWithin(lo, hi, size, core, wraps)) {
            split(rest, axis, line, &low, &high);
            if (low.size() >= 3) out.push_back(low);
            rest.swap(high);
        }
        if (rest.size() >= 3) out.push_back(std::move(rest));
    }
    return out;
}

// The cell a piece lies in, from its centroid: period and core index per axis.
std::pair<int64_t, int> cellOf(double centre, int size, int core, int cells, bool wraps) {
    int64_t period = 0;
    if (wraps) period = static_cast<int64_t>(std::floor(centre / size));  // finite and within two periods of the triangle
    const double within = centre - static_cast<double>(period) * size;
    const int k = static_cast<int>(std::clamp(std::floor(within / core), 0.0, static_cast<double>(cells - 1)));
    return {period, k};
}

}  // namespace

bool clipToTiles(const TileGrid& grid, const std::array<ClipVertex, 3>& triangle, std::vector<TilePiece>* out) {
    std::vector<Corner> poly;
    for (const ClipVertex& v : triangle)
        poly.push_back({v.uv.x * grid.width, (1 - v.uv.y) * grid.height, v.position, v.uv_atlas});
    if (!std::all_of(poly.begin(), poly.end(), [](const Corner& c) { return std::isfinite(c.s) && std::isfinite(c.t); }))
        return false;
    if (grid.wraps)
        for (int axis = 0; axis < 2; ++axis) {
            double lo = along(poly[0], axis), hi = lo;
            for (const Corner& c : poly) lo = std::min(lo, along(c, axis)), hi = std::max(hi, along(c, axis));
            // (Far from the origin, whole periods no longer hold in a double.)
            if (hi - lo >= 2.0 * (axis == 0 ? grid.width : grid.height) || std::abs(lo) > 0x1p50 || std::abs(hi) > 0x1p50)
                return false;
        }
    std::vector<std::vector<Corner>> pieces = slice({poly}, 0, grid.width, grid.core, grid.wraps);
    pieces = slice(std::move(pieces), 1, grid.height, grid.core, grid.wraps);
    for (const std::vector<Corner>& p : pieces) {
        double cs = 0, ct = 0;
        for (const Corner& c : p) cs += c.s, ct += c.t;
        cs /= static_cast<double>(p.size());
        ct /= static_cast<double>(p.size());
        // (Pairs, not structured bindings: the lambda below uses the periods.)
        const std::pair<int64_t, int> cell_s = cellOf(cs, grid.width, grid.core, grid.columns(), grid.wraps);
        const std::pair<int64_t, int> cell_t = cellOf(ct, grid.height, grid.core, grid.rows(), grid.wraps);
        const int64_t ps = cell_s.first, pt = cell_t.first;
        const int tile = cell_t.second * grid.columns() + cell_s.second;
        const TexelRect r = grid.rectOf(tile);
        auto corner = [&](const Corner& c) {
            const double x = c.s - static_cast<double>(ps) * grid.width, y = c.t - static_cast<double>(pt) * grid.height;
            return ClipVertex{c.position, {(x - r.x0) / r.width(), 1 - (y - r.y0) / r.height()}, c.uv_atlas};
        };
        for (size_t i = 1; i + 1 < p.size(); ++i) {
            const std::array<const Corner*, 3> tri{&p[0], &p[i], &p[i + 1]};
            const double area_st = (tri[1]->s - tri[0]->s) * (tri[2]->t - tri[0]->t) - (tri[2]->s - tri[0]->s) * (tri[1]->t - tri[0]->t);
            const double area_xyz = length(cross(tri[1]->position - tri[0]->position, tri[2]->position - tri[0]->position));
            if (area_st == 0 && area_xyz == 0) continue;
            out->push_back({tile, {corner(*tri[0]), corner(*tri[1]), corner(*tri[2])}});
        }
    }
    return true;
}

}  // namespace cityatlas::tiles
