// SPDX-License-Identifier: GPL-3.0-or-later
// buildAtlasTree: critical triangles, recursive node splitting until every
// node's regions pack (papers/000 §4.5.1), then numbering, triangle order,
// root-atlas coordinates and the images.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <set>

#include <fmt/format.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include "atlas/atlas_images.h"
#include "atlas/atlas_tree.h"
#include "atlas/charts.h"
#include "atlas/default_dmin.h"
#include "atlas/placement.h"
#include "atlas/subdivide.h"
#include "atlas/texel_budget.h"
#include "atlas/texel_estimate.h"
#include "atlas/texture_economy.h"
#include "core/resource_usage.h"

namespace cityatlas::atlas {

namespace fs = std::filesystem;

namespace {

Layer layerOf(const Triangle& t, const Scene& scene) {
    if (t.texture >= 0) return scene.textures[t.texture].channels == 4 ? Layer::Alpha : Layer::Opaque;
    if (t.material >= 0 && scene.materials[t.material].transparency > 0) return Layer::Alpha;
    return Layer::Opaque;
}

// What the packer needs per triangle, computed once.
struct TriangleInfo {
    TexelDensity density;
    Layer layer = Layer::Opaque;
    Vec3d uv_centre;          // (u, v, 0): where it lies in its texture
    double texel_area = 0;    // its uv area in texels of its texture
};

struct LayerPack {
    std::vector<PackedRegion> regions;
    std::vector<uint32_t> region_of;  // per triangle of the node (in `ids` order); kNoRegion when not in this layer
    uint64_t packed_texels = 0;
    BinSize size;                     // the leaf atlas, once shrunk
};
constexpr uint32_t kNoRegion = UINT32_MAX;

struct BuildNode {
    std::vector<uint32_t> ids;  // leaves only, once built
    std::array<std::unique_ptr<BuildNode>, 4> kids;
    std::array<LayerPack, kLayerCount> packs;
    bool leaf = false;
    double forced_shrink = 0;  // > 0: could not pack at full resolution; regions scaled by this
};

class StructureBuilder {
public:
    StructureBuilder(const std::vector<Triangle>& tris, const std::vector<TriangleInfo>& info,
                     const std::vector<double>& weight, const AtlasParams& params, double ppm, double d_min,
                     const std::vector<NativeSize>& native, const std::vector<uint8_t>& promote)
        : tris_(tris), info_(info), weight_(weight), params_(params), ppm_(ppm), d_min_(d_min), native_(native),
          promote_(promote) {}

    // Area-balanced cuts can peel off one triangle per level when areas fall
    // geometrically (a fan of slivers); from this level on, cuts balance
    // counts, which bounds the depth by about log4(n) more levels.
    static constexpr int kCountBalancedFromLevel = 16;
    // Offsets double per level in 64-bit texels; a node this deep is made a leaf, its regions scaled down to fit.
    static constexpr int kMaxLevel = 31;

