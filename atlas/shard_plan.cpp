// SPDX-License-Identifier: GPL-3.0-or-later
// planShards: the top cuts over whole features; assembleTree: the shards'
// subtrees under that top, numbered and placed as one tree.
#include "atlas/shard_plan.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>

#include <fmt/format.h>

#include "atlas/placement.h"
#include "core/external_sort.h"
#include "core/windowed_records.h"

namespace cityatlas::atlas {

void FeatureSummaries::add(const Triangle& t) {
    FeatureSummary& s = records.at(t.feature);
    const double a = triangleArea(t.position_local);
    const Vec3d c = (1.0 / 3.0) * (t.position_local[0] + t.position_local[1] + t.position_local[2]);
    ++s.count;
    // Every triangle places its feature (a zero-area one still counts a little);
    // only textured area weighs in the cut, as in the tree (tree_build.cpp).
    const double w = a > 0 ? a : 1e-300;
    s.point = s.point + w * c;
    s.area += w;
    if (t.texture >= 0) s.weight += a;
}

ShardPlan planShards(const Scene& scene, uint64_t max_triangles) {
    FeatureSummaries s({}, scene.features.size() + 1);  // the scene is in memory: so are its summaries
    for (const Triangle& t : scene.triangles) s.add(t);
    ShardPlan plan;
    const Status st = planShards(std::move(s), scene.features.size(), max_triangles, {}, &plan);
    if (!st.ok()) throw std::runtime_error(st.error);  // only a failing temporary disk
    return plan;
}

namespace {

// A feature as the cut sees it; ordered by its coordinate along the axis
// being cut (`key`), ties by id, as subdivide.cpp's sortAlong orders.
struct CutItem {
    double key = 0;
    uint32_t id = 0;
    Vec3d point{0, 0, 0};
    double weight = 0;
    uint64_t count = 0;
    bool operator<(const CutItem& o) const { return key < o.key || (!(o.key < key) && id < o.id); }
};

// A group of features, written once and read in order: a WindowedRecords
// whose window is `memory_bytes` (core/windowed_records.h: beyond it the
// older items wait in a scratch file and come back a block at a time). Its
// triangles and its points' box are kept as it is written.
class Group {
public:
    Group(const std::filesystem::path& dir, size_t memory_bytes)
        : items_(dir, std::max<size_t>(1024, memory_bytes / sizeof(CutItem))) {}
    Status push(const CutItem& item) {
        triangles_ += item.count;
        box_.extend(item.point);
        items_.at(items_.size()) = item;
        return items_.status();
    }
    Status forEach(const std::function<void(const CutItem&)>& fn) {
        for (size_t i = 0; i < items_.size(); ++i) fn(items_.get(i));
        return items_.status();
    }
    uint64_t size() const { return items_.size(); }
    uint64_t triangles() const { return triangles_; }
    const Box3d& box() const { return box_; }
    void clear() {
        items_.clear();
        triangles_ = 0, box_ = {};
    }

private:
    WindowedRecords<CutItem> items_;
    uint64_t triangles_ = 0;
    Box3d box_;
};

// Where the cut works and with how much memory: its sorts take
// `sort_bytes`, a group keeps `group_bytes` in memory (a few groups are
// alive at a time: the node's, its halves and quarters, and the quarters
// waiting at each level above).
struct CutMemory {
    std::filesystem::path dir;
    size_t sort_bytes;
    size_t group_bytes;
    Group group() const { return Group(dir, group_bytes); }
};

double coordinate(const Vec3d& p, int axis) { return axis == 0 ? p.x : axis == 1 ? p.y : p.z; }

// `in` sorted along `axis` and cut in two non-empty parts with the first
// one's weight as close as possible to half the total (subdivide.cpp's
// balancedCut: the total summed in sorted order; all-zero weights count
// items). `in` is consumed.
Status cutAlong(Group& in, int axis, const CutMemory& memory, Group* low, Group* high) {
    ExternalSorter<CutItem> sorter(memory.dir, memory.sort_bytes);
    Status pushed;
    if (Status s = in.forEach([&](const CutItem& item) {
            CutItem keyed = item;
            keyed.key = coordinate(item.point, axis);
            if (pushed.ok()) pushed = sorter.push(keyed);
        });
        !s.ok())
        return s;
    if (!pushed.ok()) return pushed;
    in.clear();
    Group sorted = memory.group();
    double total = 0;
    if (Status s = sorter.forEachSorted([&](const CutItem& item) {
            total += item.weight;
            if (pushed.ok()) pushed = sorted.push(item);
        });
        !s.ok())
        return s;
    if (!pushed.ok()) return pushed;
    const uint64_t n = sorted.size();
    const bool by_count = !(total > 0);
    if (by_count) total = static_cast<double>(n);
    double run = 0, best_gap = 1e300;
    uint64_t best = 1, k = 0;
    if (Status s = sorted.forEach([&](const CutItem& item) {
            if (++k >= n) return;  // a cut after item k - 1 leaves items k.. on the other side
            run += by_count ? 1.0 : item.weight;
            const double gap = std::abs(run - 0.5 * total);
            if (gap < best_gap) best_gap = gap, best = k;
        });
        !s.ok())
        return s;
    k = 0;
    if (Status s = sorted.forEach([&](const CutItem& item) {
            if (pushed.ok()) pushed = (k++ < best ? low : high)->push(item);
        });
        !s.ok())
        return s;
    return pushed;
}

// subdivide.cpp's splitAlong on a group: cut along the longest axis of its
// box, then each half (of two or more) along the second longest.
Status splitInFour(Group& in, const CutMemory& memory, std::array<Group, 4>* groups) {
    const Box3d box = in.box();
    const std::array<double, 3> extent{box.max.x - box.min.x, box.max.y - box.min.y, box.max.z - box.min.z};
    std::array<int, 3> axes{0, 1, 2};
    std::stable_sort(axes.begin(), axes.end(), [&](int a, int b) { return extent[a] > extent[b]; });
    std::array<Group, 2> halves{memory.group(), memory.group()};
    if (Status s = cutAlong(in, axes[0], memory, &halves[0], &halves[1]); !s.ok()) return s;
    for (int h = 0; h < 2; ++h) {
        Group& half = halves[h];
        if (half.size() >= 2) {
            if (Status s = cutAlong(half, axes[1], memory, &(*groups)[h], &(*groups)[h + 2]); !s.ok()) return s;
            continue;
        }
        Status pushed;
        if (Status s = half.forEach([&](const CutItem& item) { pushed = (*groups)[h].push(item); }); !s.ok()) return s;
        if (!pushed.ok()) return pushed;
    }
    return Status::Ok();
}

}  // namespace

Status planShards(FeatureSummaries&& summaries, size_t features, uint64_t max_triangles,
                  const std::filesystem::path& scratch_dir, ShardPlan* out, size_t memory_bytes) {
    ShardPlan& plan = *out;
    plan = {};
    const size_t nf = features;
    const CutMemory memory{scratch_dir, memory_bytes, memory_bytes / 8};
    Group all = memory.group();
    for (size_t f = 0; f < nf; ++f) {
        const FeatureSummary s = summaries.records.get(f);
        if (s.count == 0) continue;
        if (Status st = all.push({0, static_cast<uint32_t>(f), (1.0 / s.area) * s.point, s.weight, s.count}); !st.ok())
            return st;
    }
    if (Status st = summaries.records.status(); !st.ok()) return st;
    summaries.records.clear();
    plan.shard_of_feature.assign(nf, -1);
    std::function<Status(Group&, int32_t, int, int32_t*)> cut = [&](Group& group, int32_t parent, int level,
                                                                    int32_t* made) {
        const auto id = static_cast<int32_t>(plan.nodes.size());
        *made = id;
        plan.nodes.push_back({parent, {-1, -1, -1, -1}, level, -1});
        if (group.triangles() <= max_triangles || group.size() < 2) {
            const auto shard = static_cast<int32_t>(plan.shard_triangles.size());
            plan.nodes[static_cast<size_t>(id)].shard = shard;
            plan.shard_triangles.push_back(group.triangles());
            return group.forEach([&](const CutItem& item) { plan.shard_of_feature[item.id] = shard; });
        }
        std::array<Group, 4> groups{memory.group(), memory.group(), memory.group(), memory.group()};
        if (Status s = splitInFour(group, memory, &groups); !s.ok()) return s;
        for (size_t q = 0; q < 4; ++q) {
            if (groups[q].size() == 0) continue;
            int32_t c = -1;
            if (Status s = cut(groups[q], id, level + 1, &c); !s.ok()) return s;
            groups[q].clear();
            plan.nodes[static_cast<size_t>(id)].children[q] = c;
        }
        return Status::Ok();
    };
    int32_t root = -1;
    return cut(all, -1, 0, &root);
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
