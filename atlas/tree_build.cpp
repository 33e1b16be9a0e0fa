// SPDX-License-Identifier: GPL-3.0-or-later
// buildAtlasTree: critical triangles, recursive node splitting until every
// node's regions pack (papers/000 §4.5.1), then numbering, triangle order,
// root-atlas coordinates and the images.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <sys/resource.h>

#include <fmt/format.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include "atlas/atlas_images.h"
#include "atlas/atlas_tree.h"
#include "atlas/subdivide.h"
#include "atlas/texel_estimate.h"

namespace cityatlas::atlas {

namespace fs = std::filesystem;

namespace {

double peakRssMb() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return static_cast<double>(u.ru_maxrss) * 1024.0 / 1e6;  // Linux reports KiB; MB as the CLI prints them
}

Layer layerOf(const Triangle& t, const Scene& scene) {
    if (t.texture >= 0) return scene.textures[t.texture].channels == 4 ? Layer::Alpha : Layer::Opaque;
    if (t.material >= 0 && scene.materials[t.material].transparency > 0) return Layer::Alpha;
    return Layer::Opaque;
}

struct TexelDensityBox {
    Vec2d lo, hi;
};

// What the packer needs per triangle, computed once.
struct TriangleInfo {
    TexelDensity density;
    Layer layer = Layer::Opaque;
};

struct LayerPack {
    std::vector<PackedRegion> regions;
    std::vector<uint32_t> region_of;  // per triangle of the node (in `ids` order); kNoRegion when not in this layer
    uint64_t packed_texels = 0;
};
constexpr uint32_t kNoRegion = UINT32_MAX;

bool overlaps1d(double alo, double ahi, double blo, double bhi) {
    const double lo = std::max(alo, blo), hi = std::min(ahi, bhi);
    return hi > lo || (hi == lo && (alo == ahi || blo == bhi));
}

// Charts: the triangles of one texture whose uv boxes overlap, transitively.
// Each chart becomes its own region, so the two opposite walls of a building
// sharing a wrapped facade texture do not pay for the walls between them in
// texture space (the papers take one box per texture and node). Charts may
// overlap in uv (a chart's box is the union of its members'), which only
// duplicates texels; every triangle's uv box lies inside its chart's region.
std::vector<uint32_t> uvCharts(const std::vector<uint32_t>& members, const std::vector<TexelDensityBox>& box) {
    std::vector<uint32_t> parent(members.size());
    for (uint32_t k = 0; k < parent.size(); ++k) parent[k] = k;
    auto find = [&](uint32_t k) {
        while (parent[k] != k) k = parent[k] = parent[parent[k]];
        return k;
    };
    std::vector<uint32_t> order(members.size());
    for (uint32_t k = 0; k < order.size(); ++k) order[k] = k;
    std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
        const double ua = box[members[a]].lo.x, ub = box[members[b]].lo.x;
        return ua != ub ? ua < ub : a < b;
    });
    std::vector<uint32_t> active;
    for (uint32_t k : order) {
        const TexelDensityBox& bk = box[members[k]];
        size_t kept = 0;
        for (uint32_t j : active) {
            const TexelDensityBox& bj = box[members[j]];
            if (bj.hi.x < bk.lo.x) continue;  // ends before this one starts: never overlaps a later one either
            active[kept++] = j;
            if (overlaps1d(bj.lo.x, bj.hi.x, bk.lo.x, bk.hi.x) && overlaps1d(bj.lo.y, bj.hi.y, bk.lo.y, bk.hi.y)) {
                const uint32_t a = find(j), b = find(k);
                if (a != b) parent[std::max(a, b)] = std::min(a, b);
            }
        }
        active.resize(kept);
        active.push_back(k);
    }
    for (uint32_t k = 0; k < parent.size(); ++k) parent[k] = find(k);
    return parent;  // chart id = smallest member position
}

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
                     const std::vector<double>& weight, const AtlasParams& params, double f)
        : tris_(tris), info_(info), weight_(weight), params_(params), f_(f) {}

    // Area-balanced cuts can peel off one triangle per level when areas fall
    // geometrically (a fan of slivers); from this level on, cuts balance
    // counts, which bounds the depth by about log4(n) more levels.
    static constexpr int kCountBalancedFromLevel = 16;
    // Node offsets are 32-bit; a node this deep is made a leaf, its regions scaled down to fit.
    static constexpr int kMaxLevel = 31;

    void build(BuildNode& node, std::vector<uint32_t> ids, int level) {
        if (tryPack(node, ids, 1.0)) {
            node.leaf = true;
            node.ids = std::move(ids);
            return;
        }
        if (ids.size() < 2 || level >= kMaxLevel) {
            // Only a critical triangle that splitting could not fix, or a
            // pathological depth, ends here: lower the resolution until it
            // packs, and count it.
            double shrink = 1.0;
            while (!tryPack(node, ids, shrink *= 0.8) && shrink > 1e-9) {
            }
            node.leaf = true;
            node.forced_shrink = shrink;
            node.ids = std::move(ids);
            return;
        }
        auto groups = splitIntoFour(ids, tris_, level >= kCountBalancedFromLevel ? std::span<const double>() : weight_);
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
    // Regions per texture (papers/000 §4.5.2): the largest density of its
    // triangles in this node over the union of their uv boxes.
    // `shrink` < 1 lowers every region's content resolution (forced leaves only).
    bool tryPack(BuildNode& node, const std::vector<uint32_t>& ids, double shrink) {
        const bool clamp = shrink < 1.0;  // forced leaf: no region larger than the atlas
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
                std::vector<uint32_t> members(positions.size());
                for (size_t k = 0; k < positions.size(); ++k) members[k] = ids[positions[k]];
                const std::vector<uint32_t> chart = uvCharts(members, boxes_);
                // Per chart: the largest density of its triangles over the union of their uv boxes (papers/000 §4.5.2).
                std::map<uint32_t, uint32_t> region_of_chart;
                struct Acc {
                    double per_u = 0, per_v = 0;
                    Vec2d lo{1e300, 1e300}, hi{-1e300, -1e300};
                };
                std::vector<Acc> acc;
                for (size_t k = 0; k < members.size(); ++k) {
                    auto [it, fresh] = region_of_chart.emplace(chart[k], static_cast<uint32_t>(acc.size()));
                    if (fresh) acc.emplace_back();
                    Acc& c = acc[it->second];
                    const TexelDensity& d = info_[members[k]].density;
                    c.per_u = std::max(c.per_u, d.s_world * f_);
                    c.per_v = std::max(c.per_v, d.t_world * f_);
                    c.lo = {std::min(c.lo.x, d.uv_min.x), std::min(c.lo.y, d.uv_min.y)};
                    c.hi = {std::max(c.hi.x, d.uv_max.x), std::max(c.hi.y, d.uv_max.y)};
                    pack.region_of[positions[k]] = static_cast<uint32_t>(pack.regions.size()) + it->second;
                }
                for (const Acc& c : acc) {
                    RegionSize rs = regionSize(c.per_u * shrink, c.per_v * shrink, c.lo, c.hi, params_.border_px);
                    if (clamp) rs.w = std::min(rs.w, a), rs.h = std::min(rs.h, a);
                    PackedRegion r;
                    r.texture = texture, r.w = rs.w, r.h = rs.h, r.uv_min = rs.uv_min, r.uv_max = rs.uv_max;
                    pack.regions.push_back(r);
                    items.push_back({rs.w / 4, rs.h / 4});
                    area += static_cast<uint64_t>(rs.w) * rs.h;
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
    std::vector<TexelDensityBox> boxes_ = [this] {
        std::vector<TexelDensityBox> b(info_.size());
        for (size_t i = 0; i < b.size(); ++i) b[i] = {info_[i].density.uv_min, info_[i].density.uv_max};
        return b;
    }();
    const std::vector<double>& weight_;
    const AtlasParams& params_;
    double f_;
};

struct Flattener {
    AtlasTree& tree;
    const std::vector<Triangle>& tris;
    const std::vector<uint32_t>& sources;
    const std::vector<TriangleInfo>& info;
    std::vector<const BuildNode*> build_of;  // per flat node
    uint64_t forced = 0;
    double smallest_shrink = 1.0;

    int32_t visit(const BuildNode& b, int32_t parent, int level, std::array<uint32_t, 2> offset) {
        const auto id = static_cast<int32_t>(tree.nodes.size());
        tree.nodes.emplace_back();
        build_of.push_back(&b);
        {
            AtlasNode& n = tree.nodes.back();
            n.parent = parent, n.level = level, n.offset = offset;
        }
        tree.stats.depth = std::max(tree.stats.depth, level);
        if (b.forced_shrink > 0) ++forced, smallest_shrink = std::min(smallest_shrink, b.forced_shrink);
        for (int q = 0; q < 4; ++q) {
            if (!b.kids[q]) continue;
            const std::array<uint32_t, 2> child_offset{2 * offset[0] + (q & 1), 2 * offset[1] + (q >> 1)};
            const int32_t c = visit(*b.kids[q], id, level + 1, child_offset);
            tree.nodes[id].children[q] = c;
        }
        return id;
    }

    // Appends each leaf's triangles of `layer` in depth-first order (by
    // texture within a leaf) and sets every node's range for that layer.
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
            const double a = tree.params.atlas_size_px, scale = std::ldexp(1.0, -n.level);
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
                    const PackedRegion* r = &pack.regions[pack.region_of[k]];
                    for (int c = 0; c < 3; ++c) {
                        const Vec2d texel = r->toAtlasTexels(t.tri.uv[c]);
                        t.atlas_uv[c] = {(texel.x / a + n.offset[0]) * scale, (texel.y / a + n.offset[1]) * scale};
                    }
                }
                tree.triangles.push_back(t);
            }
            nl.regions = pack.regions;
            nl.packed_texels = pack.packed_texels;
        } else {
            for (int32_t c : n.children)
                if (c >= 0) order(c, layer);
        }
        tree.nodes[id].layers[static_cast<int>(layer)].range.count =
            static_cast<uint32_t>(tree.triangles.size()) - tree.nodes[id].layers[static_cast<int>(layer)].range.first;
    }

    // Bounds and minDistance bottom-up (papers/000 §4.5.1: 2 x the largest child).
    void finish(int32_t id, double d_min) {
        AtlasNode& n = tree.nodes[id];
        if (n.leaf()) {
            n.min_distance_m = d_min;
            for (int l = 0; l < kLayerCount; ++l) {
                const TriangleRange& r = n.layers[l].range;
                for (uint32_t i = r.first; i < r.first + r.count; ++i)
                    for (const Vec3d& p : tree.triangles[i].tri.position_local) n.bounds.extend(p);
            }
            return;
        }
        double worst = 0;
        for (int32_t c : n.children) {
            if (c < 0) continue;
            finish(c, d_min);
            const AtlasNode& k = tree.nodes[c];
            worst = std::max(worst, k.min_distance_m);
            if (!k.bounds.empty()) n.bounds.extend(k.bounds.min), n.bounds.extend(k.bounds.max);
        }
        n.min_distance_m = 2.0 * worst;
    }
};

}  // namespace