    void build(BuildNode& node, std::vector<uint32_t> ids, int level) {
        if (tryPack(node, ids, 1.0)) {
            makeLeaf(node, std::move(ids), 0);
            return;
        }
        if (ids.size() < 2 || level >= kMaxLevel) {
            // Only a critical triangle that splitting could not fix, or a
            // pathological depth, ends here: lower the resolution until it
            // packs, and count it.
            double shrink = 1.0;
            while (!tryPack(node, ids, shrink *= 0.8) && shrink > 1e-9) {
            }
            makeLeaf(node, std::move(ids), shrink);
            return;
        }
        auto groups = split(ids, level);
        std::vector<uint32_t>().swap(ids);
        tbb::task_group g;
        for (int q = 0; q < 4; ++q) {
            if (groups[q].empty()) continue;
            node.kids[q] = std::make_unique<BuildNode>();
            g.run([this, &node, &groups, q, level] { build(*node.kids[q], std::move(groups[q]), level + 1); });
        }
        g.wait();
    }

private:
    // Area-balanced median cuts (papers/000 §4.5.3), with two refinements.
    // Units, not triangles, are cut: the triangles of one chart of one feature
    // (one texture, overlapping uv boxes, e.g. the two triangles of a textured
    // quad) stay together, since a chart cut in two costs its whole uv box in both
    // children. And a node whose textured area is mostly one texture is cut in
    // that texture's own space: its charts go to children as contiguous
    // pieces of the texture, which merge into few regions (a building's
    // texture atlas, a facade wrapped around its walls), instead of scattered
    // pieces that each pay a border. The other units join the piece nearest
    // to them. Only a texture of one feature counts: a texture shared by many
    // buildings says nothing about where they are.
    std::array<std::vector<uint32_t>, 4> split(const std::vector<uint32_t>& ids, int level) const {
        const bool by_count = level >= kCountBalancedFromLevel;
        std::vector<Unit> units = unitsOf(ids);
        if (units.size() < 2) return splitIntoFour(ids, tris_, by_count ? std::span<const double>() : weight_);
        const int32_t dominant = dominantTexture(units);
        std::vector<uint32_t> mine, rest;  // unit indices: of the dominant texture, the others
        for (uint32_t k = 0; k < units.size(); ++k) (dominant >= 0 && units[k].texture == dominant ? mine : rest).push_back(k);
        if (mine.size() < 2) {  // nothing to cut in texture space
            rest.insert(rest.end(), mine.begin(), mine.end());
            std::sort(rest.begin(), rest.end());
            mine.clear();
        }
        std::vector<Vec3d> world(units.size()), uv(units.size());
        std::vector<double> w(units.size()), texels(units.size());
        for (size_t k = 0; k < units.size(); ++k)
            world[k] = units[k].world, uv[k] = units[k].uv, w[k] = units[k].weight, texels[k] = units[k].texels;
        auto weights = [&](const std::vector<double>& v) { return by_count ? std::span<const double>() : std::span<const double>(v); };
        std::array<std::vector<uint32_t>, 4> unit_groups;
        if (mine.empty()) {
            unit_groups = splitIntoFourAt(rest, world, weights(w));
        } else {
            unit_groups = splitIntoFourAt(mine, uv, weights(texels));
            joinNearest(units, rest, unit_groups);
        }
        std::array<std::vector<uint32_t>, 4> groups;
        for (int q = 0; q < 4; ++q) {
            for (uint32_t k : unit_groups[q]) groups[q].insert(groups[q].end(), units[k].ids.begin(), units[k].ids.end());
            std::sort(groups[q].begin(), groups[q].end());
        }
        return groups;
    }

    struct Unit {
        std::vector<uint32_t> ids;
        int32_t texture = -1;
        uint32_t feature = 0;
        Vec3d world, uv;  // weighted centroids
        double weight = 0, texels = 0;
    };

    // One unit per chart and feature of every texture (a repeating texture
    // shared by many buildings, paving on roofs, overlaps in uv across all of
    // them, and those must stay free to go their own ways); one per untextured triangle.
    std::vector<Unit> unitsOf(const std::vector<uint32_t>& ids) const {
        std::vector<Unit> units;
        std::map<int32_t, std::vector<uint32_t>> by_texture;
        for (uint32_t i : ids) {
            if (tris_[i].texture >= 0) {
                by_texture[tris_[i].texture].push_back(i);
            } else {
                units.push_back({{i}, -1, tris_[i].feature, {}, {}, 0, 0});
            }
        }
        for (const auto& [texture, members] : by_texture) {
            std::vector<ChartMember> m(members.size());
            for (size_t k = 0; k < members.size(); ++k) {
                const TexelDensity& d = info_[members[k]].density;
                m[k] = {d.uv_min, d.uv_max, 0, 0};
            }
            const std::vector<uint32_t> chart = uvCharts(m);
            std::map<std::pair<uint32_t, uint32_t>, size_t> unit_of;
            for (size_t k = 0; k < members.size(); ++k) {
                auto [it, fresh] = unit_of.emplace(std::pair{chart[k], tris_[members[k]].feature}, units.size());
                if (fresh) units.push_back({{}, texture, tris_[members[k]].feature, {}, {}, 0, 0});
                units[it->second].ids.push_back(members[k]);
            }
        }
        for (Unit& u : units) {
            double w = 0;
            for (uint32_t i : u.ids) {
                const Triangle& t = tris_[i];
                const Vec3d c = (1.0 / 3.0) * (t.position_local[0] + t.position_local[1] + t.position_local[2]);
                const double wi = weight_[i] > 0 ? weight_[i] : 1e-300;  // untextured: still a position
                u.world = u.world + wi * c, u.uv = u.uv + wi * info_[i].uv_centre, w += wi;
                u.weight += weight_[i], u.texels += info_[i].texel_area;
            }
            u.world = (1.0 / w) * u.world, u.uv = (1.0 / w) * u.uv;
        }
        return units;
    }

    // The texture holding at least kDominantShare of the units' textured area,
    // if all of it belongs to one feature (texture space says where things are
    // only within one object); -1 otherwise.
    static int32_t dominantTexture(const std::vector<Unit>& units) {
        std::map<int32_t, double> weight;
        std::map<int32_t, std::set<uint32_t>> features;
        double total = 0;
        for (const Unit& u : units) {
            if (u.texture < 0) continue;
            weight[u.texture] += u.weight, total += u.weight;
            features[u.texture].insert(u.feature);
        }
        for (const auto& [t, w] : weight)
            if (total > 0 && w >= kDominantShare * total && features[t].size() == 1) return t;
        return -1;
    }

