// SPDX-License-Identifier: GPL-3.0-or-later
// buildBlockMap: a node's buildings as the prisms of a BlockMap (passes in
// atlas/blockmap.h).
#include "atlas/blockmap.h"
#include "atlas/texture_file.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>
#include <numeric>
#include <unordered_map>

#include <OpenImageIO/imagecache.h>
#include <fmt/format.h>

#include "atlas/raycast.h"
#include "core/srgb.h"

namespace cityatlas::atlas {
namespace {

using format::BlockMap;
using format::kBlockMapNone;

// The grid over the triangles' box: corner on multiples of the cell side.
// Embree's tree over the triangles' corners (the rays of passes 1 and 4).
std::unique_ptr<RayCaster> casterOver(std::span<const Triangle> triangles) {
    std::vector<std::array<Vec3d, 3>> corners(triangles.size());
    for (size_t i = 0; i < triangles.size(); ++i) corners[i] = triangles[i].position_local;
    return RayCaster::build(corners);
}

// Cells along x and y of the grid aligned to multiples of cell_m from the
// local origin that covers `box` (at least one each way).
std::array<double, 2> gridSizeOver(const Box3d& box, double cell_m) {
    return {std::max(1.0, std::ceil((box.max.x - std::floor(box.min.x / cell_m) * cell_m) / cell_m)),
            std::max(1.0, std::ceil((box.max.y - std::floor(box.min.y / cell_m) * cell_m) / cell_m))};
}

// Fails for a box that is not finite or a grid the file could not hold.
Status placeGrid(std::span<const Triangle> triangles, double cell_m, BlockMap* bm) {
    Box3d box;
    for (const Triangle& t : triangles)
        for (const Vec3d& p : t.position_local) box.extend(p);
    for (double v : {box.min.x, box.min.y, box.min.z, box.max.x, box.max.y, box.max.z})
        if (!std::isfinite(v)) return Status::Fail(StatusCode::kInvalidInput, "BlockMap: a triangle corner is not finite");
    const auto [nx, ny] = gridSizeOver(box, cell_m);
    if (nx * ny > static_cast<double>(format::kBlockMapMaxCells))
        return Status::Fail(StatusCode::kUnsupported,
                            fmt::format("BlockMap: {:.0f} x {:.0f} cells of {} m exceed {} cells: a larger cell is needed", nx,
                                        ny, cell_m, format::kBlockMapMaxCells));
    bm->cell_m = cell_m;
    bm->origin = {std::floor(box.min.x / cell_m) * cell_m, std::floor(box.min.y / cell_m) * cell_m, box.min.z};
    bm->nx = static_cast<int>(nx), bm->ny = static_cast<int>(ny);
    // A flat scene still gets a range (heights are quantized over it).
    bm->z_hi = box.max.z > box.min.z ? box.max.z : box.min.z + 1;
    return Status::Ok();
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
// A building no sample hit (narrower than a cell, between the centres) takes
// the cell under its box's centre when no other building holds it: a prism of
// its box's height. Buildings in ascending id claim cells first: deterministic.
void keepSmallBuildings(std::span<const Triangle> triangles, BlockMap* bm, std::vector<uint32_t>* hit_feature) {
    std::unordered_map<uint32_t, Box3d> missing;
    {
        std::vector<uint32_t> held(hit_feature->begin(), hit_feature->end());
        std::sort(held.begin(), held.end());
        for (const Triangle& t : triangles)
            if (!std::binary_search(held.begin(), held.end(), t.feature))
                for (const Vec3d& p : t.position_local) missing[t.feature].extend(p);
    }
    std::vector<uint32_t> order;
    for (const auto& [f, box] : missing) order.push_back(f);
    std::sort(order.begin(), order.end());
    for (const uint32_t f : order) {
        const Box3d& box = missing[f];
        const int x = static_cast<int>(std::floor((0.5 * (box.min.x + box.max.x) - bm->origin.x) / bm->cell_m));
        const int y = static_cast<int>(std::floor((0.5 * (box.min.y + box.max.y) - bm->origin.y) / bm->cell_m));
        if (!bm->inside(x, y) || (*hit_feature)[bm->index(x, y)] != kBlockMapNone) continue;
        format::BlockMapCell& c = bm->cells[bm->index(x, y)];
        c.top = std::max<uint16_t>(1, bm->quantize(box.max.z));
        c.base = std::min(c.top, bm->quantize(box.min.z));
        (*hit_feature)[bm->index(x, y)] = f;
    }
}

void castCells(std::span<const Triangle> triangles, const RayCaster* caster, BlockMapSample sample, bool keep_small,
               BlockMap* bm) {
    const double above = bm->z_hi + 1, below = bm->origin.z - 1;
    std::vector<uint32_t> hit_feature(static_cast<size_t>(bm->nx) * static_cast<size_t>(bm->ny), kBlockMapNone);
    bm->cells.assign(hit_feature.size(), format::BlockMapCell{});
    // Centre: one sample at the cell centre. Max: 4 x 4 over the cell; the
    // highest top, the lowest base, the building of the highest top.
    const int n = sample == BlockMapSample::Max ? 4 : 1;
    tbb::parallel_for(0, bm->ny, [&](int y) {
        for (int x = 0; x < bm->nx; ++x) {
            double top = -std::numeric_limits<double>::infinity(), base = std::numeric_limits<double>::infinity();
            uint32_t feature = kBlockMapNone;
            for (int a = 0; a < n; ++a)
                for (int b = 0; b < n; ++b) {
                    const double cx = bm->origin.x + (x + (a + 0.5) / n) * bm->cell_m;
                    const double cy = bm->origin.y + (y + (b + 0.5) / n) * bm->cell_m;
                    const RayHit down = caster->nearest({cx, cy, above}, {0, 0, -1});
                    if (!down.hit) continue;
                    const RayHit up = caster->nearest({cx, cy, below}, {0, 0, 1});
                    const double t = heightOn(triangles[down.triangle], cx, cy, above - down.distance);
                    const double u = up.hit ? std::min(t, heightOn(triangles[up.triangle], cx, cy, below + up.distance)) : bm->origin.z;
                    if (t > top) top = t, feature = triangles[down.triangle].feature;
                    base = std::min(base, u);
                }
            if (feature == kBlockMapNone) continue;
            format::BlockMapCell& c = bm->cells[bm->index(x, y)];
            c.top = std::max<uint16_t>(1, bm->quantize(top));
            c.base = std::min(c.top, bm->quantize(base));
            hit_feature[bm->index(x, y)] = feature;
        }
    });
    if (keep_small) keepSmallBuildings(triangles, bm, &hit_feature);
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


// Pass 4: the colour of what rays hit, averaged in linear light.

// A texel index inside [0, n): repeated, mirrored or clamped as the texture wraps.
int wrapIndex(int i, int n, WrapMode mode) {
    if (mode == WrapMode::Wrap) return ((i % n) + n) % n;
    if (mode == WrapMode::Mirror) {
        const int m = ((i % (2 * n)) + 2 * n) % (2 * n);
        return m < n ? m : 2 * n - 1 - m;
    }
    return std::clamp(i, 0, n - 1);
}

}  // namespace

class ReducedTextures {
public:
    static constexpr int kLargest = 32;  ///< texels a side of the largest level kept
    struct Levels {
        bool readable = false;
        int first = 0;  ///< levels[k] is mip level first + k of the full image (level 0)
        std::vector<int> width, height;
        /// sRGB bytes (RGB), rows top-down: the levels are box-filtered in
        /// linear light and stored encoded, 3 bytes a texel (100,000 facades
        /// of 32 px: 0.4 GB, against 1.6 GB as linear floats); read through
        /// linearOf. The rounding moves a linear value by at most 0.0045 (half
        /// a step at white).
        std::vector<std::vector<std::array<uint8_t, 3>>> texels;
    };
    static float linearOf(uint8_t v) { return linearTable()[v]; }
    explicit ReducedTextures(size_t textures) : entries_(textures) {}

    /// The reduced levels of texture `t` (decoded on first use).
    const Levels& levels(size_t t, const TextureTable& textures) {
        Entry& e = entries_[t];
        std::call_once(e.once, [&] { e.levels = reduce(textures.path(t)); });
        return e.levels;
    }

private:
    struct Entry {
        std::once_flag once;
        Levels levels;
    };
    // Read with the atlas stage's reader (atlas/texture_file.h), not through
    // the ImageCache: a city's root reads every texture once, and the
    // cache's whole-image reads cost more than the decoding (see
    // texture_file.cpp). A texture with alpha counts as opaque over black
    // (premultiplied), as the cache's reads gave it.
    static Levels reduce(const std::string& path) {
        Levels out;
        std::string why;
        const std::shared_ptr<const DecodedTexture> d = readTextureFile(path, &why, /*straight_alpha=*/false);
        if (!d) return out;
        int w = d->spec.width, h = d->spec.height;
        const size_t nc = static_cast<size_t>(d->channels);
        const size_t grey = nc < 3 ? 1 : 0;  // one colour channel (grey, grey and alpha): all three from it
        // 8 bits a channel (16-bit ones are rounded) through a table: a pow per
        // texel would cost more than the decoding.
        const std::array<float, 256>& kLinear = linearTable();
        std::vector<std::array<float, 3>> level(static_cast<size_t>(w) * static_cast<size_t>(h));
        for (size_t i = 0; i < level.size(); ++i)
            for (size_t k = 0; k < 3; ++k) {
                const size_t at = i * nc + (grey ? 0 : k);
                const unsigned v = d->raw8.empty() ? (d->raw16[at] + 128u) / 257u : d->raw8[at];
                level[i][k] = kLinear[v];
            }
        // Halve (a 2 x 2 box; an odd last row or column averaged with itself)
        // until the level is small enough to keep, then keep it and the rest.
        int lvl = 0;
        out.readable = true;
        for (;;) {
            if (std::max(w, h) <= kLargest) {
                if (out.texels.empty()) out.first = lvl;
                out.width.push_back(w), out.height.push_back(h), out.texels.push_back(encoded(level));
            }
            if (w == 1 && h == 1) break;
            const int w2 = std::max(1, (w + 1) / 2), h2 = std::max(1, (h + 1) / 2);
            std::vector<std::array<float, 3>> next(static_cast<size_t>(w2) * static_cast<size_t>(h2));
            for (int y = 0; y < h2; ++y)
                for (int x = 0; x < w2; ++x) {
                    const int x0 = std::min(2 * x, w - 1), x1 = std::min(2 * x + 1, w - 1);
                    const int y0 = std::min(2 * y, h - 1), y1 = std::min(2 * y + 1, h - 1);
                    for (size_t k = 0; k < 3; ++k)
                        next[static_cast<size_t>(y * w2 + x)][k] =
                            0.25f * (level[static_cast<size_t>(y0 * w + x0)][k] + level[static_cast<size_t>(y0 * w + x1)][k] +
                                     level[static_cast<size_t>(y1 * w + x0)][k] + level[static_cast<size_t>(y1 * w + x1)][k]);
                }
            level = std::move(next), w = w2, h = h2, ++lvl;
        }
        return out;
    }
    static const std::array<float, 256>& linearTable() {
        static const std::array<float, 256> table = [] {
            std::array<float, 256> t{};
            for (int i = 0; i < 256; ++i) t[static_cast<size_t>(i)] = static_cast<float>(linearFromSrgb(i / 255.0));
            return t;
        }();
        return table;
    }
    static std::vector<std::array<uint8_t, 3>> encoded(const std::vector<std::array<float, 3>>& level) {
        std::vector<std::array<uint8_t, 3>> out(level.size());
        for (size_t i = 0; i < level.size(); ++i)
            for (size_t k = 0; k < 3; ++k)
                out[i][k] = static_cast<uint8_t>(std::lround(std::clamp(srgbFromLinear(level[i][k]), 0.0, 1.0) * 255));
        return out;
    }
    std::vector<Entry> entries_;
};

std::shared_ptr<ReducedTextures> makeReducedTextures(size_t textures) {
    return std::make_shared<ReducedTextures>(textures);
}

namespace {

class SurfaceColours {
public:
    SurfaceColours(std::span<const Triangle> triangles, const SurfaceTables& tables)
        // The process's shared cache: a private one destroyed while the pool's
        // threads keep their per-thread records of it crashes the next one made
        // (two BlockMaps built one after another, build --blockmaps). It is
        // set up once and never emptied here: the BlockMaps of one tree level
        // are built at once, and destroy() (which empties the shared cache)
        // or a new attribute under another's reads aborted OpenImageIO
        // ("levelinfo: m_subimages.size() > subimage").
        : triangles_(triangles), tables_(tables), cache_(OIIO::ImageCache::create(true)) {
        static std::once_flag configured;
        std::call_once(configured, [&] {
            cache_->attribute("max_memory_MB", static_cast<float>(tables.cache_mb));
            cache_->attribute("autotile", 0);
        });
    }
    SurfaceColours(const SurfaceColours&) = delete;
    SurfaceColours& operator=(const SurfaceColours&) = delete;

    /// Linear RGB of triangle `index` at point `p` on it, for samples `spacing_m` apart.
    std::array<double, 3> at(uint32_t index, const Vec3d& p, double spacing_m, std::atomic<uint64_t>* unreadable,
                             uint64_t* reduced) const {
        const Triangle& t = triangles_[index];
        if (t.texture >= 0 && static_cast<size_t>(t.texture) < tables_.textures.size()) {
            const TextureInfo& ref = tables_.textures[static_cast<size_t>(t.texture)];
            const Vec2d uv = uvAt(t, p);
            if (tables_.reduced) {
                // The mip level whose texel is the samples' spacing: a reduced one when it is small enough.
                const ReducedTextures::Levels& r = tables_.reduced->levels(static_cast<size_t>(t.texture), tables_.textures);
                if (r.readable) {
                    const double footprint = spacing_m * texelsPerMetre(t, r.width[0] << r.first, r.height[0] << r.first);
                    const int level = footprint >= 1 ? static_cast<int>(std::floor(std::log2(footprint))) : 0;
                    if (level >= r.first) {
                        const size_t k = std::min(static_cast<size_t>(level - r.first), r.texels.size() - 1);
                        const int w = r.width[k], h = r.height[k];
                        const int x = wrapIndex(static_cast<int>(std::floor(uv.x * w)), w, ref.wrap);
                        const int y = wrapIndex(static_cast<int>(std::floor((1 - uv.y) * h)), h, ref.wrap);
                        const auto& c = r.texels[k][static_cast<size_t>(y * w + x)];
                        ++*reduced;
                        return {ReducedTextures::linearOf(c[0]), ReducedTextures::linearOf(c[1]),
                                ReducedTextures::linearOf(c[2])};
                    }
                }
            }
            float rgb[4] = {0, 0, 0, 0};
            const OIIO::ustring path(tables_.textures.path(static_cast<size_t>(t.texture)));
            const OIIO::ImageSpec* spec = cache_->imagespec(path);
            if (spec && spec->width > 0 && spec->height > 0) {
                const int x = wrapIndex(static_cast<int>(std::floor(uv.x * spec->width)), spec->width, ref.wrap);
                const int y = wrapIndex(static_cast<int>(std::floor((1 - uv.y) * spec->height)), spec->height, ref.wrap);
                const int nc = std::min(spec->nchannels, 3);
                if (cache_->get_pixels(path, 0, 0, x, x + 1, y, y + 1, 0, 1, 0, nc, OIIO::TypeFloat, rgb)) {
                    if (nc < 3) rgb[1] = rgb[2] = rgb[0];  // grey images
                    return {linearFromSrgb(rgb[0]), linearFromSrgb(rgb[1]), linearFromSrgb(rgb[2])};
                }
            }
            (void)cache_->geterror();
            ++*unreadable;
            return {0.5, 0.5, 0.5};
        }
        if (t.material >= 0 && static_cast<size_t>(t.material) < tables_.materials.size()) {
            const auto& d = tables_.materials[static_cast<size_t>(t.material)].diffuse;
            return {d[0], d[1], d[2]};
        }
        return {0.7, 0.7, 0.7};
    }

private:
    // Texels of a w x h texture per metre of triangle t (the square root of
    // their areas' ratio); 0 for a degenerate triangle or uv triangle.
    static double texelsPerMetre(const Triangle& t, int w, int h) {
        const auto& q = t.position_local;
        const double world = length(cross(q[1] - q[0], q[2] - q[0]));
        const double ax = t.uv[1].x - t.uv[0].x, ay = t.uv[1].y - t.uv[0].y;
        const double bx = t.uv[2].x - t.uv[0].x, by = t.uv[2].y - t.uv[0].y;
        const double texels = std::abs(ax * by - ay * bx) * w * h;
        return world > 0 ? std::sqrt(texels / world) : 0;
    }
    // The uv at p from its barycentric coordinates (in double).
    static Vec2d uvAt(const Triangle& t, const Vec3d& p) {
        const auto& q = t.position_local;
        const Vec3d e0 = q[1] - q[0], e1 = q[2] - q[0], ep = p - q[0];
        const double d00 = dot(e0, e0), d01 = dot(e0, e1), d11 = dot(e1, e1), dp0 = dot(ep, e0), dp1 = dot(ep, e1);
        const double den = d00 * d11 - d01 * d01;
        const double b1 = den != 0 ? (d11 * dp0 - d01 * dp1) / den : 0, b2 = den != 0 ? (d00 * dp1 - d01 * dp0) / den : 0;
        const double b0 = 1 - b1 - b2;
        return {b0 * t.uv[0].x + b1 * t.uv[1].x + b2 * t.uv[2].x, b0 * t.uv[0].y + b1 * t.uv[1].y + b2 * t.uv[2].y};
    }
    std::span<const Triangle> triangles_;
    const SurfaceTables& tables_;
    OIIO::ImageCache* cache_;
};

// A deterministic offset in [0, 1) for sample (a, b) of item i: stratified
// jitter, so a regular sample grid cannot alias with a periodic texture
// (paving whose repeat divides the cell: every sample on its joints).
double jitter(uint64_t i, int a, int b, int axis) {
    uint64_t h = (i * 0x9E3779B97F4A7C15ull) ^ (static_cast<uint64_t>(a * 4 + b) << 32 | static_cast<uint64_t>(axis));
    h ^= h >> 31, h *= 0xBF58476D1CE4E5B9ull, h ^= h >> 27, h *= 0x94D049BB133111EBull, h ^= h >> 31;
    return static_cast<double>(h >> 11) * 0x1.0p-53;
}

std::array<uint8_t, 3> srgb8(const std::array<double, 3>& linear) {
    std::array<uint8_t, 3> out{};
    for (size_t k = 0; k < 3; ++k)
        out[k] = static_cast<uint8_t>(std::lround(std::clamp(srgbFromLinear(linear[k]), 0.0, 1.0) * 255));
    return out;
}

void colourPlanes(std::span<const Triangle> triangles, const RayCaster& caster, const SurfaceTables& tables, BlockMap* bm,
                  BlockMapColourStats* stats) {
    const SurfaceColours colours(triangles, tables);
    std::atomic<uint64_t> rays{0}, hits{0}, without{0}, unreadable{0}, reduced{0};
    const double s = bm->cell_m, above = bm->z_hi + 1;
    bm->roof.assign(bm->cells.size() * 3, 0);
    std::vector<std::array<double, 3>> roof_linear(bm->cells.size(), {0.7, 0.7, 0.7});
    tbb::parallel_for(0, bm->ny, [&](int y) {
        uint64_t r = 0, h = 0, reduced_here = 0;
        for (int x = 0; x < bm->nx; ++x) {
            const size_t c = bm->index(x, y);
            if (!bm->cells[c].occupied()) continue;
            std::array<double, 3> sum{0, 0, 0};
            int n = 0;
            for (int a = 0; a < 4; ++a)
                for (int b = 0; b < 4; ++b, ++r) {
                    const Vec3d o{bm->origin.x + (x + (a + jitter(c, a, b, 0)) / 4) * s,
                                  bm->origin.y + (y + (b + jitter(c, a, b, 1)) / 4) * s, above};
                    const RayHit hit = caster.nearest(o, {0, 0, -1});
                    if (!hit.hit) continue;
                    const auto rgb = colours.at(hit.triangle, o + hit.distance * Vec3d{0, 0, -1}, s / 4, &unreadable, &reduced_here);
                    for (size_t k = 0; k < 3; ++k) sum[k] += rgb[k];
                    ++n, ++h;
                }
            if (n > 0) roof_linear[c] = {sum[0] / n, sum[1] / n, sum[2] / n};
            const auto out = srgb8(roof_linear[c]);
            std::copy(out.begin(), out.end(), bm->roof.begin() + static_cast<long>(c * 3));
        }
        rays += r, hits += h, reduced += reduced_here;
    });
    bm->walls.assign(static_cast<size_t>(bm->wall_width) * static_cast<size_t>(bm->wall_height) * 3, 0);
    tbb::parallel_for(size_t{0}, bm->columns.size(), [&](size_t i) {
        const format::BlockMapColumn& col = bm->columns[i];
        const int x = static_cast<int>(col.cell % static_cast<uint32_t>(bm->nx));
        const int y = static_cast<int>(col.cell / static_cast<uint32_t>(bm->nx));
        const int dx = format::kSideDx[col.side], dy = format::kSideDy[col.side];
        const double zb = bm->height(col.base), zt = bm->height(bm->cells[col.cell].top);
        const Vec3d inward{-static_cast<double>(dx), -static_cast<double>(dy), 0};
        // Half a cell outside the side, across its width.
        const double ex = bm->origin.x + (x + 0.5 + dx) * s, ey = bm->origin.y + (y + 0.5 + dy) * s;
        uint64_t r = 0, h = 0, reduced_here = 0;
        for (int row = 0; row < col.rows; ++row) {
            std::array<double, 3> sum{0, 0, 0};
            int n = 0;
            for (int a = 0; a < 4; ++a)
                for (int b = 0; b < 4; ++b, ++r) {
                    const uint64_t texel = (static_cast<uint64_t>(i) << 16) + static_cast<uint64_t>(row);
                    const double along = (a + jitter(texel, a, b, 0)) / 4 - 0.5;
                    const double z = zb + (zt - zb) * (row + (b + jitter(texel, a, b, 1)) / 4) / col.rows;
                    const Vec3d o{ex + along * s * std::abs(dy), ey + along * s * std::abs(dx), z};
                    const RayHit hit = caster.nearest(o, inward, 0, 1.5 * s);
                    if (!hit.hit) continue;
                    const auto rgb = colours.at(hit.triangle, o + hit.distance * inward, s / 4, &unreadable, &reduced_here);
                    for (size_t k = 0; k < 3; ++k) sum[k] += rgb[k];
                    ++n, ++h;
                }
            std::array<double, 3> mean = roof_linear[col.cell];
            if (n > 0) mean = {sum[0] / n, sum[1] / n, sum[2] / n};
            else ++without;
            const auto out = srgb8(mean);
            std::copy(out.begin(), out.end(),
                      bm->walls.begin() + static_cast<long>(((col.y + row) * static_cast<size_t>(bm->wall_width) + col.x) * 3));
        }
        rays += r, hits += h, reduced += reduced_here;
    });
    if (stats) *stats = {rays.load(), hits.load(), without.load(), unreadable.load(), reduced.load()};
}

}  // namespace

Status buildBlockMap(std::span<const Triangle> triangles, const BlockMapParams& params, format::BlockMap* out,
                     const SurfaceTables* surfaces, BlockMapColourStats* stats) {
    if (!(params.cell_m > 0) || !std::isfinite(params.cell_m) || params.row_m < 0 || params.wall_width < 1 ||
        params.wall_width > 65535)
        return Status::Usage(fmt::format("BlockMap: bad parameters (cell {} m, row {} m, wall width {})", params.cell_m,
                                         params.row_m, params.wall_width));
    *out = format::BlockMap{};
    if (triangles.empty()) return Status::Ok();
    if (Status s = placeGrid(triangles, params.cell_m, out); !s.ok()) return s;
    const auto caster = casterOver(triangles);
    castCells(triangles, caster.get(), params.sample, params.keep_small, out);
    makeColumns(params, out);
    if (out->columns.size() > format::kBlockMapMaxColumns || out->wall_height > format::kBlockMapMaxWallHeight)
        return Status::Fail(StatusCode::kUnsupported,
                            fmt::format("BlockMap: {} wall columns, {} texels high, exceed the file's limits", out->columns.size(),
                                        out->wall_height));
    out->dist = format::chebyshevDistances(*out);
    if (surfaces) colourPlanes(triangles, *caster, *surfaces, out, stats);
    return Status::Ok();
}

std::array<double, 2> blockMapGridSize(std::span<const Triangle> triangles, double cell_m) {
    Box3d box;
    for (const Triangle& t : triangles)
        for (const Vec3d& p : t.position_local) box.extend(p);
    return gridSizeOver(box, cell_m);
}

void colourBlockMap(std::span<const Triangle> triangles, const SurfaceTables& surfaces, BlockMap* bm,
                    BlockMapColourStats* stats) {
    if (triangles.empty() || bm->cells.empty()) return;
    const auto caster = casterOver(triangles);
    colourPlanes(triangles, *caster, surfaces, bm, stats);
}

}  // namespace cityatlas::atlas