Status buildAtlasTree(const Scene& scene, const AtlasParams& params, const fs::path& output_dir,
                      Diagnostics& diagnostics, const AtlasProgressFn& progress, AtlasTree* tree) {
    if (Status s = validateParams(params); !s.ok()) return s;
    *tree = AtlasTree{};
    tree->params = params;
    tree->projection = projectionBound(params);
    AtlasStats& stats = tree->stats;
    auto clock = std::chrono::steady_clock::now();
    auto step = [&](const char* name) {
        const auto now = std::chrono::steady_clock::now();
        stats.steps.push_back({name, std::chrono::duration<double>(now - clock).count(), peakRssMb()});
        clock = now;
    };
    if (scene.triangles.empty()) return Status::Fail("the scene has no triangles: nothing to build an atlas tree from");

    const int threads = params.threads > 0 ? params.threads : static_cast<int>(tbb::info::default_concurrency());
    tbb::task_arena arena(threads);

    // d_min: given, or the papers' fraction of the scene diagonal.
    Box3d box;
    for (const Triangle& t : scene.triangles)
        for (const Vec3d& p : t.position_local) box.extend(p);
    stats.scene_diagonal_m = length(box.max - box.min);
    stats.d_min_requested_m = params.d_min_m ? *params.d_min_m : stats.scene_diagonal_m * params.d_min_diagonal_fraction;
    if (!(stats.d_min_requested_m > 0))
        return Status::Fail("the scene has zero extent: give --d-min in metres");
    const double ppm = tree->projection.pixelsPerMetreAt1m();

    // d_full (papers/000 §6.1.2): per texture, the distance at which it needs
    // exactly its original resolution on its more demanding axis.
    std::vector<double> native_distance(scene.textures.size(), 0);
    {
        std::vector<double> s_max(scene.textures.size(), 0), t_max(scene.textures.size(), 0);
        for (const Triangle& t : scene.triangles) {
            if (t.texture < 0) continue;
            const TexelDensity d = texelDensity(t);
            s_max[t.texture] = std::max(s_max[t.texture], d.s_world);
            t_max[t.texture] = std::max(t_max[t.texture], d.t_world);
            stats.degenerate_uv_triangles += d.kind != TexelDensity::Kind::Regular;
            ++stats.textured_triangles;
        }
        double lo = 1e300, hi = 0;
        for (size_t i = 0; i < scene.textures.size(); ++i) {
            const TextureRef& r = scene.textures[i];
            if (r.width_px > 0) native_distance[i] = std::max(native_distance[i], s_max[i] * ppm / r.width_px);
            if (r.height_px > 0) native_distance[i] = std::max(native_distance[i], t_max[i] * ppm / r.height_px);
            if (native_distance[i] > 0) lo = std::min(lo, native_distance[i]), hi = std::max(hi, native_distance[i]);
        }
        stats.d_full_m = lo < 1e300 ? lo : 0;
        stats.d_first_upsampled_m = hi;
    }

    std::vector<Triangle> tris = scene.triangles;
    std::vector<uint32_t> sources;
    const CriticalResult critical =
        resolveCriticalTriangles(tris, sources, stats.d_min_requested_m, ppm, params.atlas_size_px, params.border_px,
                                 params.critical_fraction);
    stats.d_min_used_m = critical.d_min_used_m;
    stats.critical_triangles = critical.critical_at_requested;
    stats.critical_after_enlarge = critical.critical_after_enlarge;
    stats.enlarged_for_split_budget = critical.enlarged_for_split_budget;
    stats.triangles_split = critical.triangles_split;
    stats.triangles_added_by_split = critical.triangles_added;
    const double f = ppm / stats.d_min_used_m;
    for (double d : native_distance) stats.textures_upsampled += d > stats.d_min_used_m;

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
        StructureBuilder builder(tris, info, weight, params, f);
        arena.execute([&] { builder.build(root, std::move(all), 0); });
    }
    step("structure");

    Flattener flat{*tree, tris, sources, info, {}, 0};
    flat.visit(root, -1, 0, {0, 0});
    tree->triangles.reserve(tris.size());
    flat.order(0, Layer::Opaque);
    flat.order(0, Layer::Alpha);
    flat.finish(0, stats.d_min_used_m);
    stats.nodes = tree->nodes.size();
    // Children are numbered after their parent, so a reverse sweep sees every
    // child's atlas before its parent asks for it. A layer with only
    // untextured triangles needs no image, nor do ancestors without a textured child.
    const uint64_t atlas_texels = static_cast<uint64_t>(params.atlas_size_px) * params.atlas_size_px;
    for (size_t id = tree->nodes.size(); id-- > 0;) {
        AtlasNode& n = tree->nodes[id];
        stats.leaves += n.leaf();
        for (int l = 0; l < kLayerCount; ++l) {
            NodeLayer& nl = n.layers[l];
            bool textured = n.leaf() && !nl.regions.empty();
            for (int32_t c : n.children) textured |= c >= 0 && !tree->nodes[c].layers[l].atlas_path.empty();
            if (nl.range.count == 0 || !textured) continue;
            nl.atlas_path = fmt::format("atlas/{}/{}.png", layerName(static_cast<Layer>(l)), id);
            ++stats.atlases;
            stats.atlas_texture_bytes += atlas_texels * (l == 0 ? 3 : 4);
            if (n.leaf()) stats.packed_texels += nl.packed_texels, stats.leaf_atlas_texels += atlas_texels;
        }
    }
    if (flat.forced) {
        stats.leaves_below_resolution = flat.forced;
        diagnostics.warn("atlas_resolution_lowered",
                         {"", 0, "", fmt::format("{} leaf node(s) could not pack at the resolution d_min asks for "
                                                 "(a critical triangle left unsplit, or a tree deeper than 31 levels); "
                                                 "their regions were scaled down, to {:.3g} at worst, and the "
                                                 "texel-size guarantee does not hold for them",
                                                 flat.forced, flat.smallest_shrink)});
    }
    step("order");

    if (!params.render_images) return Status::Ok();
    RenderResult rendered;
    Status s;
    arena.execute([&] { s = renderAtlases(scene, *tree, output_dir, progress, &rendered); });
    if (!s.ok()) return s;
    stats.original_texture_bytes = rendered.original_texture_bytes;
    stats.textures_unreadable = rendered.unreadable_textures.size();
    for (int32_t t : rendered.unreadable_textures)
        diagnostics.warn(warn::kTextureUnreadable,
                         {scene.textures[t].path, 0, "", "cannot be read: its atlas regions are mid grey"});
    step("images");
    return Status::Ok();
}

}  // namespace cityatlas::atlas