    // The other units join the piece of the texture nearest to them in the
    // world, so no child spans more than the node does.
    static void joinNearest(const std::vector<Unit>& units, const std::vector<uint32_t>& rest,
                            std::array<std::vector<uint32_t>, 4>& groups) {
        std::array<Vec3d, 4> centre{};
        for (int q = 0; q < 4; ++q) {
            double sw = 0;
            for (uint32_t k : groups[q]) {
                const double wk = units[k].weight + 1e-300;
                centre[q] = centre[q] + wk * units[k].world, sw += wk;
            }
            if (sw > 0) centre[q] = (1.0 / sw) * centre[q];
        }
        for (uint32_t k : rest) {
            int best = -1;
            double best_d = 1e300;
            for (int q = 0; q < 4; ++q) {
                if (groups[q].empty()) continue;
                const double d = length(units[k].world - centre[q]);
                if (d < best_d) best_d = d, best = q;
            }
            groups[best].push_back(k);
        }
    }
    static constexpr double kDominantShare = 0.75;

    // A leaf's atlases shrink to the smallest size their regions pack into.
    void makeLeaf(BuildNode& node, std::vector<uint32_t> ids, double shrink) {
        node.leaf = true;
        node.forced_shrink = shrink;
        node.ids = std::move(ids);
        for (LayerPack& pack : node.packs)
            if (!pack.regions.empty()) pack.size = shrinkLeafAtlas(params_.packing, params_.atlas_size_px, pack.regions);
    }

    // Regions per texture (papers/000 §4.5.2, charts.h): the largest density
    // of its triangles in this node, capped at the texture's resolution.
    // `shrink` < 1 lowers every region's content resolution (forced leaves only).
    bool tryPack(BuildNode& node, const std::vector<uint32_t>& ids, double shrink) {
        const int a = params_.atlas_size_px, blocks = a / 4;
        const uint64_t capacity = static_cast<uint64_t>(a) * a;
        for (int l = 0; l < kLayerCount; ++l) {
            std::map<int32_t, std::vector<uint32_t>> by_texture;  // texture -> positions in ids
            for (uint32_t k = 0; k < ids.size(); ++k) {
                const Triangle& t = tris_[ids[k]];
                if (t.texture >= 0 && static_cast<int>(info_[ids[k]].layer) == l) by_texture[t.texture].push_back(k);
            }
            LayerPack pack;
            pack.region_of.assign(ids.size(), kNoRegion);
            std::vector<PackItem> items;
            uint64_t area = 0;
            for (const auto& [texture, positions] : by_texture) {
                std::vector<ChartMember> members(positions.size());
                for (size_t k = 0; k < positions.size(); ++k) {
                    const TexelDensity& d = info_[ids[positions[k]]].density;
                    members[k] = {d.uv_min, d.uv_max, d.s_world * ppm_, d.t_world * ppm_};
                }
                if (params_.unique_charts) {
                    std::vector<SurfaceTriangle> surface(positions.size());
                    for (size_t k = 0; k < positions.size(); ++k) {
                        const Triangle& t = tris_[ids[positions[k]]];
                        surface[k] = {t.position_local, t.uv};
                    }
                    const std::vector<uint32_t> of = surfaceComponents(surface);
                    for (size_t k = 0; k < positions.size(); ++k) members[k].surface = of[k];
                }
                ChartSettings cs;
                cs.unique = params_.unique_charts;
                cs.d_min_m = d_min_, cs.shrink = shrink, cs.border_px = params_.border_px, cs.atlas_size_px = a;
                cs.native = static_cast<size_t>(texture) < native_.size() ? native_[static_cast<size_t>(texture)] : NativeSize{};
                cs.promote = static_cast<size_t>(texture) < promote_.size() && promote_[static_cast<size_t>(texture)];
                const TextureRegions planned = planTextureRegions(members, cs);
                const auto first = static_cast<uint32_t>(pack.regions.size());
                for (size_t k = 0; k < positions.size(); ++k) pack.region_of[positions[k]] = first + planned.region_of[k];
                for (const PlannedRegion& p : planned.regions) {
                    PackedRegion r;
                    r.texture = texture, r.w = p.size.w, r.h = p.size.h;
                    r.uv_min = p.size.uv_min, r.uv_max = p.size.uv_max;
                    r.native_u = p.size.native_u, r.native_v = p.size.native_v;
                    r.single_colour = p.single_colour;
                    r.sharp_from_m = sharpFrom(p);
                    r.content_uv_min = p.uv_min, r.content_uv_max = p.uv_max;
                    r.content_w = p.size.content_w, r.content_h = p.size.content_h;
                    r.border_u = p.size.border_u, r.border_v = p.size.border_v;
                    pack.regions.push_back(r);
                    items.push_back({r.w / 4, r.h / 4});
                    area += static_cast<uint64_t>(r.w) * r.h;
                }
                if (area > capacity) return false;  // cannot pack: skip the rest of the work
            }
            std::vector<Placement> placements;
            if (!atlas::pack(params_.packing, items, blocks, &placements)) return false;
            for (size_t k = 0; k < items.size(); ++k) {
                PackedRegion& r = pack.regions[k];
                r.x = placements[k].x * 4, r.y = placements[k].y * 4, r.rotated = placements[k].rotated;
                if (r.rotated) std::swap(r.w, r.h);  // w, h: the footprint in the atlas
            }
            pack.packed_texels = area;
            node.packs[l] = std::move(pack);
        }
        return true;
    }

