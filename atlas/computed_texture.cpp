// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/computed_texture.h"

#include "atlas/placement.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace cityatlas::atlas {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;

struct AtlasTriangle {
    std::array<Vec2d, 3> t;  // computed-image texels
    double area = 0;         // twice the signed area
    Vec3d normal;            // unit, in the local frame
};

double cross2(const Vec2d& o, const Vec2d& a, const Vec2d& b) {
    return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

// The point of `tri` with the barycentric coordinates that `c` has in its
// atlas image (extrapolated outside it).
Vec3d pointAt(const Triangle& tri, const AtlasTriangle& a, const Vec2d& c) {
    const double w0 = cross2(a.t[1], a.t[2], c) / a.area, w1 = cross2(a.t[2], a.t[0], c) / a.area;
    const double w2 = 1.0 - w0 - w1;
    const auto& p = tri.position_local;
    return w0 * p[0] + w1 * p[1] + w2 * p[2];
}

Vec3d unitNormal(const Triangle& tri) {
    const auto& p = tri.position_local;
    const Vec3d n = cross(p[1] - p[0], p[2] - p[0]);
    const double l = length(n);
    return l > 0 ? (1.0 / l) * n : Vec3d{0, 0, 0};
}

// The closed triangle holds c, decided exactly (a centre on a shared edge is
// on both triangles, and the first in the range takes it).
bool holds(const AtlasTriangle& a, const Vec2d& c) {
    const K::Point_2 p0(a.t[0].x, a.t[0].y), p1(a.t[1].x, a.t[1].y), p2(a.t[2].x, a.t[2].y), q(c.x, c.y);
    const CGAL::Orientation o = CGAL::orientation(p0, p1, p2);
    if (o == CGAL::COLLINEAR) return false;
    return CGAL::orientation(p0, p1, q) != -o && CGAL::orientation(p1, p2, q) != -o &&
           CGAL::orientation(p2, p0, q) != -o;
}

}  // namespace

LeafTexelMap leafTexelMap(const AtlasTree& tree, int32_t node_index, Layer layer, int scale) {
    LeafTexelMap map;
    const AtlasNode& node = tree.nodes[static_cast<size_t>(node_index)];
    const NodeLayer& nl = node.layers[static_cast<size_t>(layer)];
    if (!nl.present() || scale < 1) return map;
    map.width = (nl.width + scale - 1) / scale, map.height = (nl.height + scale - 1) / scale;
    map.texel.assign(static_cast<size_t>(map.width) * static_cast<size_t>(map.height), -1);
    const int a = tree.params.atlas_size_px;
    const double inv = 1.0 / scale;
    std::vector<AtlasTriangle> atlas_of;  // per triangle of the range
    atlas_of.reserve(nl.range.count);

    // Covered texels: rasterize each triangle's atlas image at texel centres.
    for (uint32_t k = 0; k < nl.range.count; ++k) {
        const uint32_t i = nl.range.first + k;
        const TreeTriangle& t = tree.triangles[i];
        AtlasTriangle at;
        for (int c = 0; c < 3; ++c) {
            const Vec2d q = nl.texelFromRoot(t.atlas_uv[c], node.level, a);
            at.t[c] = {q.x * inv, q.y * inv};
        }
        at.area = cross2(at.t[0], at.t[1], at.t[2]);
        at.normal = unitNormal(t.tri);
        atlas_of.push_back(at);
        if (t.tri.texture < 0 || at.area == 0) continue;
        const int x0 = std::max(0, static_cast<int>(std::floor(std::min({at.t[0].x, at.t[1].x, at.t[2].x}) - 0.5)));
        const int x1 = std::min(map.width - 1, static_cast<int>(std::ceil(std::max({at.t[0].x, at.t[1].x, at.t[2].x}))));
        const int y0 = std::max(0, static_cast<int>(std::floor(std::min({at.t[0].y, at.t[1].y, at.t[2].y}) - 0.5)));
        const int y1 = std::min(map.height - 1, static_cast<int>(std::ceil(std::max({at.t[0].y, at.t[1].y, at.t[2].y}))));
        for (int y = y0; y <= y1; ++y)
            for (int x = x0; x <= x1; ++x) {
                int32_t& slot = map.texel[static_cast<size_t>(y) * static_cast<size_t>(map.width) + static_cast<size_t>(x)];
                const Vec2d c{x + 0.5, y + 0.5};
                if (slot >= 0 || !holds(at, c)) continue;
                slot = static_cast<int32_t>(map.surfaces.size());
                map.surfaces.push_back({i, pointAt(t.tri, at, c), at.normal, true});
            }
    }
    map.covered = map.surfaces.size();

    // Border fill, region by region: a ring at a time, an empty texel of the
    // region takes the triangle of its 8-neighbour (from the rings before)
    // with the lowest triangle index, at its own centre's barycentrics.
    for (const PackedRegion& r : nl.regions) {
        const int rx0 = r.x / scale, ry0 = r.y / scale;
        const int rx1 = std::min(map.width, (r.x + r.w + scale - 1) / scale);
        const int ry1 = std::min(map.height, (r.y + r.h + scale - 1) / scale);
        std::vector<std::pair<size_t, uint32_t>> ring;  // texel, triangle
        for (;;) {
            ring.clear();
            for (int y = ry0; y < ry1; ++y)
                for (int x = rx0; x < rx1; ++x) {
                    const size_t at = static_cast<size_t>(y) * static_cast<size_t>(map.width) + static_cast<size_t>(x);
                    if (map.texel[at] >= 0) continue;
                    uint32_t best = UINT32_MAX;
                    for (int dy = -1; dy <= 1; ++dy)
                        for (int dx = -1; dx <= 1; ++dx) {
                            const int nx = x + dx, ny = y + dy;
                            if (nx < rx0 || nx >= rx1 || ny < ry0 || ny >= ry1) continue;
                            const int32_t s = map.texel[static_cast<size_t>(ny) * static_cast<size_t>(map.width) + static_cast<size_t>(nx)];
                            if (s >= 0) best = std::min(best, map.surfaces[static_cast<size_t>(s)].triangle);
                        }
                    if (best != UINT32_MAX) ring.emplace_back(at, best);
                }
            if (ring.empty()) break;
            for (const auto& [at, i] : ring) {
                const AtlasTriangle& t = atlas_of[i - nl.range.first];
                const Vec2d c{static_cast<double>(at % static_cast<size_t>(map.width)) + 0.5,
                              static_cast<double>(at / static_cast<size_t>(map.width)) + 0.5};
                map.texel[at] = static_cast<int32_t>(map.surfaces.size());
                map.surfaces.push_back({i, pointAt(tree.triangles[i].tri, t, c), t.normal, false});
            }
        }
    }
    return map;
}

