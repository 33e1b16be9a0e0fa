// SPDX-License-Identifier: GPL-3.0-or-later
// planShards: the top cuts over whole features; assembleTree: the shards'
// subtrees under that top, numbered and placed as one tree.
#include "atlas/shard_plan.h"

#include <algorithm>
#include <functional>

#include <fmt/format.h>

#include "atlas/placement.h"
#include "atlas/subdivide.h"

namespace cityatlas::atlas {

void FeatureSummaries::add(const Triangle& t) {
    const size_t f = t.feature;
    if (f >= count.size()) {
        const size_t n = f + 1;
        count.resize(n, 0), weight.resize(n, 0), area.resize(n, 0), point.resize(n, Vec3d{0, 0, 0});
    }
    const double a = triangleArea(t.position_local);
    const Vec3d c = (1.0 / 3.0) * (t.position_local[0] + t.position_local[1] + t.position_local[2]);
    ++count[f];
    // Every triangle places its feature (a zero-area one still counts a little);
    // only textured area weighs in the cut, as in the tree (tree_build.cpp).
    const double w = a > 0 ? a : 1e-300;
    point[f] = point[f] + w * c;
    area[f] += w;
    if (t.texture >= 0) weight[f] += a;
}

ShardPlan planShards(const Scene& scene, uint64_t max_triangles) {
    FeatureSummaries s;
    for (const Triangle& t : scene.triangles) s.add(t);
    return planShards(std::move(s), scene.features.size(), max_triangles);
}

namespace {
// A summary column as a vector (what the cuts index), its deque freed at
// once: one column is held twice at a time, not the whole summaries.
template <class T>
std::vector<T> column(std::deque<T>& in, size_t n, const T& none) {
    std::vector<T> out(n, none);
    std::copy_n(in.begin(), std::min(n, in.size()), out.begin());
    std::deque<T>().swap(in);
    return out;
}
}  // namespace

ShardPlan planShards(FeatureSummaries&& summaries, size_t features, uint64_t max_triangles) {
    ShardPlan plan;
    const size_t nf = features;
    const std::vector<uint64_t> count = column(summaries.count, nf, uint64_t{0});
    const std::vector<double> weight = column(summaries.weight, nf, 0.0);
    std::vector<Vec3d> point(nf, Vec3d{0, 0, 0});
    for (size_t f = 0; f < std::min(nf, summaries.point.size()); ++f)
        if (count[f] > 0) point[f] = (1.0 / summaries.area[f]) * summaries.point[f];
    summaries = {};
    std::vector<uint32_t> all;
    for (uint32_t f = 0; f < nf; ++f)
        if (count[f] > 0) all.push_back(f);
    plan.shard_of_feature.assign(nf, -1);
    std::function<int32_t(std::vector<uint32_t>, int32_t, int)> cut = [&](std::vector<uint32_t> ids, int32_t parent,
                                                                          int level) {
        const auto id = static_cast<int32_t>(plan.nodes.size());
        plan.nodes.push_back({parent, {-1, -1, -1, -1}, level, -1});
        uint64_t triangles = 0;
        for (uint32_t f : ids) triangles += count[f];
        if (triangles <= max_triangles || ids.size() < 2) {
            const auto shard = static_cast<int32_t>(plan.shard_triangles.size());
            plan.nodes[static_cast<size_t>(id)].shard = shard;
            plan.shard_triangles.push_back(triangles);
            for (uint32_t f : ids) plan.shard_of_feature[f] = shard;
            return id;
        }
        auto groups = splitIntoFourAt(ids, point, weight);
        std::vector<uint32_t>().swap(ids);
        for (size_t q = 0; q < 4; ++q) {
            if (groups[q].empty()) continue;
            const int32_t c = cut(std::move(groups[q]), id, level + 1);
            plan.nodes[static_cast<size_t>(id)].children[q] = c;
        }
        return id;
    };
    cut(std::move(all), -1, 0);
    return plan;
}

void assembleTree(const ShardPlan& plan, const std::vector<AtlasTree>& shards, const AtlasParams& params,
                  AtlasTree* out, std::vector<int32_t>* shard_root, std::vector<uint8_t>* built) {
    *out = AtlasTree{};
    out->params = params;
    out->projection = projectionBound(params);
    shard_root->assign(shards.size(), -1);
    built->clear();
    std::vector<AtlasNode>& nodes = out->nodes;
    std::function<int32_t(int32_t, int32_t, int)> emit = [&](int32_t plan_id, int32_t parent, int level) {
        const PlanNode& pn = plan.nodes[static_cast<size_t>(plan_id)];
        if (pn.shard >= 0) {
            const auto base = static_cast<int32_t>(nodes.size());
            for (const AtlasNode& local : shards[static_cast<size_t>(pn.shard)].nodes) {
                AtlasNode n = local;
                const auto id = static_cast<int32_t>(nodes.size());
                n.parent = local.parent < 0 ? parent : base + local.parent;
                for (int32_t& c : n.children)
                    if (c >= 0) c += base;
                n.level = local.level + level;
                for (int l = 0; l < kLayerCount; ++l)
                    if (!n.layers[l].atlas_path.empty())
                        n.layers[l].atlas_path = fmt::format("atlas/{}/{}.png", layerName(static_cast<Layer>(l)), id);
                nodes.push_back(std::move(n));
                built->push_back(1);
            }
            (*shard_root)[static_cast<size_t>(pn.shard)] = base;
            return base;
        }
        const auto id = static_cast<int32_t>(nodes.size());
        AtlasNode top;
        top.parent = parent;
        top.level = level;
        nodes.push_back(std::move(top));
        built->push_back(0);
        for (size_t q = 0; q < 4; ++q)
            if (pn.children[q] >= 0) {
                const int32_t c = emit(pn.children[q], id, level + 1);
                nodes[static_cast<size_t>(id)].children[q] = c;
            }
        return id;
    };
    emit(0, -1, 0);
    // The top's nodes as buildAtlasTree makes inner nodes (tree_build.cpp
    // finish() and the atlas paths): children are numbered after their parent.
    for (size_t id = nodes.size(); id-- > 0;) {
        if ((*built)[id]) continue;
        AtlasNode& n = nodes[id];
        double worst = 0;
        for (int32_t c : n.children) {
            if (c < 0) continue;
            const AtlasNode& k = nodes[static_cast<size_t>(c)];
            worst = std::max(worst, k.sharp_from_m);
            if (!k.bounds.empty()) n.bounds.extend(k.bounds.min), n.bounds.extend(k.bounds.max);
            for (int l = 0; l < kLayerCount; ++l) n.layers[l].range.count += k.layers[l].range.count;
        }
        n.min_distance_m = 2.0 * worst;
        n.sharp_from_m = n.min_distance_m;
        for (int l = 0; l < kLayerCount; ++l) {
            bool textured = false;
            for (int32_t c : n.children) textured |= c >= 0 && !nodes[static_cast<size_t>(c)].layers[l].atlas_path.empty();
            if (n.layers[l].range.count > 0 && textured)
                n.layers[l].atlas_path = fmt::format("atlas/{}/{}.png", layerName(static_cast<Layer>(l)), id);
        }
    }
    placeAtlases(*out);
    AtlasStats& s = out->stats;
    s.nodes = nodes.size();
    for (const AtlasNode& n : nodes) {
        s.leaves += n.leaf();
        s.depth = std::max(s.depth, n.level);
    }
}

}  // namespace cityatlas::atlas