    const std::vector<Triangle>& tris_;
    const std::vector<TriangleInfo>& info_;
    const std::vector<double>& weight_;
    const AtlasParams& params_;
    double ppm_, d_min_;
    const std::vector<NativeSize>& native_;
    const std::vector<uint8_t>& promote_;
};

struct Flattener {
    AtlasTree& tree;
    const std::vector<Triangle>& tris;
    const std::vector<uint32_t>& sources;
    const std::vector<TriangleInfo>& info;
    std::vector<const BuildNode*> build_of;  // per flat node
    uint64_t forced = 0;
    double smallest_shrink = 1.0;

    int32_t visit(const BuildNode& b, int32_t parent, int level) {
        const auto id = static_cast<int32_t>(tree.nodes.size());
        tree.nodes.emplace_back();
        build_of.push_back(&b);
        {
            AtlasNode& n = tree.nodes.back();
            n.parent = parent, n.level = level;
        }
        tree.stats.depth = std::max(tree.stats.depth, level);
        if (b.forced_shrink > 0) ++forced, smallest_shrink = std::min(smallest_shrink, b.forced_shrink);
        for (int q = 0; q < 4; ++q) {
            if (!b.kids[q]) continue;
            const int32_t c = visit(*b.kids[q], id, level + 1);
            tree.nodes[id].children[q] = c;
        }
        return id;
    }

    // Appends each leaf's triangles of `layer` in depth-first order (by
    // texture within a leaf) and sets every node's range for that layer.
    // atlas_uv holds leaf-atlas texels until rootCoordinates() converts them.
    void order(int32_t id, Layer layer) {
        AtlasNode& n = tree.nodes[id];
        NodeLayer& nl = n.layers[static_cast<int>(layer)];
        nl.range.first = static_cast<uint32_t>(tree.triangles.size());
        if (n.leaf()) {
            const BuildNode& b = *build_of[id];
            const LayerPack& pack = b.packs[static_cast<int>(layer)];
            std::vector<uint32_t> mine;  // positions in b.ids
            for (uint32_t k = 0; k < b.ids.size(); ++k)
                if (info[b.ids[k]].layer == layer) mine.push_back(k);
            std::stable_sort(mine.begin(), mine.end(), [&](uint32_t x, uint32_t y) {
                return tris[b.ids[x]].texture < tris[b.ids[y]].texture;
            });
            for (uint32_t k : mine) {
                const uint32_t i = b.ids[k];
                TreeTriangle t;
                t.tri = tris[i], t.source = sources[i], t.layer = layer;
                // A forced leaf whose regions did not pack even scaled down to
                // nothing (thousands of textures at level 31) has no region:
                // its triangles keep atlas coordinates (0,0), counted with the
                // forced leaves, rather than reading past the region list.
                const bool has_region = k < pack.region_of.size() && pack.region_of[k] < pack.regions.size();
                if (t.tri.texture >= 0 && has_region) {
                    const PackedRegion& r = pack.regions[pack.region_of[k]];
                    for (int c = 0; c < 3; ++c) t.atlas_uv[c] = r.toAtlasTexels(t.tri.uv[c]);
                }
                tree.triangles.push_back(t);
            }
            nl.regions = pack.regions;
            nl.packed_texels = pack.packed_texels;
            if (!pack.regions.empty()) nl.width = pack.size.w, nl.height = pack.size.h;
        } else {
            for (int32_t c : n.children)
                if (c >= 0) order(c, layer);
        }
        tree.nodes[id].layers[static_cast<int>(layer)].range.count =
            static_cast<uint32_t>(tree.triangles.size()) - tree.nodes[id].layers[static_cast<int>(layer)].range.first;
    }

