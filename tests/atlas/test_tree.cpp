// SPDX-License-Identifier: GPL-3.0-or-later
// buildAtlasTree end to end: one brute-force invariant checker (structure,
// ranges, regions, root-atlas coordinates recomputed from the quadrant path,
// split pieces, and the texel-size guarantee measured on every triangle at
// every level) applied to synthetic towns, to hand-made extremes, and to two
// builds that differ only in their thread count.
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <set>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "atlas/atlas_report.h"
#include "atlas/atlas_tree.h"
#include "atlas/charts.h"
#include "atlas/shard_plan.h"
#include "atlas/texel_estimate.h"
#include "ingest/synth/facade_texture.h"
#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"
#include "tests/ingest/test_support.h"

namespace cityatlas::atlas {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------
// Small geometry, written here so the checker shares no code with the library.

Vec3d sub(const Vec3d& a, const Vec3d& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3d scaled(const Vec3d& a, double s) { return {a.x * s, a.y * s, a.z * s}; }
Vec3d added(const Vec3d& a, const Vec3d& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
double norm(const Vec3d& a) { return std::sqrt(a.x * a.x + a.y * a.y + a.z * a.z); }
double dot3(const Vec3d& a, const Vec3d& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3d cross3(const Vec3d& a, const Vec3d& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double area3(const std::array<Vec3d, 3>& p) { return 0.5 * norm(cross3(sub(p[1], p[0]), sub(p[2], p[0]))); }
double det2(const Vec2d& a, const Vec2d& b) { return a.x * b.y - a.y * b.x; }
Vec2d sub2(const Vec2d& a, const Vec2d& b) { return {a.x - b.x, a.y - b.y}; }
double len2sq(const Vec2d& a) { return a.x * a.x + a.y * a.y; }

// Zero area in world space (all corners on a line or a point): such a
// triangle covers no pixels, so it has no texel size to check.
bool worldDegenerate(const std::array<Vec3d, 3>& p) {
    const double e = std::max({dot3(sub(p[1], p[0]), sub(p[1], p[0])), dot3(sub(p[2], p[1]), sub(p[2], p[1])),
                               dot3(sub(p[0], p[2]), sub(p[0], p[2]))});
    return !(e > 0) || 2.0 * area3(p) <= 1e-12 * e;
}

// All uv equal or on a line: the triangle shows one colour (or one line of
// the texture), which has no texel-per-metre density to check.
bool uvDegenerate(const std::array<Vec2d, 3>& uv) {
    const Vec2d a = sub2(uv[1], uv[0]), b = sub2(uv[2], uv[0]);
    const double e = std::max({len2sq(a), len2sq(b), len2sq(sub2(uv[2], uv[1]))});
    return !(e > 0) || std::abs(det2(a, b)) <= 1e-9 * e;
}

// World length per unit of u and of v of a triangle's affine uv -> world map.
std::pair<double, double> metresPerUv(const Triangle& t) {
    const Vec2d a = sub2(t.uv[1], t.uv[0]), b = sub2(t.uv[2], t.uv[0]);
    const double d = det2(a, b);
    const Vec3d v1 = sub(t.position_local[1], t.position_local[0]), v2 = sub(t.position_local[2], t.position_local[0]);
    const Vec3d du = scaled(added(scaled(v1, b.y), scaled(v2, -a.y)), 1.0 / d);
    const Vec3d dv = scaled(added(scaled(v1, -b.x), scaled(v2, a.x)), 1.0 / d);
    return {norm(du), norm(dv)};
}

Layer expectedLayer(const Scene& scene, const Triangle& t) {
    if (t.texture >= 0) return scene.textures[t.texture].channels == 4 ? Layer::Alpha : Layer::Opaque;
    if (t.material >= 0 && scene.materials[t.material].transparency > 0) return Layer::Alpha;
    return Layer::Opaque;
}

// ---------------------------------------------------------------------------
// The invariant checker.

class Violations {
public:
    template <class... T>
    void add(const T&... parts) {
        ++count_;
        if (first_.size() >= 20) return;
        std::ostringstream s;
        s.precision(17);
        (s << ... << parts);
        first_.push_back(s.str());
    }
    testing::AssertionResult result() const {
        if (count_ == 0) return testing::AssertionSuccess();
        auto r = testing::AssertionFailure();
        r << count_ << " violation(s); the first " << first_.size() << ":";
        for (const std::string& m : first_) r << "\n  " << m;
        return r;
    }
    uint64_t count() const { return count_; }

private:
    uint64_t count_ = 0;
    std::vector<std::string> first_;
};

struct Checker {
    const Scene& scene;
    const AtlasTree& tree;
    Violations v;
    std::vector<int32_t> leaf_of;   // per tree triangle
    std::vector<int32_t> preorder;  // node ids as a depth-first walk by quadrant meets them
    std::vector<int32_t> leaves;    // the same, leaves only

    void walk(int32_t id) {
        preorder.push_back(id);
        if (tree.nodes[id].leaf()) leaves.push_back(id);
        for (int32_t c : tree.nodes[id].children)
            if (c >= 0 && c < static_cast<int32_t>(tree.nodes.size()) && c > id) walk(c);
    }

    // Quadrant indices P_1..P_k from the root down to `id`, found by walking up via `parent`.
    std::vector<int> quadrantPath(int32_t id) const {
        std::vector<int> path;
        for (int32_t cur = id; tree.nodes[cur].parent >= 0; cur = tree.nodes[cur].parent) {
            const AtlasNode& p = tree.nodes[tree.nodes[cur].parent];
            int q = -1;
            for (int k = 0; k < 4; ++k)
                if (p.children[k] == cur) q = k;
            path.push_back(q);
        }
        std::reverse(path.begin(), path.end());
        return path;
    }

    void structure() {
        const auto& nodes = tree.nodes;
        const auto n = static_cast<int32_t>(nodes.size());
        if (n == 0) return v.add("no nodes");
        if (nodes[0].parent != -1 || nodes[0].level != 0) v.add("root: parent ", nodes[0].parent, " level ", nodes[0].level);
        for (const NodeLayer& l : nodes[0].layers)
            if (l.offset != std::array<int64_t, 2>{0, 0}) v.add("root: offset ", l.offset[0], ",", l.offset[1]);
        std::vector<int> referenced(n, 0);
        int depth = 0;
        uint64_t leaf_count = 0;
        for (int32_t id = 0; id < n; ++id) {
            const AtlasNode& node = nodes[id];
            depth = std::max(depth, node.level);
            leaf_count += node.leaf();
            double worst_child = 0;
            // Children's halved atlases: inside this node's, apart from each other.
            std::array<std::vector<std::array<int64_t, 4>>, kLayerCount> placed;
            for (int q = 0; q < 4; ++q) {
                const int32_t c = node.children[q];
                if (c < 0) continue;
                if (c <= id || c >= n) {
                    v.add("node ", id, " quadrant ", q, ": child id ", c, " out of order or range");
                    continue;
                }
                ++referenced[c];
                const AtlasNode& k = nodes[c];
                if (k.parent != id) v.add("node ", c, ": parent ", k.parent, ", expected ", id);
                if (k.level != node.level + 1) v.add("node ", c, ": level ", k.level, " under level ", node.level);
                for (int l = 0; l < kLayerCount; ++l) {
                    const NodeLayer &cl = k.layers[l], &pl = node.layers[l];
                    if (cl.atlas_path.empty()) continue;
                    if (pl.atlas_path.empty()) {
                        v.add("node ", c, " layer ", l, ": an atlas under a parent without one");
                        continue;
                    }
                    if (cl.offset[0] % 2 || cl.offset[1] % 2) {
                        v.add("node ", c, " layer ", l, ": odd offset ", cl.offset[0], ",", cl.offset[1]);
                        continue;
                    }
                    const int64_t x = cl.offset[0] / 2 - pl.offset[0], y = cl.offset[1] / 2 - pl.offset[1];
                    const std::array<int64_t, 4> r{x, y, x + (cl.width + 1) / 2, y + (cl.height + 1) / 2};
                    if (x < 0 || y < 0 || r[2] > pl.width || r[3] > pl.height)
                        v.add("node ", c, " layer ", l, ": halved atlas at ", x, ",", y, " leaves its parent's ", pl.width,
                              "x", pl.height);
                    for (const auto& o : placed[l])
                        if (r[0] < o[2] && o[0] < r[2] && r[1] < o[3] && o[1] < r[3])
                            v.add("node ", c, " layer ", l, ": halved atlas overlaps a sibling's in node ", id);
                    placed[l].push_back(r);
                }
                const Box3d& a = k.bounds;
                const Box3d& b = node.bounds;
                if (a.empty() || a.min.x < b.min.x || a.min.y < b.min.y || a.min.z < b.min.z || a.max.x > b.max.x ||
                    a.max.y > b.max.y || a.max.z > b.max.z)
                    v.add("node ", c, ": bounds not inside its parent ", id, "'s");
                worst_child = std::max(worst_child, k.sharp_from_m);
            }
            for (const NodeLayer& l : node.layers)
                if (!l.atlas_path.empty() && (l.width <= 0 || l.height <= 0 || l.width % 4 || l.height % 4 ||
                                              l.width > tree.params.atlas_size_px || l.height > tree.params.atlas_size_px))
                    v.add("node ", id, ": atlas ", l.width, "x", l.height, " not whole blocks within A");
            if (node.leaf()) {
                if (node.min_distance_m != tree.stats.d_min_used_m)
                    v.add("leaf ", id, ": min_distance ", node.min_distance_m, " != d_min used ",
                          tree.stats.d_min_used_m);
                double sharp = node.min_distance_m;
                for (const NodeLayer& l : node.layers)
                    for (const PackedRegion& r : l.regions) sharp = std::max(sharp, r.sharp_from_m);
                if (node.sharp_from_m != sharp)
                    v.add("leaf ", id, ": sharp_from ", node.sharp_from_m, " != its regions' largest ", sharp);
            } else {
                if (node.min_distance_m != 2.0 * worst_child)
                    v.add("node ", id, ": min_distance ", node.min_distance_m, " != 2 x ", worst_child);
                if (node.sharp_from_m != node.min_distance_m)
                    v.add("node ", id, ": sharp_from ", node.sharp_from_m, " != min_distance ", node.min_distance_m);
                for (const NodeLayer& l : node.layers)
                    if (!l.regions.empty()) v.add("inner node ", id, " has packed regions");
            }
        }
        for (int32_t id = 1; id < n; ++id)
            if (referenced[id] != 1) v.add("node ", id, " is the child of ", referenced[id], " nodes");
        walk(0);
        for (int32_t k = 0; k < static_cast<int32_t>(preorder.size()) && k < n; ++k)
            if (preorder[k] != k) {
                v.add("nodes are not numbered in depth-first preorder: position ", k, " holds ", preorder[k]);
                break;
            }
        if (tree.stats.nodes != static_cast<uint64_t>(n) || tree.stats.leaves != leaf_count ||
            tree.stats.depth != depth)
            v.add("stats nodes/leaves/depth ", tree.stats.nodes, "/", tree.stats.leaves, "/", tree.stats.depth,
                  ", counted ", n, "/", leaf_count, "/", depth);
    }

    void ranges() {
        const auto& tris = tree.triangles;
        // Layers in order: every opaque triangle before every alpha one.
        std::array<uint32_t, kLayerCount> start{}, count{};
        for (size_t i = 0; i < tris.size(); ++i) {
            const int l = static_cast<int>(tris[i].layer);
            if (i > 0 && tris[i].layer < tris[i - 1].layer) v.add("triangle ", i, ": layers out of order");
            ++count[l];
            if (tris[i].source < scene.triangles.size() &&
                expectedLayer(scene, scene.triangles[tris[i].source]) != tris[i].layer)
                v.add("triangle ", i, ": layer ", layerName(tris[i].layer), " for its texture/material");
        }
        start[1] = count[0];
        leaf_of.assign(tris.size(), -1);
        for (int l = 0; l < kLayerCount; ++l) {
            uint32_t pos = start[l];
            for (int32_t id : leaves) {
                const TriangleRange& r = tree.nodes[id].layers[l].range;
                if (r.first != pos && r.count > 0)
                    v.add("leaf ", id, " layer ", l, ": range starts at ", r.first, ", the previous leaf ended at ",
                          pos);
                if (r.count == 0) continue;
                for (uint32_t i = r.first; i < r.first + r.count && i < tris.size(); ++i) {
                    if (static_cast<int>(tris[i].layer) != l)
                        v.add("leaf ", id, " layer ", l, ": triangle ", i, " is of the other layer");
                    if (leaf_of[i] >= 0) v.add("triangle ", i, " in two leaves");
                    leaf_of[i] = id;
                    if (i > r.first && tris[i].tri.texture < tris[i - 1].tri.texture)
                        v.add("leaf ", id, " layer ", l, ": triangles not grouped by texture at ", i);
                }
                pos = r.first + r.count;
            }
            if (pos != start[l] + count[l])
                v.add("layer ", l, ": leaves cover up to ", pos, " of [", start[l], ", ", start[l] + count[l], ")");
            for (int32_t id : preorder) {
                const AtlasNode& node = tree.nodes[id];
                if (node.leaf()) continue;
                const TriangleRange& r = node.layers[l].range;
                uint32_t at = r.first;
                for (int32_t c : node.children) {
                    if (c < 0) continue;
                    const TriangleRange& cr = tree.nodes[c].layers[l].range;
                    if (cr.count > 0 && cr.first != at)
                        v.add("node ", id, " layer ", l, ": child ", c, " starts at ", cr.first, ", expected ", at);
                    at += cr.count;
                }
                if (at != r.first + r.count)
                    v.add("node ", id, " layer ", l, ": children cover [", r.first, ", ", at, "), the node [", r.first,
                          ", ", r.first + r.count, ")");
            }
            if (tree.nodes[0].layers[l].range.first != start[l] || tree.nodes[0].layers[l].range.count != count[l])
                v.add("root layer ", l, ": range ", tree.nodes[0].layers[l].range.first, "+",
                      tree.nodes[0].layers[l].range.count, ", expected ", start[l], "+", count[l]);
        }
        for (size_t i = 0; i < tris.size(); ++i)
            if (leaf_of[i] < 0) v.add("triangle ", i, " is in no leaf");
    }

    void regions() {
        for (int32_t id : leaves) {
            const AtlasNode& node = tree.nodes[id];
            for (int l = 0; l < kLayerCount; ++l) {
                const NodeLayer& nl = node.layers[l];
                const int cells_x = nl.width / 4, cells_y = nl.height / 4;
                std::vector<uint8_t> used(static_cast<size_t>(cells_x) * cells_y, 0);
                uint64_t texels = 0;
                for (size_t k = 0; k < nl.regions.size(); ++k) {
                    const PackedRegion& r = nl.regions[k];
                    texels += static_cast<uint64_t>(r.w) * r.h;
                    if (r.texture < 0 || r.texture >= static_cast<int32_t>(scene.textures.size()) ||
                        (scene.textures[r.texture].channels == 4) != (l == 1))
                        v.add("leaf ", id, " layer ", l, " region ", k, ": texture ", r.texture,
                              " wrong for the layer");
                    if (r.x % 4 || r.y % 4 || r.w % 4 || r.h % 4 || r.w <= 0 || r.h <= 0) {
                        v.add("leaf ", id, " layer ", l, " region ", k, ": ", r.x, ",", r.y, " ", r.w, "x", r.h,
                              " not on the 4-texel grid");
                        continue;
                    }
                    if (r.x < 0 || r.y < 0 || r.x + r.w > nl.width || r.y + r.h > nl.height) {
                        v.add("leaf ", id, " layer ", l, " region ", k, " leaves the atlas");
                        continue;
                    }
                    if (!(r.uv_min.x <= r.uv_max.x && r.uv_min.y <= r.uv_max.y))
                        v.add("leaf ", id, " layer ", l, " region ", k, ": empty uv box");
                    for (int y = r.y / 4; y < (r.y + r.h) / 4; ++y)
                        for (int x = r.x / 4; x < (r.x + r.w) / 4; ++x)
                            if (used[static_cast<size_t>(y) * cells_x + x]++)
                                v.add("leaf ", id, " layer ", l, " region ", k, " overlaps another at block ", x, ",",
                                      y);
                }
                if (texels != nl.packed_texels)
                    v.add("leaf ", id, " layer ", l, ": packed_texels ", nl.packed_texels, ", regions cover ", texels);
            }
        }
        // Atlases exist exactly where a layer of a subtree has a textured triangle.
        uint64_t atlases = 0;
        for (int32_t id = 0; id < static_cast<int32_t>(tree.nodes.size()); ++id)
            for (int l = 0; l < kLayerCount; ++l) {
                const NodeLayer& nl = tree.nodes[id].layers[l];
                bool textured = false;
                for (uint32_t i = nl.range.first; i < nl.range.first + nl.range.count && i < tree.triangles.size(); ++i)
                    textured |= tree.triangles[i].tri.texture >= 0;
                if (textured == nl.atlas_path.empty())
                    v.add("node ", id, " layer ", l, ": atlas path '", nl.atlas_path, "' but textured=", textured);
                atlases += !nl.atlas_path.empty();
            }
        if (atlases != tree.stats.atlases) v.add("stats.atlases ", tree.stats.atlases, ", counted ", atlases);
    }

    // Root-atlas coordinates: every textured triangle's, recomputed from its
    // region's mapping and its leaf's integer offset (atlas_tree.h: texel =
    // root * A * 2^level - offset), and every corner inside its region's
    // content (the region's border kept clear).
    void coordinates() {
        const double a = tree.params.atlas_size_px;
        for (size_t i = 0; i < tree.triangles.size(); ++i) {
            const TreeTriangle& t = tree.triangles[i];
            const int32_t leaf = leaf_of[i];
            if (leaf < 0) continue;
            const AtlasNode& node = tree.nodes[leaf];
            for (const Vec3d& p : t.tri.position_local)
                if (p.x < node.bounds.min.x || p.y < node.bounds.min.y || p.z < node.bounds.min.z ||
                    p.x > node.bounds.max.x || p.y > node.bounds.max.y || p.z > node.bounds.max.z)
                    v.add("triangle ", i, ": corner outside its leaf ", leaf, "'s bounds");
            if (t.tri.texture < 0) {
                for (const Vec2d& r : t.atlas_uv)
                    if (r.x != 0 || r.y != 0) v.add("untextured triangle ", i, " has atlas coordinates");
                continue;
            }
            const NodeLayer& nl = node.layers[static_cast<int>(t.layer)];
            const double scale = std::ldexp(1.0 / a, -node.level);
            // The region: same texture, uv box holding the triangle's uv, and
            // the one whose mapping reproduces atlas_uv (charts may overlap in uv).
            const PackedRegion* best = nullptr;
            double best_err = 1e300;
            for (const PackedRegion& r : nl.regions) {
                if (r.texture != t.tri.texture) continue;
                bool inside = true;
                for (const Vec2d& uv : t.tri.uv) {
                    const double tol = 1e-9 * (1 + std::abs(uv.x) + std::abs(uv.y));
                    inside &= uv.x >= r.uv_min.x - tol && uv.x <= r.uv_max.x + tol && uv.y >= r.uv_min.y - tol &&
                              uv.y <= r.uv_max.y + tol;
                }
                if (!inside) continue;
                double err = 0;
                for (int c = 0; c < 3; ++c) {
                    const Vec2d texel = r.toAtlasTexels(t.tri.uv[c]);
                    const double rx = (texel.x + static_cast<double>(nl.offset[0])) * scale,
                                 ry = (texel.y + static_cast<double>(nl.offset[1])) * scale;
                    err = std::max({err, std::abs(rx - t.atlas_uv[c].x), std::abs(ry - t.atlas_uv[c].y)});
                }
                if (err < best_err) best_err = err, best = &r;
            }
            if (!best) {
                v.add("triangle ", i, ": no region of texture ", t.tri.texture, " in leaf ", leaf, " holds its uv");
                continue;
            }
            if (best_err > 1e-12) v.add("triangle ", i, ": atlas_uv off its region's value by ", best_err);
            const double bx = best->rotated ? best->border_v : best->border_u, by = best->rotated ? best->border_u : best->border_v;
            for (int c = 0; c < 3; ++c) {
                const Vec2d p{t.atlas_uv[c].x / scale - static_cast<double>(nl.offset[0]),
                              t.atlas_uv[c].y / scale - static_cast<double>(nl.offset[1])};
                const double tol = 1e-9 * a;
                if (p.x < best->x + bx - tol || p.x > best->x + best->w - bx + tol || p.y < best->y + by - tol ||
                    p.y > best->y + best->h - by + tol)
                    v.add("triangle ", i, " corner ", c, ": texel ", p.x, ",", p.y, " outside the content of region ",
                          best->x, ",", best->y, " ", best->w, "x", best->h, " (border ", bx, ",", by, ")");
            }
        }
    }

    void sources() {
        const size_t n = scene.triangles.size();
        std::vector<std::vector<uint32_t>> pieces(n);
        for (uint32_t i = 0; i < tree.triangles.size(); ++i) {
            const uint32_t s = tree.triangles[i].source;
            if (s >= n) {
                v.add("triangle ", i, ": source ", s, " out of range");
                continue;
            }
            pieces[s].push_back(i);
        }
        uint64_t split = 0, extra = 0;
        for (uint32_t s = 0; s < n; ++s) {
            const Triangle& src = scene.triangles[s];
            if (pieces[s].empty()) {
                v.add("scene triangle ", s, " is missing from the tree");
                continue;
            }
            for (uint32_t i : pieces[s]) {
                const Triangle& t = tree.triangles[i].tri;
                if (t.texture != src.texture || t.material != src.material || t.feature != src.feature ||
                    t.semantic != src.semantic)
                    v.add("triangle ", i, ": texture/material/feature/semantic differ from source ", s);
            }
            if (pieces[s].size() == 1) {
                const Triangle& t = tree.triangles[pieces[s][0]].tri;
                if (t.position_local != src.position_local || t.uv != src.uv)
                    v.add("triangle ", pieces[s][0], ": an unsplit triangle whose corners differ from source ", s);
                continue;
            }
            ++split;
            extra += pieces[s].size() - 1;
            double sum = 0;
            for (uint32_t i : pieces[s]) sum += area3(tree.triangles[i].tri.position_local);
            const double whole = area3(src.position_local);
            if (std::abs(sum - whole) > 1e-9 * whole)
                v.add("source ", s, ": ", pieces[s].size(), " pieces of total area ", sum, " for ", whole);
            // Every piece corner lies on the source and carries the source's uv there.
            const Vec3d e1 = sub(src.position_local[1], src.position_local[0]),
                        e2 = sub(src.position_local[2], src.position_local[0]);
            const double g11 = dot3(e1, e1), g12 = dot3(e1, e2), g22 = dot3(e2, e2), g = g11 * g22 - g12 * g12;
            if (!(g > 0)) continue;
            for (uint32_t i : pieces[s])
                for (int c = 0; c < 3; ++c) {
                    const Vec3d d = sub(tree.triangles[i].tri.position_local[c], src.position_local[0]);
                    const double r1 = dot3(d, e1), r2 = dot3(d, e2);
                    const double u = (g22 * r1 - g12 * r2) / g, w = (g11 * r2 - g12 * r1) / g;
                    const Vec3d back = added(added(src.position_local[0], scaled(e1, u)), scaled(e2, w));
                    const Vec2d uv{src.uv[0].x + u * (src.uv[1].x - src.uv[0].x) + w * (src.uv[2].x - src.uv[0].x),
                                   src.uv[0].y + u * (src.uv[1].y - src.uv[0].y) + w * (src.uv[2].y - src.uv[0].y)};
                    const Vec2d got = tree.triangles[i].tri.uv[c];
                    const double scale = std::sqrt(std::max(g11, g22));
                    if (u < -1e-9 || w < -1e-9 || u + w > 1 + 1e-9 ||
                        norm(sub(back, tree.triangles[i].tri.position_local[c])) > 1e-9 * scale)
                        v.add("piece ", i, " corner ", c, " is not on its source triangle ", s);
                    if (std::abs(uv.x - got.x) > 1e-9 * (1 + std::abs(uv.x)) ||
                        std::abs(uv.y - got.y) > 1e-9 * (1 + std::abs(uv.y)))
                        v.add("piece ", i, " corner ", c, ": uv ", got.x, ",", got.y, ", the source maps it to ", uv.x,
                              ",", uv.y);
                }
        }
        if (split != tree.stats.triangles_split || extra != tree.stats.triangles_added_by_split)
            v.add("stats say ", tree.stats.triangles_split, " split / ", tree.stats.triangles_added_by_split,
                  " added; the tree has ", split, " / ", extra);
    }

    // Each texel edge of every atlas a triangle appears in, mapped to the
    // world through the triangle, is at most N.min_distance / (pixels per
    // metre at 1 m) long: at least one pixel per texel from min_distance on.
    // Each texel edge of every atlas a triangle appears in, mapped to the
    // world through the triangle, is at most N.min_distance / (pixels per
    // metre at 1 m) long: at least one pixel per texel from min_distance on.
    // The resolution cap's exception: an edge that spans exactly one texel of
    // the texture (the atlas holds it at its own resolution). No edge may span
    // less than one (the atlas above the texture's resolution).
    void guarantee() {
        const double ppm = tree.projection.pixelsPerMetreAt1m();
        const double a = tree.params.atlas_size_px;
        for (size_t i = 0; i < tree.triangles.size(); ++i) {
            const TreeTriangle& t = tree.triangles[i];
            if (t.tri.texture < 0 || leaf_of[i] < 0) continue;
            if (worldDegenerate(t.tri.position_local) || uvDegenerate(t.tri.uv)) continue;
            const Vec3d v1 = sub(t.tri.position_local[1], t.tri.position_local[0]);
            const Vec3d v2 = sub(t.tri.position_local[2], t.tri.position_local[0]);
            const Vec2d t1 = sub2(t.tri.uv[1], t.tri.uv[0]), t2 = sub2(t.tri.uv[2], t.tri.uv[0]);
            const TextureRef tex = scene.textures.ref(static_cast<size_t>(t.tri.texture));
            for (int32_t id = leaf_of[i]; id >= 0; id = tree.nodes[id].parent) {
                const AtlasNode& node = tree.nodes[id];
                const NodeLayer& nl = node.layers[static_cast<int>(t.layer)];
                std::array<Vec2d, 3> p;
                for (int c = 0; c < 3; ++c) {
                    const Vec2d check{t.atlas_uv[c].x * std::ldexp(a, node.level) - static_cast<double>(nl.offset[0]),
                                      t.atlas_uv[c].y * std::ldexp(a, node.level) - static_cast<double>(nl.offset[1])};
                    if (nl.texelFromRoot(t.atlas_uv[c], node.level, tree.params.atlas_size_px) != check)
                        v.add("node ", id, ": texelFromRoot disagrees with root * A * 2^k - offset");
                    if (check.x < -1e-9 * a || check.x > nl.width * (1 + 1e-12) || check.y < -1e-9 * a ||
                        check.y > nl.height * (1 + 1e-12))
                        v.add("triangle ", i, " corner ", c, ": texel ", check.x, ",", check.y, " outside node ", id,
                              "'s ", nl.width, "x", nl.height, " atlas");
                    p[c] = check;
                }
                const Vec2d e1 = sub2(p[1], p[0]), e2 = sub2(p[2], p[0]);
                const double d = det2(e1, e2);
                if (d == 0) {
                    v.add("triangle ", i, ": collapsed in node ", id, "'s atlas");
                    break;
                }
                const double limit = node.min_distance_m / ppm * (1 + 1e-9);
                // Per atlas axis: its world edge and the texture texels it spans.
                const std::array<std::pair<double, double>, 2> k{std::pair{e2.y / d, -e1.y / d}, std::pair{-e2.x / d, e1.x / d}};
                for (int axis = 0; axis < 2; ++axis) {
                    const auto [k1, k2] = k[static_cast<size_t>(axis)];
                    const double world = norm(added(scaled(v1, k1), scaled(v2, k2)));
                    const double su = (k1 * t1.x + k2 * t2.x) * tex.width_px, sv = (k1 * t1.y + k2 * t2.y) * tex.height_px;
                    const double texels = std::sqrt(su * su + sv * sv);
                    if (texels < 1 - 1e-6)
                        v.add("triangle ", i, " in node ", id, ": an atlas texel spans ", texels,
                              " texels of its texture (above its resolution)");
                    if (world > limit && std::abs(texels - 1) > 1e-6)
                        v.add("triangle ", i, " (source ", t.source, ") in node ", id, " (level ", node.level,
                              "): a texel edge spans ", world, " m, more than ", limit, " m");
                }
            }
        }
    }

    testing::AssertionResult run() {
        structure();
        if (v.count() == 0) {
            ranges();
            regions();
            coordinates();
            sources();
            guarantee();
        }
        return v.result();
    }
};

testing::AssertionResult treeIsValid(const Scene& scene, const AtlasTree& tree) {
    Checker c{scene, tree, {}, {}, {}, {}};
    return c.run();
}

// ---------------------------------------------------------------------------
// Scenes and builds.

struct Built {
    AtlasTree tree;
    Diagnostics diagnostics;
    Status status;
    double seconds = 0;
};

std::unique_ptr<Built> build(const Scene& scene, const AtlasParams& params, const std::string& label,
                             const fs::path& out = {}) {
    auto b = std::make_unique<Built>();
    const auto t0 = std::chrono::steady_clock::now();
    b->status = buildAtlasTree(scene, params, out, b->diagnostics, {}, &b->tree);
    b->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const AtlasStats& s = b->tree.stats;
    std::cout << "[" << label << "] " << scene.triangles.size() << " triangles: d_min requested " << s.d_min_requested_m
              << " m, used " << s.d_min_used_m << " m; critical " << s.critical_triangles << ", after enlarging "
              << s.critical_after_enlarge << ", split " << s.triangles_split << " (+" << s.triangles_added_by_split
              << "); nodes " << s.nodes << ", leaves " << s.leaves << ", depth " << s.depth << ", atlases " << s.atlases
              << "; " << b->seconds << " s\n";
    return b;
}

Scene townScene(uint32_t buildings, uint64_t seed, int texture_size_px = synth::TownSettings{}.texture_size_px) {
    synth::TownSettings settings;
    settings.buildings = buildings;
    settings.seed = seed;
    settings.texture_size_px = texture_size_px;
    // render_images = false never opens a texture: the folder need not exist.
    return synth::townToScene(synth::generateTown(settings), "/nonexistent/cityatlas_test_town");
}

const Scene& town100() {
    static const Scene scene = townScene(100, 7);
    return scene;
}

AtlasParams structureOnly() {
    AtlasParams p;
    p.render_images = false;
    return p;
}

int addTexture(Scene& scene, const std::string& path, int size, int channels = 3) {
    TextureRef t;
    t.path = path;
    t.width_px = t.height_px = size;
    t.channels = channels;
    t.wrap = WrapMode::Wrap;
    scene.textures.push_back(t);
    return static_cast<int>(scene.textures.size()) - 1;
}

Triangle triangle(Vec3d a, Vec3d b, Vec3d c, Vec2d ta, Vec2d tb, Vec2d tc, int32_t texture) {
    Triangle t;
    t.position_local = {a, b, c};
    t.uv = {ta, tb, tc};
    t.texture = texture;
    t.semantic = SurfaceSemantic::Wall;
    return t;
}

// A square of side `size` at z = `z` with uv 0..repeats, as two triangles.
void addQuad(Scene& scene, double x0, double y0, double size, double repeats, int32_t texture, double z = 0) {
    const Vec3d p00{x0, y0, z}, p10{x0 + size, y0, z}, p11{x0 + size, y0 + size, z}, p01{x0, y0 + size, z};
    const Vec2d t00{0, 0}, t10{repeats, 0}, t11{repeats, repeats}, t01{0, repeats};
    scene.triangles.push_back(triangle(p00, p10, p11, t00, t10, t11, texture));
    scene.triangles.push_back(triangle(p00, p11, p01, t00, t11, t01, texture));
}

// Textured triangles that are critical (need more than one atlas) at `d_min`,
// counted with this file's own density, for checking the enlargement.
uint64_t criticalAt(const Scene& scene, double d_min, const AtlasTree& tree) {
    const double f = tree.projection.pixelsPerMetreAt1m() / d_min;
    const double room = tree.params.atlas_size_px - 2.0 * tree.params.border_px;
    uint64_t n = 0;
    for (const Triangle& t : scene.triangles) {
        if (t.texture < 0 || uvDegenerate(t.uv)) continue;
        const auto [su, sv] = metresPerUv(t);
        const double du = std::max({t.uv[0].x, t.uv[1].x, t.uv[2].x}) - std::min({t.uv[0].x, t.uv[1].x, t.uv[2].x});
        const double dv = std::max({t.uv[0].y, t.uv[1].y, t.uv[2].y}) - std::min({t.uv[0].y, t.uv[1].y, t.uv[2].y});
        n += std::max(su * f * du, sv * f * dv) > room;
    }
    return n;
}

// The report states the d_min enlargement and the splits as the stats do.
void expectReportSaysWhatHappened(const Built& b, const Scene& scene) {
    const AtlasStats& s = b.tree.stats;
    const auto r = makeAtlasReport(b.tree, scene, b.diagnostics);
    EXPECT_EQ(r["d_min"]["requested_m"], s.d_min_requested_m);
    EXPECT_EQ(r["d_min"]["used_m"], s.d_min_used_m);
    EXPECT_EQ(r["d_min"]["enlarged"], s.d_min_used_m > s.d_min_requested_m);
    EXPECT_EQ(r["critical_triangles"]["at_requested_d_min"], s.critical_triangles);
    EXPECT_EQ(r["critical_triangles"]["at_used_d_min"], s.critical_after_enlarge);
    EXPECT_EQ(r["critical_triangles"]["split"], s.triangles_split);
    EXPECT_EQ(r["critical_triangles"]["triangles_added"], s.triangles_added_by_split);
    EXPECT_EQ(r["tree"]["nodes"], b.tree.nodes.size());
    EXPECT_EQ(r["tree"]["triangles"], b.tree.triangles.size());
    EXPECT_EQ(r["nodes"].size(), b.tree.nodes.size());
}

std::vector<fs::path> filesUnder(const fs::path& dir) {
    std::vector<fs::path> files;
    if (!fs::exists(dir)) return files;
    for (const auto& e : fs::recursive_directory_iterator(dir))
        if (e.is_regular_file()) files.push_back(fs::relative(e.path(), dir));
    std::sort(files.begin(), files.end());
    return files;
}

std::string readBytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Every atlas the tree names is an A x A PNG with the layer's channels, and nothing else was written.
void expectImagesWritten(const AtlasTree& tree, const fs::path& out) {
    const std::vector<fs::path> files = filesUnder(out / "atlas");
    EXPECT_EQ(files.size(), tree.stats.atlases);
    for (const AtlasNode& n : tree.nodes)
        for (int l = 0; l < kLayerCount; ++l) {
            const std::string& rel = n.layers[l].atlas_path;
            if (rel.empty()) continue;
            auto in = OIIO::ImageInput::open((out / rel).string());
            ASSERT_TRUE(in) << rel << " cannot be opened";
            EXPECT_EQ(in->spec().width, n.layers[l].width) << rel;
            EXPECT_EQ(in->spec().height, n.layers[l].height) << rel;
            EXPECT_EQ(in->spec().nchannels, l == 0 ? 3 : 4) << rel;
        }
}

// ---------------------------------------------------------------------------
// The checker itself must fail on broken trees, or the tests below prove nothing.

TEST(AtlasTree, CheckerRejectsCorruptedTrees) {
    const Scene scene = townScene(12, 3);
    AtlasParams p = structureOnly();
    p.atlas_size_px = 256;
    const auto good = build(scene, p, "checker baseline");
    ASSERT_TRUE(good->status.ok()) << good->status.error;
    ASSERT_TRUE(treeIsValid(scene, good->tree));
    ASSERT_GT(good->tree.stats.depth, 1);

    auto expectCaught = [&](const char* what, auto&& corrupt) {
        AtlasTree bad = good->tree;
        corrupt(bad);
        EXPECT_FALSE(treeIsValid(scene, bad)) << "not caught: " << what;
    };
    size_t leaf = 0, textured = 0;
    while (!good->tree.nodes[leaf].leaf() || good->tree.nodes[leaf].layers[0].regions.size() < 2) ++leaf;
    while (good->tree.triangles[textured].tri.texture < 0) ++textured;
    expectCaught("atlas_uv nudged by 1e-9", [&](AtlasTree& t) { t.triangles[textured].atlas_uv[1].x += 1e-9; });
    expectCaught("regions overlapping", [&](AtlasTree& t) {
        auto& r = t.nodes[leaf].layers[0].regions;
        r[1].x = r[0].x, r[1].y = r[0].y;
    });
    expectCaught("region off the grid", [&](AtlasTree& t) { t.nodes[leaf].layers[0].regions[0].w += 2; });
    expectCaught("min_distance halved", [&](AtlasTree& t) { t.nodes[0].min_distance_m *= 0.5; });
    expectCaught("leaf range shortened", [&](AtlasTree& t) { --t.nodes[leaf].layers[0].range.count; });
    expectCaught("offset moved by one texel pair", [&](AtlasTree& t) { t.nodes[1].layers[0].offset[0] += 2; });
    expectCaught("sharp_from of a leaf lowered", [&](AtlasTree& t) { t.nodes[leaf].sharp_from_m *= 0.5; });
    expectCaught("a triangle credited to another source", [&](AtlasTree& t) {
        t.triangles[textured].source =
            (t.triangles[textured].source + 1) % static_cast<uint32_t>(scene.triangles.size());
    });
    expectCaught("texel too coarse", [&](AtlasTree& t) {
        for (AtlasNode& n : t.nodes) n.min_distance_m *= 0.99;
        t.stats.d_min_used_m *= 0.99;
    });
}

// ---------------------------------------------------------------------------
// Normal trees.

TEST(AtlasTree, TownDefaultParams) {
    const auto b = build(town100(), structureOnly(), "town default");
    ASSERT_TRUE(b->status.ok()) << b->status.error;
    EXPECT_GT(b->tree.stats.depth, 0);
    EXPECT_TRUE(treeIsValid(town100(), b->tree));
}

TEST(AtlasTree, TownIgarashiCosgrove) {
    AtlasParams p = structureOnly();
    p.packing = PackingMethod::IgarashiCosgrove;
    const auto b = build(town100(), p, "town igarashi-cosgrove");
    ASSERT_TRUE(b->status.ok()) << b->status.error;
    EXPECT_TRUE(treeIsValid(town100(), b->tree));
}

TEST(AtlasTree, TownAtlas64) {
    AtlasParams p = structureOnly();
    p.atlas_size_px = 64;
    const auto b = build(town100(), p, "town A=64");
    ASSERT_TRUE(b->status.ok()) << b->status.error;
    EXPECT_TRUE(treeIsValid(town100(), b->tree));
}

TEST(AtlasTree, TownAtlas4096) {
    AtlasParams p = structureOnly();
    p.atlas_size_px = 4096;
    const auto b = build(town100(), p, "town A=4096");
    ASSERT_TRUE(b->status.ok()) << b->status.error;
    EXPECT_TRUE(treeIsValid(town100(), b->tree));
}

// ---------------------------------------------------------------------------
// Extremes.

TEST(AtlasExtremes, TinyDminIsEnlargedUntilTheAllowedFractionIsCritical) {
    const Scene scene = townScene(10, 11);
    AtlasParams p = structureOnly();
    p.d_min_m = 0.01;
    const auto b = build(scene, p, "d_min 0.01 m");
    ASSERT_TRUE(b->status.ok()) << b->status.error;
    const AtlasStats& s = b->tree.stats;
    EXPECT_TRUE(treeIsValid(scene, b->tree));
    EXPECT_EQ(s.d_min_requested_m, 0.01);
    EXPECT_GT(s.d_min_used_m, s.d_min_requested_m);
    const auto allowed =
        static_cast<uint64_t>(std::floor(p.critical_fraction * static_cast<double>(s.textured_triangles)));
    EXPECT_EQ(s.critical_triangles, criticalAt(scene, 0.01, b->tree));
    EXPECT_GT(s.critical_triangles, allowed);
    // Enlarged just enough: at most the allowed fraction left critical, more a hair closer.
    EXPECT_EQ(s.critical_after_enlarge, criticalAt(scene, s.d_min_used_m, b->tree));
    EXPECT_LE(s.critical_after_enlarge, allowed);
    EXPECT_GT(criticalAt(scene, s.d_min_used_m * (1 - 1e-6), b->tree), allowed);
    EXPECT_EQ(s.triangles_split, s.critical_after_enlarge);
    EXPECT_GT(s.triangles_split, 0u);
    expectReportSaysWhatHappened(*b, scene);
}

TEST(AtlasExtremes, HugeDminGivesOneRootLeaf) {
    const Scene scene = townScene(10, 11);
    AtlasParams p = structureOnly();
    p.d_min_m = 1e6;
    const auto b = build(scene, p, "d_min 1e6 m");
    ASSERT_TRUE(b->status.ok()) << b->status.error;
    EXPECT_TRUE(treeIsValid(scene, b->tree));
    EXPECT_EQ(b->tree.nodes.size(), 1u);
    EXPECT_TRUE(b->tree.nodes[0].leaf());
    EXPECT_EQ(b->tree.stats.depth, 0);
    EXPECT_EQ(b->tree.stats.d_min_used_m, 1e6);
    EXPECT_EQ(b->tree.stats.critical_triangles, 0u);
    EXPECT_EQ(b->tree.triangles.size(), scene.triangles.size());
    expectReportSaysWhatHappened(*b, scene);
}

// A texture repeated 1000 times over a quad needs the same texels per metre
// as one stretched over it, so it must not take more atlas area; rendered,
// to see the resampler cope with the repeats. The texture (1024 px) has more
// texels than either needs, so the resolution cap plays no part.
TEST(AtlasExtremes, ThousandTextureRepeatsCostNoMoreThanOne) {
    const fs::path dir = test::scratchPath("atlas_tree", "repeats");
    fs::create_directories(dir);
    synth::FacadeStyle style;
    style.building_number = 7;
    std::string error;
    ASSERT_TRUE(synth::writePng((dir / "facade.png").string(), synth::drawFacade(style, 1024, 1024), &error)) << error;

    AtlasParams p;
    p.d_min_m = 100;  // 20 m at about 22 px/m: some 450 texels, inside a 512 atlas
    std::array<uint64_t, 2> texels{};
    for (int k = 0; k < 2; ++k) {
        const double repeats = k == 0 ? 1 : 1000;
        Scene scene;
        const int tex = addTexture(scene, (dir / "facade.png").string(), 1024);
        addQuad(scene, 0, 0, 20, repeats, tex);
        const fs::path out = dir / (k == 0 ? "out1" : "out1000");
        const auto b = build(scene, p, k == 0 ? "repeats 1" : "repeats 1000", out);
        ASSERT_TRUE(b->status.ok()) << b->status.error;
        EXPECT_TRUE(treeIsValid(scene, b->tree));
        EXPECT_EQ(b->tree.stats.triangles_split, 0u);
        EXPECT_EQ(b->tree.stats.d_min_used_m, 100.0);
        EXPECT_EQ(b->tree.stats.textures_unreadable, 0u);
        expectReportSaysWhatHappened(*b, scene);
        texels[k] = b->tree.stats.packed_texels;
        expectImagesWritten(b->tree, out);
    }
    EXPECT_GT(texels[0], 0u);
    EXPECT_LE(texels[1], texels[0]);
    fs::remove_all(dir);
}

TEST(AtlasExtremes, KilometreTriangleIsSplitNotEnlarged) {
    Scene scene;
    const int tex = addTexture(scene, "/nonexistent/ground.png", 16384);  // more texels than d_min asks for: no cap
    scene.triangles.push_back(triangle({0, 0, 0}, {1000, 0, 0}, {0, 1000, 0}, {0, 0}, {1, 0}, {0, 1}, tex));
    scene.triangles.back().semantic = SurfaceSemantic::Ground;
    AtlasParams p = structureOnly();
    p.d_min_m = 300;            // 1000 m at about 7.4 px/m: some 7400 texels against 512
    p.critical_fraction = 1.0;  // the one triangle may stay critical: split, do not enlarge
    const auto b = build(scene, p, "1 km triangle");
    ASSERT_TRUE(b->status.ok()) << b->status.error;
    const AtlasStats& s = b->tree.stats;
    EXPECT_TRUE(treeIsValid(scene, b->tree));
    EXPECT_EQ(s.d_min_used_m, 300.0);
    EXPECT_EQ(s.critical_triangles, 1u);
    EXPECT_EQ(s.triangles_split, 1u);
    EXPECT_GT(s.triangles_added_by_split, 100u);
    EXPECT_EQ(b->diagnostics.count("atlas_resolution_lowered"), 0u);
    expectReportSaysWhatHappened(*b, scene);
}

// One textured triangle with 1 km legs, its texture `texture_px` square over it.
Scene kilometreTriangle(int texture_px) {
    Scene scene;
    const int tex = addTexture(scene, "/nonexistent/ground.png", texture_px);
    scene.triangles.push_back(triangle({0, 0, 0}, {1000, 0, 0}, {0, 1000, 0}, {0, 0}, {1, 0}, {0, 1}, tex));
    return scene;
}

// d_min 1 m, and the one triangle may stay critical (split, never enlarged for the fraction).
AtlasParams oneMetreOneCritical() {
    AtlasParams p = structureOnly();
    p.d_min_m = 1;
    p.critical_fraction = 1.0;
    return p;
}

// The same triangle at d_min 1 m would need some 2.2 million texels along an
// edge: about 10^8 pieces, and its 65536 px texture still some 17,000 at its
// own resolution. Splitting is bounded (at most 10,000 pieces for a small
// scene); beyond that d_min is raised, and the report says why.
TEST(AtlasExtremes, KilometreTriangleAtOneMetreRaisesDminToBoundSplitting) {
    const Scene scene = kilometreTriangle(65536);
    const auto b = build(scene, oneMetreOneCritical(), "1 km triangle at 1 m");
    ASSERT_TRUE(b->status.ok()) << b->status.error;
    const AtlasStats& s = b->tree.stats;
    EXPECT_TRUE(s.enlarged_for_split_budget);
    EXPECT_GT(s.d_min_used_m, 1.0);
    EXPECT_EQ(s.triangles_split, 1u);
    EXPECT_LE(s.triangles_added_by_split, 10000u);
    EXPECT_GT(s.triangles_added_by_split, 1000u);  // raised only as far as the budget needs
    EXPECT_TRUE(treeIsValid(scene, b->tree));
}

// With a 1024 px texture the same triangle at 1 m asks for far more than the
// texture has: its pieces hold the texture's own texels (capped), a bounded
// number whatever d_min, so d_min stays where it was asked.
TEST(AtlasExtremes, KilometreTriangleWithAModestTextureIsCappedNotEnlarged) {
    const Scene scene = kilometreTriangle(1024);
    const auto b = build(scene, oneMetreOneCritical(), "1 km triangle at 1 m, 1024 px");
    ASSERT_TRUE(b->status.ok()) << b->status.error;
    const AtlasStats& s = b->tree.stats;
    EXPECT_FALSE(s.enlarged_for_split_budget);
    EXPECT_EQ(s.d_min_used_m, 1.0);
    EXPECT_EQ(s.triangles_split, 1u);
    // 1024 x 1024 texels at full resolution, 496 x 496 of content per 512 atlas at most: at least 5 pieces.
    EXPECT_GE(s.triangles_added_by_split, 4u);
    EXPECT_LE(s.triangles_added_by_split, 64u);
    for (const AtlasNode& n : b->tree.nodes)
        for (const PackedRegion& r : n.layers[0].regions) EXPECT_TRUE(r.native_u && r.native_v) << "a region not capped";
    EXPECT_TRUE(treeIsValid(scene, b->tree));
}

// One texture mapped 0..1 on 30,000 separate walls (a generic facade, as real
// data often has): every uv box overlaps every other, so they are one chart,
// found in a sweep that stays linear (quadratic, this test took 9 s instead of
// 0.2 s; at a city's 10^6 walls it would take hours).
TEST(AtlasExtremes, ThirtyThousandWallsShareOneTextureMapping) {
    Scene scene;
    const int tex = addTexture(scene, "/nonexistent/facade.png", 256);
    for (int i = 0; i < 15000; ++i) addQuad(scene, 12.0 * (i % 120), 12.0 * (i / 120), 10, 1, tex);
    AtlasParams p = structureOnly();
    p.d_min_m = 200;
    const auto b = build(scene, p, "30,000 walls, one texture mapping");
    ASSERT_TRUE(b->status.ok()) << b->status.error;
    EXPECT_TRUE(treeIsValid(scene, b->tree));
    std::vector<ChartMember> members;
    for (const Triangle& t : scene.triangles) {
        const TexelDensity d = texelDensity(t);
        members.push_back({d.uv_min, d.uv_max, 0, 0});
    }
    const std::vector<uint32_t> charts = uvCharts(members);
    EXPECT_TRUE(std::all_of(charts.begin(), charts.end(), [](uint32_t c) { return c == 0; }));
}

// 5000 triangles of 1 cm, each with its own cell of one texture, so none share a region.
TEST(AtlasExtremes, FiveThousandCentimetreTriangles) {
    Scene scene;
    const int tex = addTexture(scene, "/nonexistent/cells.png", 2048);
    const int per_row = 71;
    const double cell = 1.0 / per_row;
    for (int i = 0; i < 5000; ++i) {
        const double x = (i % per_row) * 0.1, y = (i / per_row) * 0.1;
        const Vec2d t0{(i % per_row) * cell, (i / per_row) * cell};
        scene.triangles.push_back(
            triangle({x, y, 0}, {x + 0.01, y, 0}, {x, y + 0.01, 0}, t0, {t0.x + cell, t0.y}, {t0.x, t0.y + cell}, tex));
    }
    const auto b = build(scene, structureOnly(), "5000 x 1 cm");
    ASSERT_TRUE(b->status.ok()) << b->status.error;
    EXPECT_TRUE(treeIsValid(scene, b->tree));
    EXPECT_EQ(b->tree.stats.triangles_split, 0u);
    EXPECT_GT(b->tree.stats.leaves, 1u);
    expectReportSaysWhatHappened(*b, scene);
}

TEST(AtlasExtremes, DegenerateUvMixedWithRegular) {
    Scene scene;
    const int tex = addTexture(scene, "/nonexistent/wall.png", 512);
    for (int i = 0; i < 8; ++i) addQuad(scene, 12.0 * i, 0, 10, 1, tex);
    uint64_t degenerate = 0;
    for (int i = 0; i < 6; ++i) {
        const double x = 5.0 * i, y = 20;
        const Vec3d a{x, y, 0}, b{x + 4, y, 0}, c{x, y + 4, 0};
        if (i % 3 == 0) {  // one colour: all uv equal
            scene.triangles.push_back(triangle(a, b, c, {0.3, 0.7}, {0.3, 0.7}, {0.3, 0.7}, tex));
        } else if (i % 3 == 1) {  // a diagonal line of the texture
            scene.triangles.push_back(triangle(a, b, c, {0.1, 0.1}, {0.9, 0.9}, {0.5, 0.5}, tex));
        } else {  // a horizontal line: zero uv extent in v
            scene.triangles.push_back(triangle(a, b, c, {0.0, 0.25}, {1.0, 0.25}, {0.5, 0.25}, tex));
        }
        ++degenerate;
    }
    const auto b = build(scene, structureOnly(), "degenerate uv");
    ASSERT_TRUE(b->status.ok()) << b->status.error;
    EXPECT_TRUE(treeIsValid(scene, b->tree));
    EXPECT_EQ(b->tree.stats.degenerate_uv_triangles, degenerate);
    EXPECT_EQ(b->tree.stats.textured_triangles, scene.triangles.size());
    EXPECT_EQ(makeAtlasReport(b->tree, scene, b->diagnostics)["scene"]["degenerate_uv_triangles"], degenerate);
    expectReportSaysWhatHappened(*b, scene);
}

TEST(AtlasExtremes, ZeroAreaTrianglesWithValidUv) {
    Scene scene;
    const int tex = addTexture(scene, "/nonexistent/wall.png", 512);
    for (int i = 0; i < 4; ++i) addQuad(scene, 12.0 * i, 0, 10, 1, tex);
    // A point and a line in space, each with a whole texture.
    scene.triangles.push_back(triangle({3, 3, 3}, {3, 3, 3}, {3, 3, 3}, {0, 0}, {1, 0}, {0, 1}, tex));
    scene.triangles.push_back(triangle({0, 5, 0}, {10, 5, 0}, {5, 5, 0}, {0, 0}, {1, 0}, {0, 1}, tex));
    const auto b = build(scene, structureOnly(), "zero-area positions");
    ASSERT_TRUE(b->status.ok()) << b->status.error;
    EXPECT_TRUE(treeIsValid(scene, b->tree));
    EXPECT_EQ(b->tree.triangles.size(), scene.triangles.size());
    expectReportSaysWhatHappened(*b, scene);
}

TEST(AtlasExtremes, UntexturedOnlyMakesNoAtlases) {
    Scene scene;
    const int32_t grey = scene.internMaterial(Material{});
    Material glass;
    glass.transparency = 0.5f;
    const int32_t see_through = scene.internMaterial(glass);
    for (int i = 0; i < 10; ++i) {
        addQuad(scene, 12.0 * i, 0, 10, 1, -1);
        scene.triangles[scene.triangles.size() - 2].material = grey;
        scene.triangles.back().material = i % 2 ? see_through : grey;
    }
    for (Triangle& t : scene.triangles) t.uv = {};
    const fs::path out = test::scratchPath("atlas_tree", "untextured");
    AtlasParams p;  // images on: nothing may be written
    const auto b = build(scene, p, "untextured", out);
    ASSERT_TRUE(b->status.ok()) << b->status.error;
    EXPECT_TRUE(treeIsValid(scene, b->tree));
    EXPECT_EQ(b->tree.stats.atlases, 0u);
    EXPECT_EQ(b->tree.stats.textured_triangles, 0u);
    EXPECT_EQ(b->tree.nodes.size(), 1u);
    EXPECT_EQ(b->tree.nodes[0].layers[1].range.count, 5u);
    EXPECT_TRUE(filesUnder(out / "atlas").empty());
    expectReportSaysWhatHappened(*b, scene);
    fs::remove_all(out);
}

// A chain of slivers whose areas halve from one to the next: area-weighted
// cuts isolate about one triangle per level. Past level 16 the cuts balance
// counts instead, so the depth stays far below the 31 levels that 32-bit
// node offsets allow, and every invariant holds (found while writing these
// tests: the depth used to reach 35 and the offsets wrapped silently).
TEST(AtlasExtremes, SliverChainStaysShallow) {
    Scene scene;
    for (int i = 0; i < 70; ++i) {
        // 100 m along both texture axes (about 300 texels each at d_min 744 m), area 50 * 2^-i m^2.
        const int tex = addTexture(scene, "/nonexistent/sliver.png", 512);
        scene.triangles.push_back(
            triangle({0, 0, 0}, {100, 0, 0}, {100, std::ldexp(1.0, -i), 0}, {0, 0}, {1, 0}, {0, 1}, tex));
    }
    AtlasParams p = structureOnly();
    p.d_min_m = 744;
    const auto b = build(scene, p, "sliver chain");
    ASSERT_TRUE(b->status.ok()) << b->status.error;
    EXPECT_LE(b->tree.stats.depth, 16 + 4);  // 16 area-balanced levels, then log4(70) < 4 count-balanced ones
    EXPECT_EQ(b->tree.stats.leaves_below_resolution, 0u);
    EXPECT_TRUE(treeIsValid(scene, b->tree));
}

// ---------------------------------------------------------------------------
// Determinism.

void expectSameTree(const AtlasTree& a, const AtlasTree& b) {
    ASSERT_EQ(a.nodes.size(), b.nodes.size());
    for (size_t i = 0; i < a.nodes.size(); ++i) {
        const AtlasNode &x = a.nodes[i], &y = b.nodes[i];
        EXPECT_EQ(x.parent, y.parent) << i;
        EXPECT_EQ(x.children, y.children) << i;
        EXPECT_EQ(x.level, y.level) << i;
        EXPECT_EQ(x.sharp_from_m, y.sharp_from_m) << i;
        EXPECT_EQ(x.bounds.min, y.bounds.min) << i;
        EXPECT_EQ(x.bounds.max, y.bounds.max) << i;
        EXPECT_EQ(x.min_distance_m, y.min_distance_m) << i;
        for (int l = 0; l < kLayerCount; ++l) {
            const NodeLayer &p = x.layers[l], &q = y.layers[l];
            EXPECT_EQ(p.range.first, q.range.first) << i;
            EXPECT_EQ(p.range.count, q.range.count) << i;
            EXPECT_EQ(p.atlas_path, q.atlas_path) << i;
            EXPECT_EQ(p.offset, q.offset) << i;
            EXPECT_EQ(p.width, q.width) << i;
            EXPECT_EQ(p.height, q.height) << i;
            EXPECT_EQ(p.packed_texels, q.packed_texels) << i;
            ASSERT_EQ(p.regions.size(), q.regions.size()) << i;
            for (size_t k = 0; k < p.regions.size(); ++k) {
                const PackedRegion &r = p.regions[k], &s = q.regions[k];
                EXPECT_TRUE(r.texture == s.texture && r.x == s.x && r.y == s.y && r.w == s.w && r.h == s.h &&
                            r.rotated == s.rotated && r.uv_min == s.uv_min && r.uv_max == s.uv_max)
                    << "node " << i << " region " << k;
            }
        }
    }
    ASSERT_EQ(a.triangles.size(), b.triangles.size());
    for (size_t i = 0; i < a.triangles.size(); ++i) {
        const TreeTriangle &x = a.triangles[i], &y = b.triangles[i];
        EXPECT_TRUE(x.source == y.source && x.layer == y.layer &&
                    std::memcmp(&x.atlas_uv, &y.atlas_uv, sizeof x.atlas_uv) == 0 &&
                    x.tri.position_local == y.tri.position_local && x.tri.uv == y.tri.uv)
            << "triangle " << i;
    }
}

// A synthetic town written to dir/town (its textures on disk), as a Scene.
void writtenTownScene(const fs::path& dir, uint32_t buildings, uint64_t seed, int texture_px, Scene* scene) {
    synth::TownSettings settings;
    settings.buildings = buildings;
    settings.seed = seed;
    settings.texture_size_px = texture_px;
    const synth::Town town = synth::generateTown(settings);
    const Status written = synth::writeTown(town, dir / "town", false, {});
    ASSERT_TRUE(written.ok()) << written.error;
    *scene = synth::townToScene(town, dir / "town");
}

TEST(AtlasDeterminism, OneAndFourThreadsGiveIdenticalTreesAndImages) {
    const fs::path dir = test::scratchPath("atlas_tree", "determinism");
    Scene scene;
    ASSERT_NO_FATAL_FAILURE(writtenTownScene(dir, 60, 5, 128, &scene));

    std::array<std::unique_ptr<Built>, 2> builds;
    for (int k = 0; k < 2; ++k) {
        AtlasParams p;
        p.threads = k == 0 ? 1 : 4;
        builds[k] = build(scene, p, k == 0 ? "town 1 thread" : "town 4 threads", dir / (k == 0 ? "t1" : "t4"));
        ASSERT_TRUE(builds[k]->status.ok()) << builds[k]->status.error;
        EXPECT_EQ(builds[k]->tree.stats.textures_unreadable, 0u);
    }
    EXPECT_TRUE(treeIsValid(scene, builds[0]->tree));
    expectSameTree(builds[0]->tree, builds[1]->tree);
    const AtlasStats &s1 = builds[0]->tree.stats, &s4 = builds[1]->tree.stats;
    EXPECT_EQ(s1.d_min_used_m, s4.d_min_used_m);
    EXPECT_EQ(s1.triangles_split, s4.triangles_split);
    EXPECT_EQ(s1.packed_texels, s4.packed_texels);
    EXPECT_EQ(s1.atlases, s4.atlases);
    EXPECT_EQ(s1.original_texture_bytes, s4.original_texture_bytes);
    expectImagesWritten(builds[0]->tree, dir / "t1");
    const std::vector<fs::path> files = filesUnder(dir / "t1"), other = filesUnder(dir / "t4");
    ASSERT_EQ(files, other);
    EXPECT_EQ(files.size(), builds[0]->tree.stats.atlases);
    for (const fs::path& f : files) EXPECT_TRUE(readBytes(dir / "t1" / f) == readBytes(dir / "t4" / f)) << f;
    fs::remove_all(dir);
}

// `build` gives the scene's triangles to the atlas stage instead of copying
// them (memory at city scale): the tree and its images are the same, the
// vector is empty afterwards, and a vector that is not the scene's own is
// copied, not taken.
TEST(AtlasDeterminism, ConsumingTheScenesTrianglesGivesTheSameTree) {
    const fs::path dir = test::scratchPath("atlas_tree", "consume");
    Scene scene;
    ASSERT_NO_FATAL_FAILURE(writtenTownScene(dir, 30, 9, 64, &scene));
    const auto copied = build(scene, {}, "copied", dir / "copied");
    ASSERT_TRUE(copied->status.ok()) << copied->status.error;

    Scene own = scene;
    Built consumed;
    consumed.status = buildAtlasTree(own, {}, dir / "consumed", consumed.diagnostics, {}, &consumed.tree, {}, &own.triangles);
    ASSERT_TRUE(consumed.status.ok()) << consumed.status.error;
    EXPECT_TRUE(own.triangles.empty());
    expectSameTree(copied->tree, consumed.tree);
    EXPECT_EQ(copied->tree.triangles.size(), consumed.tree.triangles.size());
    for (size_t i = 0; i < copied->tree.triangles.size(); ++i) {
        const TreeTriangle &a = copied->tree.triangles[i], &b = consumed.tree.triangles[i];
        ASSERT_EQ(a.source, b.source) << i;
        ASSERT_EQ(a.tri.position_local, b.tri.position_local) << i;
        ASSERT_EQ(a.tri.uv, b.tri.uv) << i;
        ASSERT_EQ(a.atlas_uv, b.atlas_uv) << i;
    }
    const std::vector<fs::path> files = filesUnder(dir / "copied");
    ASSERT_EQ(files, filesUnder(dir / "consumed"));
    for (const fs::path& f : files) EXPECT_TRUE(readBytes(dir / "copied" / f) == readBytes(dir / "consumed" / f)) << f;

    std::vector<Triangle> other = scene.triangles;  // not the scene's own vector: copied, left alone
    AtlasParams structure_only;
    structure_only.render_images = false;
    Built b3;
    b3.status = buildAtlasTree(scene, structure_only, {}, b3.diagnostics, {}, &b3.tree, {}, &other);
    ASSERT_TRUE(b3.status.ok()) << b3.status.error;
    EXPECT_EQ(other.size(), scene.triangles.size());
    fs::remove_all(dir);
}

// ---------------------------------------------------------------------------
// Sharded builds (atlas/shard_plan.h): the plan's cuts and a shard's subtree.

TEST(AtlasShards, PlanPutsEveryFeatureInOneShardOfBoundedSize) {
    const Scene& scene = town100();
    const uint64_t max = scene.triangles.size() / 5;
    const ShardPlan plan = planShards(scene, max);
    ASSERT_GE(plan.shards(), 4u);
    std::vector<uint64_t> count(plan.shards(), 0);
    for (const Triangle& t : scene.triangles) {
        const int32_t k = plan.shard_of_feature[t.feature];
        ASSERT_GE(k, 0) << "feature " << t.feature << " has triangles but no shard";
        ++count[static_cast<size_t>(k)];
    }
    for (size_t k = 0; k < plan.shards(); ++k) {
        EXPECT_EQ(count[k], plan.shard_triangles[k]) << "shard " << k;
        EXPECT_LE(count[k], max) << "shard " << k;
        EXPECT_GT(count[k], 0u) << "shard " << k;
    }
    // The top: preorder, each shard a leaf of it exactly once, children one level down.
    std::vector<int> seen(plan.shards(), 0);
    for (size_t i = 0; i < plan.nodes.size(); ++i) {
        const PlanNode& n = plan.nodes[i];
        if (n.shard >= 0) ++seen[static_cast<size_t>(n.shard)];
        for (int32_t c : n.children) {
            if (c < 0) continue;
            EXPECT_GT(c, static_cast<int32_t>(i));
            EXPECT_EQ(plan.nodes[static_cast<size_t>(c)].parent, static_cast<int32_t>(i));
            EXPECT_EQ(plan.nodes[static_cast<size_t>(c)].level, n.level + 1);
        }
        if (n.shard >= 0) {
            EXPECT_EQ(n.children, (std::array<int32_t, 4>{-1, -1, -1, -1}));
        }
    }
    for (size_t k = 0; k < plan.shards(); ++k) EXPECT_EQ(seen[k], 1) << "shard " << k;
    // A limit above the scene: one shard, no top.
    const ShardPlan one = planShards(scene, scene.triangles.size());
    EXPECT_EQ(one.shards(), 1u);
    EXPECT_EQ(one.nodes.size(), 1u);
}

TEST(AtlasShards, ShardSubtreeWithTheTownsDecisionsPassesTheChecker) {
    const Scene& scene = town100();
    const AtlasParams params = structureOnly();
    GlobalDecisions globals;
    ASSERT_TRUE(decideGlobals(scene, params, &globals).ok());
    // The whole town's own build decides the same (the same passes, streamed or not).
    const auto whole = build(scene, params, "whole town");
    ASSERT_TRUE(whole->status.ok()) << whole->status.error;
    EXPECT_EQ(whole->tree.stats.d_min_used_m, globals.d_min_used_m);
    EXPECT_EQ(whole->tree.stats.d_min_requested_m, globals.d_min_requested_m);
    const ShardPlan plan = planShards(scene, scene.triangles.size() / 5);
    for (const PlanNode& n : plan.nodes) {
        if (n.shard < 0) continue;
        Scene part;
        part.textures = scene.textures;
        part.materials = scene.materials;
        part.features = scene.features;
        for (const Triangle& t : scene.triangles)
            if (plan.shard_of_feature[t.feature] == n.shard) part.triangles.push_back(t);
        AtlasParams p = params;
        p.base_level = n.level;
        auto b = std::make_unique<Built>();
        b->status = buildAtlasTree(part, p, {}, b->diagnostics, {}, &b->tree, {}, nullptr, &globals);
        ASSERT_TRUE(b->status.ok()) << b->status.error;
        EXPECT_EQ(b->tree.stats.d_min_used_m, globals.d_min_used_m) << "shard " << n.shard;
        EXPECT_TRUE(treeIsValid(part, b->tree)) << "shard " << n.shard;
    }
}

}  // namespace
}  // namespace cityatlas::atlas

namespace cityatlas::atlas {
namespace {

// A city whose texture models exceed their budget is planned a range of
// textures at a time (atlas_tree.h decideGlobals): every decision must be
// the one the models held whole give, to the bit, and the passes over the
// input must be the ones the budget calls for.
void expectSameDecisions(const GlobalDecisions& a, const GlobalDecisions& b) {
    EXPECT_EQ(a.scene_diagonal_m, b.scene_diagonal_m);
    EXPECT_EQ(a.d_min_requested_m, b.d_min_requested_m);
    EXPECT_EQ(a.d_min_used_m, b.d_min_used_m);
    EXPECT_EQ(a.d_full_m, b.d_full_m);
    EXPECT_EQ(a.d_first_upsampled_m, b.d_first_upsampled_m);
    EXPECT_EQ(a.textured_triangles, b.textured_triangles);
    EXPECT_EQ(a.degenerate_uv_triangles, b.degenerate_uv_triangles);
    EXPECT_EQ(a.critical_triangles, b.critical_triangles);
    EXPECT_EQ(a.enlarged_for_split_budget, b.enlarged_for_split_budget);
    EXPECT_EQ(a.promote, b.promote);
    EXPECT_EQ(a.d_min_choice.rule, b.d_min_choice.rule);
    EXPECT_EQ(a.d_min_choice.reason, b.d_min_choice.reason);
    EXPECT_EQ(a.d_min_choice.estimated_ratio, b.d_min_choice.estimated_ratio);
    EXPECT_EQ(a.d_min_choice.originals_within_m_mb, b.d_min_choice.originals_within_m_mb);
    ASSERT_EQ(a.d_min_choice.candidates.size(), b.d_min_choice.candidates.size());
    for (size_t k = 0; k < a.d_min_choice.candidates.size(); ++k) {
        EXPECT_EQ(a.d_min_choice.candidates[k].d_m, b.d_min_choice.candidates[k].d_m) << k;
        EXPECT_EQ(a.d_min_choice.candidates[k].ratio, b.d_min_choice.candidates[k].ratio) << k;
        EXPECT_EQ(a.d_min_choice.candidates[k].originals_within_mb, b.d_min_choice.candidates[k].originals_within_mb) << k;
    }
}

struct Passes {
    int count = 0;
    TrianglePass over(const Scene& scene) {
        return [this, &scene](const std::function<void(const Triangle&)>& fn, const char*) {
            ++count;
            for (const Triangle& t : scene.triangles) fn(t);
            return Status::Ok();
        };
    }
};

TEST(GlobalDecisions, TextureModelsARangeAtATimeDecideAsTheWholeModels) {
    Scene scene = townScene(100, 7, 32);
    // Ten 1 m signs with 64 px textures mapped once: at the distance where a
    // metre needs 60 texels, each is cheaper held at its full 64 x 64 (promoted).
    const double ppm = projectionBound(structureOnly()).pixelsPerMetreAt1m();
    for (int k = 0; k < 10; ++k) {
        const int32_t tex = addTexture(scene, fmt::format("/nonexistent/sign{}.png", k), 64);
        const Vec3d o{10.0 * k, -5.0, 1.0};
        const Vec3d a = o, b = o + Vec3d{1, 0, 0}, c = o + Vec3d{1, 0, 1}, d = o + Vec3d{0, 0, 1};
        scene.triangles.push_back({{a, b, c}, {Vec2d{0, 0}, Vec2d{1, 0}, Vec2d{1, 1}}, tex, -1, 0, SurfaceSemantic::Wall});
        scene.triangles.push_back({{a, c, d}, {Vec2d{0, 0}, Vec2d{1, 1}, Vec2d{0, 1}}, tex, -1, 0, SurfaceSemantic::Wall});
    }
    std::set<int32_t> used;
    for (const Triangle& t : scene.triangles)
        if (t.texture >= 0) used.insert(t.texture);
    ASSERT_GT(used.size(), 50u);
    const std::array<std::optional<double>, 2> cases{std::nullopt, ppm / 60.0};
    for (const std::optional<double>& d_min : cases) {
        AtlasParams whole = structureOnly();
        whole.d_min_m = d_min;
        AtlasParams ranged = whole;
        ranged.model_budget_bytes = 1;  // every texture a range of its own
        Passes pw, pr;
        GlobalDecisions a, b;
        ASSERT_TRUE(decideGlobals(scene.textures, whole, pw.over(scene), &a).ok());
        ASSERT_TRUE(decideGlobals(scene.textures, ranged, pr.over(scene), &b).ok());
        SCOPED_TRACE(d_min ? "d_min given" : "d_min from the data");
        expectSameDecisions(a, b);
        EXPECT_EQ(pw.count, 2) << "models that fit: the models' pass and the critical triangles' pass";
        const int ranges = static_cast<int>(scene.textures.size());
        const int rounds = d_min ? 0 : static_cast<int>((a.d_min_choice.candidates.size() + 7) / 8);
        // The first pass, the critical pass, a pass per range for the
        // promotions and, from the data, per range and round of candidates.
        EXPECT_EQ(pr.count, 2 + ranges + rounds * ranges);
        // The decisions compared are not trivial ones.
        if (d_min) {
            EXPECT_EQ(std::count(a.promote.end() - 10, a.promote.end(), 1), 10) << "every sign is promoted";
        } else {
            EXPECT_GT(a.d_min_choice.candidates.size(), 8u);
        }
        // The in-memory entry point decides the same.
        GlobalDecisions c;
        ASSERT_TRUE(decideGlobals(scene, ranged, &c).ok());
        expectSameDecisions(a, c);
    }
}

// d_full and the first upsampled distance (papers/000 §6.1.2): per texture,
// the distance at which its most demanding triangle needs the texture's
// full resolution on its more demanding axis; over the city, the nearest and
// the farthest. Computed here the way the papers put it (the largest s and t
// per texture, then the axes), against the plan's single pass.
TEST(GlobalDecisions, DFullIsTheNearestNativeDistanceOfTheCitysTextures) {
    Scene scene = townScene(60, 11, 32);
    // Small signs, denser than the town's textures, whose coarser axis (the
    // one that sets a texture's distance) is the height on even ones (512 x
    // 128 px on w x 5 cm) and the width on odd ones (128 x 512 px on w x 10
    // cm): the nearest is an even one's height, and leaving either axis out
    // moves it.
    for (int k = 0; k < 6; ++k) {
        const bool even = k % 2 == 0;
        const int32_t tex = addTexture(scene, fmt::format("/nonexistent/sign{}.png", k), 32);
        scene.textures.set(static_cast<size_t>(tex), {scene.textures.path(static_cast<size_t>(tex)), even ? 512 : 128,
                                                      even ? 128 : 512, 3, WrapMode::Wrap});
        const double w = 0.075 + 0.025 * k, h = even ? 0.05 : 0.1;
        const Vec3d o{10.0 * k, -5.0, 1.0};
        const Vec3d a = o, b = o + Vec3d{w, 0, 0}, c = o + Vec3d{w, 0, h}, d = o + Vec3d{0, 0, h};
        scene.triangles.push_back({{a, b, c}, {Vec2d{0, 0}, Vec2d{1, 0}, Vec2d{1, 1}}, tex, -1, 0, SurfaceSemantic::Wall});
        scene.triangles.push_back({{a, c, d}, {Vec2d{0, 0}, Vec2d{1, 1}, Vec2d{0, 1}}, tex, -1, 0, SurfaceSemantic::Wall});
    }
    const AtlasParams params = structureOnly();
    const double ppm = projectionBound(params).pixelsPerMetreAt1m();
    std::vector<double> s_max(scene.textures.size(), 0), t_max(scene.textures.size(), 0);
    for (const Triangle& t : scene.triangles) {
        if (t.texture < 0) continue;
        const TexelDensity d = texelDensity(t);
        s_max[static_cast<size_t>(t.texture)] = std::max(s_max[static_cast<size_t>(t.texture)], d.s_world);
        t_max[static_cast<size_t>(t.texture)] = std::max(t_max[static_cast<size_t>(t.texture)], d.t_world);
    }
    double nearest = 1e300, farthest = 0;
    bool nearest_by_height = false;
    for (size_t i = 0; i < scene.textures.size(); ++i) {
        const TextureInfo& r = scene.textures[i];
        const double by_width = r.width_px > 0 ? s_max[i] * ppm / r.width_px : 0;
        const double by_height = r.height_px > 0 ? t_max[i] * ppm / r.height_px : 0;
        const double distance = std::max(by_width, by_height);
        if (distance > 0 && distance < nearest) nearest_by_height = by_height > by_width;
        if (distance > 0) nearest = std::min(nearest, distance), farthest = std::max(farthest, distance);
    }
    ASSERT_TRUE(nearest_by_height) << "the case the test is for";
    GlobalDecisions g;
    ASSERT_TRUE(decideGlobals(scene, params, &g).ok());
    EXPECT_EQ(g.d_full_m, nearest);
    EXPECT_EQ(g.d_first_upsampled_m, farthest);
    EXPECT_LT(nearest, farthest / 10);
}

}  // namespace
}  // namespace cityatlas::atlas