ScalarImage evaluateComputed(const LeafTexelMap& map, const std::function<double(const TexelSurface&)>& field,
                             int threads, float empty) {
    ScalarImage image;
    image.width = map.width, image.height = map.height;
    std::vector<float> per_surface(map.surfaces.size());
    const auto evaluate = [&] {
        tbb::parallel_for(size_t{0}, map.surfaces.size(), [&](size_t k) {
            per_surface[k] = static_cast<float>(field(map.surfaces[k]));
        });
    };
    if (threads > 0) {
        tbb::task_arena arena(threads);
        arena.execute(evaluate);
    } else {
        evaluate();  // the caller's arena (all cores at the top level)
    }
    image.value.resize(map.texel.size(), empty);
    for (size_t k = 0; k < map.texel.size(); ++k)
        if (map.texel[k] >= 0) image.value[k] = per_surface[static_cast<size_t>(map.texel[k])];
    return image;
}

ScalarImage innerComputed(const AtlasTree& tree, int32_t node, Layer layer, int scale,
                          const std::function<const ScalarImage*(int32_t child)>& child_image) {
    ScalarImage out;
    const NodeLayer& nl = tree.nodes[static_cast<size_t>(node)].layers[static_cast<size_t>(layer)];
    if (nl.width <= 0 || nl.height <= 0 || scale < 1) return out;
    out.width = (nl.width + scale - 1) / scale, out.height = (nl.height + scale - 1) / scale;
    out.value.assign(static_cast<size_t>(out.width) * static_cast<size_t>(out.height), kNoValue);
    for (const ChildPlacement& p : childPlacements(tree, node, static_cast<int>(layer))) {
        const ScalarImage* c = child_image(p.child);
        if (!c || c->width == 0) continue;
        const int x0 = p.x / scale, y0 = p.y / scale;
        for (int y = 0; 2 * y < c->height; ++y)
            for (int x = 0; 2 * x < c->width; ++x) {
                const int px = x0 + x, py = y0 + y;
                if (px >= out.width || py >= out.height) continue;
                double sum = 0;
                int n = 0;
                for (int dy = 0; dy < 2; ++dy)
                    for (int dx = 0; dx < 2; ++dx) {
                        const int cx = 2 * x + dx, cy = 2 * y + dy;
                        if (cx >= c->width || cy >= c->height) continue;
                        const float v = c->value[static_cast<size_t>(cy) * static_cast<size_t>(c->width) + static_cast<size_t>(cx)];
                        if (std::isnan(v)) continue;
                        sum += v, ++n;
                    }
                if (n > 0)
                    out.value[static_cast<size_t>(py) * static_cast<size_t>(out.width) + static_cast<size_t>(px)] =
                        static_cast<float>(sum / n);
            }
    }
    return out;
}

format::Image8 quantizeUnit(const ScalarImage& image) {
    format::Image8 out;
    out.width = image.width, out.height = image.height, out.channels = 1;
    out.pixels.resize(static_cast<size_t>(image.width) * static_cast<size_t>(image.height));
    for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x) {
            const float v = image.value[static_cast<size_t>(y) * static_cast<size_t>(image.width) + static_cast<size_t>(x)];
            const double q = std::isnan(v) ? 0.0 : std::clamp(std::round(255.0 * v), 0.0, 255.0);
            out.pixels[static_cast<size_t>(image.height - 1 - y) * static_cast<size_t>(image.width) + static_cast<size_t>(x)] =
                static_cast<uint8_t>(q);
        }
    return out;
}

}  // namespace cityatlas::atlas