    // Leaf texels -> root-atlas coordinates, once every offset is known:
    // root = (texel + offset) / (A * 2^level), exact up to the sum's rounding.
    void rootCoordinates() {
        const double a = tree.params.atlas_size_px;
        for (const AtlasNode& n : tree.nodes) {
            if (!n.leaf()) continue;
            const double scale = std::ldexp(1.0 / a, -n.level);
            for (int l = 0; l < kLayerCount; ++l) {
                const NodeLayer& nl = n.layers[l];
                for (uint32_t i = nl.range.first; i < nl.range.first + nl.range.count; ++i) {
                    TreeTriangle& t = tree.triangles[i];
                    if (t.tri.texture < 0) continue;
                    for (Vec2d& uv : t.atlas_uv)
                        uv = {(uv.x + static_cast<double>(nl.offset[0])) * scale,
                              (uv.y + static_cast<double>(nl.offset[1])) * scale};
                }
            }
        }
    }

    // Bounds and distances bottom-up. A leaf serves from d_min (its capped
    // regions are exact); its parent holds them halved, so it serves from
    // twice the largest child distance at which every child texel is at most a
    // pixel (papers/000 §4.5.1's 2 x the largest child, without caps).
    void finish(int32_t id, double d_min) {
        AtlasNode& n = tree.nodes[id];
        if (n.leaf()) {
            n.min_distance_m = d_min;
            n.sharp_from_m = d_min;
            for (int l = 0; l < kLayerCount; ++l) {
                const TriangleRange& r = n.layers[l].range;
                for (uint32_t i = r.first; i < r.first + r.count; ++i)
                    for (const Vec3d& p : tree.triangles[i].tri.position_local) n.bounds.extend(p);
                for (const PackedRegion& g : n.layers[l].regions) n.sharp_from_m = std::max(n.sharp_from_m, g.sharp_from_m);
            }
            return;
        }
        double worst = 0;
        for (int32_t c : n.children) {
            if (c < 0) continue;
            finish(c, d_min);
            const AtlasNode& k = tree.nodes[c];
            worst = std::max(worst, k.sharp_from_m);
            if (!k.bounds.empty()) n.bounds.extend(k.bounds.min), n.bounds.extend(k.bounds.max);
        }
        n.min_distance_m = 2.0 * worst;
        n.sharp_from_m = n.min_distance_m;
    }

    // The textures each leaf needs as originals: those with a region below
    // their own resolution.
    void originals() {
        for (AtlasNode& n : tree.nodes) {
            if (!n.leaf()) continue;
            for (const NodeLayer& nl : n.layers)
                for (const PackedRegion& r : nl.regions)
                    if (!r.exact()) n.originals.push_back(r.texture);
            std::sort(n.originals.begin(), n.originals.end());
            n.originals.erase(std::unique(n.originals.begin(), n.originals.end()), n.originals.end());
        }
    }
};

}  // namespace

namespace {

// Consecutive ranges of textures whose models' members fit `budget` bytes
// each (a texture larger than the budget is a range of its own).
std::vector<std::pair<size_t, size_t>> modelRanges(const PagedColumn<uint32_t>& members, uint64_t budget) {
    std::vector<std::pair<size_t, size_t>> out;
    size_t first = 0;
    uint64_t bytes = 0;
    for (size_t i = 0; i < members.size(); ++i) {
        const uint64_t b = uint64_t{members[i]} * sizeof(ChartMember) + TextureModelBuilder::kBytesPerTexture;
        if (i > first && bytes + b > budget) out.emplace_back(first, i), first = i, bytes = 0;
        bytes += b;
    }
    if (first < members.size()) out.emplace_back(first, members.size());
    return out;
}

}  // namespace

Status decideGlobals(const TextureTable& textures, const AtlasParams& params, const TrianglePass& pass,
                     GlobalDecisions* out) {
    if (Status s = validateParams(params); !s.ok()) return s;
    const int threads = params.threads > 0 ? params.threads : static_cast<int>(tbb::info::default_concurrency());
    tbb::task_arena arena(threads);
    const double ppm = projectionBound(params).pixelsPerMetreAt1m();
    const size_t n = textures.size();
    GlobalDecisions g;

    // --- First pass: the scene's box, each texture's d_full and triangle
    // count, the candidates' range; the models too while they fit. 12 bytes
    // a texture of the city (28 until stop 53: the native sizes copied from
    // the table, and the largest s and t apart), in columns whose memory
    // stops at 16 MiB each since stop 54 (the triangles come in scene order,
    // so their textures' pages mostly do too).
    Box3d box;
    const size_t column_bytes = TextureTable::defaultMemoryBytes() / 4;
    PagedColumn<double> native_distance({}, "the textures' native distances", column_bytes);
    PagedColumn<uint32_t> members({}, "the textures' triangle counts", column_bytes);
    for (size_t k = 0; k < n; ++k) native_distance.push_back(0), members.push_back(0);
    DminRange range;
    auto all = std::make_unique<TextureModelBuilder>(n, ppm);
    const Status first = pass(
        [&](const Triangle& t) {
            for (const Vec3d& p : t.position_local) box.extend(p);
            if (all) {
                all->add(t);
                if (all->bytes() > params.model_budget_bytes) all.reset();  // a range at a time, below
            }
            if (t.texture < 0) return;
            // d_full (papers/000 §6.1.2): per texture, the distance at which it needs
            // exactly its original resolution on its more demanding axis. The
            // largest over its triangles: taken per triangle, it is the
            // same number as from the largest s and t (a product and a
            // quotient by positive numbers round monotonically).
            const auto k = static_cast<size_t>(t.texture);
            const TexelDensity d = texelDensity(t);
            const TextureInfo r = textures[k];
            double distance = native_distance[k];
            if (r.width_px > 0) distance = std::max(distance, d.s_world * ppm / r.width_px);
            if (r.height_px > 0) distance = std::max(distance, d.t_world * ppm / r.height_px);
            native_distance.set(k, distance);
            g.degenerate_uv_triangles += d.kind != TexelDensity::Kind::Regular;
            ++g.textured_triangles;
            members.set(k, members[k] + 1);
            range.add({d.uv_min, d.uv_max, d.s_world * ppm, d.t_world * ppm},
                      NativeSize{std::max(0, r.width_px), std::max(0, r.height_px)});
        },
        "texture models");
    if (!first.ok()) return first;
    g.scene_diagonal_m = length(box.max - box.min);

    // Every texture's economy, scene-wide: for the default d_min and the
    // promotions. Held whole when it fits; else built a range at a time.
    const bool whole = all != nullptr;
    std::vector<TextureModel> models;
    if (whole) arena.execute([&] { models = all->finish(textures, params); });
    all.reset();
    const std::vector<std::pair<size_t, size_t>> ranges = modelRanges(members, params.model_budget_bytes);
    const ModelBatches batches = [&](const std::function<void(const std::vector<TextureModel>&)>& fn) -> Status {
        if (whole) {
            fn(models);
            return Status::Ok();
        }
        for (const auto& [a, b] : ranges) {
            std::vector<uint32_t> reserve(b - a);  // the range's counts (its models fit the budget, so do they)
            for (size_t k = a; k < b; ++k) reserve[k - a] = members[k];
            TextureModelBuilder builder(a, b, ppm, reserve.data());
            if (Status s = pass([&](const Triangle& t) { builder.add(t); }, "texture models, a range of textures");
                !s.ok())
                return s;
            std::vector<TextureModel> m;
            arena.execute([&] { m = builder.finish(textures, params); });
            fn(m);
        }
        return Status::Ok();
    };

    // --- d_min: given, chosen from the data, or the papers' fraction of the scene diagonal.
    if (params.d_min_m) {
        g.d_min_requested_m = *params.d_min_m;
        g.d_min_choice = {"given", "given with --d-min", 0, 0, {}};
    } else if (params.d_min_from_data) {
        Status chosen = Status::Ok();
        arena.execute([&] {
            if (whole)
                g.d_min_choice = chooseDefaultDmin(models, g.scene_diagonal_m, params, &g.d_min_requested_m);
            else
                chosen = chooseDefaultDminInBatches(range, batches, g.scene_diagonal_m, params, &g.d_min_requested_m,
                                                    &g.d_min_choice);
        });
        if (!chosen.ok()) return chosen;
    } else {
        g.d_min_requested_m = g.scene_diagonal_m * params.d_min_diagonal_fraction;
        g.d_min_choice = {"diagonal-fraction", fmt::format("the scene diagonal {:.0f} m / {:.3g}", g.scene_diagonal_m,
                                                          1.0 / params.d_min_diagonal_fraction), 0, 0, {}};
    }
    if (!(g.d_min_requested_m > 0)) return Status::Usage("the scene has zero extent: give --d-min in metres");
    double lo = 1e300, hi = 0;
    for (size_t k = 0; k < n; ++k)
        if (const double distance = native_distance[k]; distance > 0) lo = std::min(lo, distance), hi = std::max(hi, distance);
    g.d_full_m = lo < 1e300 ? lo : 0;
    g.d_first_upsampled_m = hi;
    native_distance = PagedColumn<double>();

    // --- Second pass: critical triangles, and the d_min actually used.
    CriticalDistanceBuilder critical(g.d_min_requested_m, ppm, params.atlas_size_px, params.border_px,
                                     params.critical_fraction, textures);
    if (Status s = pass([&](const Triangle& t) { critical.add(t); }, "critical triangles"); !s.ok()) return s;
    const CriticalResult c = critical.finish();
    g.d_min_used_m = c.d_min_used_m;
    g.critical_triangles = c.critical_at_requested;
    g.enlarged_for_split_budget = c.enlarged_for_split_budget;

    // --- Textures whose full resolution costs less than their original (texture_economy.h).
    g.promote.assign(n, 0);
    size_t offset = 0;
    const Status promoted = batches([&](const std::vector<TextureModel>& m) {
        arena.execute([&] {
            tbb::parallel_for(size_t{0}, m.size(), [&](size_t i) {
                g.promote[offset + i] = planTexture(m[i], params, g.d_min_used_m).promoted ? 1 : 0;
            });
        });
        offset += m.size();
    });
    if (!promoted.ok()) return promoted;
    *out = std::move(g);
    return Status::Ok();
}

Status decideGlobals(const Scene& scene, const AtlasParams& params, GlobalDecisions* out) {
    return decideGlobals(scene.textures, params,
                         [&](const std::function<void(const Triangle&)>& fn, const char*) {
                             for (const Triangle& t : scene.triangles) fn(t);
                             return Status::Ok();
                         },
                         out);
}

Status buildAtlasTree(const Scene& scene, const AtlasParams& params, const fs::path& output_dir,
                      Diagnostics& diagnostics, const AtlasProgressFn& progress, AtlasTree* tree,
                      const AtlasImageSink& sink, std::vector<Triangle>* consume_triangles,
                      const GlobalDecisions* given) {
    if (Status s = validateParams(params); !s.ok()) return s;
    *tree = AtlasTree{};
    tree->params = params;
    tree->projection = projectionBound(params);
    AtlasStats& stats = tree->stats;
    StageClock clock;
    auto step = [&](const char* name) {
        const StageCost c = clock.lap();
        stats.steps.push_back({name, c.seconds, c.peak_rss_mb, c.cpu_seconds});
    };
    if (scene.triangles.empty()) return Status::Invalid("the scene has no triangles: nothing to build an atlas tree from");

    const int threads = params.threads > 0 ? params.threads : static_cast<int>(tbb::info::default_concurrency());
    tbb::task_arena arena(threads);
    const double ppm = tree->projection.pixelsPerMetreAt1m();
    const std::vector<NativeSize> native = nativeSizes(scene);
    GlobalDecisions own;
    if (!given) {
        if (Status s = decideGlobals(scene, params, &own); !s.ok()) return s;
    }
    const GlobalDecisions& globals = given ? *given : own;
    if (globals.promote.size() != scene.textures.size())
        return Status::Invalid("atlas: the global decisions are for another scene (texture count differs)");
    stats.scene_diagonal_m = globals.scene_diagonal_m;
    stats.d_min_choice = globals.d_min_choice;
    stats.d_min_requested_m = globals.d_min_requested_m;
    stats.d_min_used_m = globals.d_min_used_m;
    stats.d_full_m = globals.d_full_m;
    stats.d_first_upsampled_m = globals.d_first_upsampled_m;
    stats.degenerate_uv_triangles = globals.degenerate_uv_triangles;
    stats.textured_triangles = globals.textured_triangles;
    stats.critical_triangles = globals.critical_triangles;
    stats.enlarged_for_split_budget = globals.enlarged_for_split_budget;
    const std::vector<uint8_t>& promote = globals.promote;

    std::vector<Triangle> tris;
    if (consume_triangles == &scene.triangles) tris = std::move(*consume_triangles);
    else tris = scene.triangles;
    std::vector<uint32_t> sources;
    CriticalResult critical;
    splitCriticalTriangles(tris, sources, globals.d_min_used_m, ppm, params.atlas_size_px, params.border_px, native,
                           &critical);
    stats.critical_after_enlarge = critical.critical_after_enlarge;
    stats.triangles_split = critical.triangles_split;
    stats.triangles_added_by_split = critical.triangles_added;

    std::vector<TriangleInfo> info(tris.size());
    std::vector<double> weight(tris.size());
    arena.execute([&] {
        tbb::task_group g;
        const size_t chunk = 1 << 14;
        for (size_t begin = 0; begin < tris.size(); begin += chunk)
            g.run([&, begin] {
                for (size_t i = begin; i < std::min(tris.size(), begin + chunk); ++i) {
                    info[i].density = texelDensity(tris[i]);
                    info[i].layer = layerOf(tris[i], scene);
                    const Triangle& t = tris[i];
                    if (t.texture >= 0) {
                        info[i].uv_centre = {(t.uv[0].x + t.uv[1].x + t.uv[2].x) / 3, (t.uv[0].y + t.uv[1].y + t.uv[2].y) / 3, 0};
                        const double uv_area = 0.5 * std::abs((t.uv[1].x - t.uv[0].x) * (t.uv[2].y - t.uv[0].y) -
                                                              (t.uv[2].x - t.uv[0].x) * (t.uv[1].y - t.uv[0].y));
                        const NativeSize n = native[static_cast<size_t>(t.texture)];
                        info[i].texel_area = uv_area * std::max(1, n.w) * std::max(1, n.h);
                    }
                    // Untextured triangles take no atlas space: they do not weigh in the split.
                    weight[i] = tris[i].texture >= 0 ? triangleArea(tris[i].position_local) : 0.0;
                }
            });
        g.wait();
    });
    step("estimate");
    if (progress) progress("splitting nodes", 0, 0);

    BuildNode root;
    {
        std::vector<uint32_t> all(tris.size());
        for (uint32_t i = 0; i < all.size(); ++i) all[i] = i;
        StructureBuilder builder(tris, info, weight, params, ppm, stats.d_min_used_m, native, promote);
        arena.execute([&] { builder.build(root, std::move(all), params.base_level); });
    }
    step("structure");

    Flattener flat{*tree, tris, sources, info, {}, 0};
    flat.visit(root, -1, 0);
    tree->triangles.reserve(tris.size());
    flat.order(0, Layer::Opaque);
    flat.order(0, Layer::Alpha);
    flat.finish(0, stats.d_min_used_m);
    flat.originals();
    stats.nodes = tree->nodes.size();
    // Children are numbered after their parent, so a reverse sweep sees every
    // child's atlas before its parent asks for it. A layer with only
    // untextured triangles needs no image, nor do ancestors without a textured child.
    for (size_t id = tree->nodes.size(); id-- > 0;) {
        AtlasNode& n = tree->nodes[id];
        stats.leaves += n.leaf();
        for (int l = 0; l < kLayerCount; ++l) {
            NodeLayer& nl = n.layers[l];
            bool textured = n.leaf() && !nl.regions.empty();
            for (int32_t c : n.children) textured |= c >= 0 && !tree->nodes[c].layers[l].atlas_path.empty();
            if (nl.range.count == 0 || !textured) {
                nl.width = nl.height = 0;
                continue;
            }
            nl.atlas_path = fmt::format("atlas/{}/{}.png", layerName(static_cast<Layer>(l)), id);
        }
    }
    placeAtlases(*tree);
    flat.rootCoordinates();
    accountTexels(scene, *tree);
    if (flat.forced) {
        stats.leaves_below_resolution = flat.forced;
        diagnostics.warn(warn::kAtlasResolutionLowered,
                         {"", 0, "", fmt::format("{} leaf node(s) could not pack at the resolution d_min asks for "
                                                 "(a critical triangle left unsplit, or a tree deeper than 31 levels); "
                                                 "their regions were scaled down, to {:.3g} at worst, and the "
                                                 "texel-size guarantee does not hold for them",
                                                 flat.forced, flat.smallest_shrink)});
    }
    step("order");
    // The images need the tree and the scene only: what the structure was
    // built from goes before they start (at 100,000 buildings, 2.2 M
    // triangles: about 230 bytes each).
    flat.build_of = {};
    root = BuildNode{};
    std::vector<Triangle>().swap(tris);
    std::vector<uint32_t>().swap(sources);
    std::vector<TriangleInfo>().swap(info);
    std::vector<double>().swap(weight);

    if (!params.render_images) return Status::Ok();
    RenderResult rendered;
    Status s;
    arena.execute([&] {
        s = renderAtlases(scene, *tree, output_dir, progress, &rendered, sink, nullptr, params.keep_root_halves);
    });
    tree->root_halves = std::move(rendered.root_halves);
    if (!s.ok()) return s;
    stats.original_texture_bytes = rendered.original_texture_bytes;
    stats.textures_unreadable = rendered.unreadable_textures.size();
    for (int32_t t : rendered.unreadable_textures)
        diagnostics.warn(warn::kTextureUnreadable,
                         {scene.textures.path(t), 0, "", "cannot be read: its atlas regions are mid grey"});
    step("images");
    return Status::Ok();
}

}  // namespace cityatlas::atlas
