// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// A sharded build's tree (cli/shards.h): the top levels fixed by a plan,
/// subtrees ("shards") built independently, then assembled.
///
/// The plan makes the area-balanced cuts of papers/000 §4.5.3 at the top of
/// the tree over whole features (a building never straddles two shards; its
/// weight is its textured area, its point the area-weighted centroid of its
/// triangles) until each group holds at most `max_triangles` triangles; each
/// such group is a shard, the root of a subtree that buildAtlasTree builds on
/// its own with the plan's GlobalDecisions. The nodes above the shards (the
/// "top") are inner nodes of the whole tree like any other: their atlases are
/// their children's halved and placed, their geometry their children's merged.
///
/// With one shard (any input of at most `max_triangles` triangles) the plan
/// has no top: the shard is the whole tree.

#include <array>
#include <cstdint>
#include <filesystem>
#include <vector>

#include "atlas/atlas_tree.h"
#include "core/status.h"
#include "core/windowed_records.h"
#include "ingest/scene.h"

namespace cityatlas::atlas {

struct PlanNode {
    int32_t parent = -1;
    std::array<int32_t, 4> children{-1, -1, -1, -1};  ///< plan nodes, by quadrant
    int level = 0;
    int32_t shard = -1;  ///< >= 0: this node is that shard's root (and a leaf of the plan)
};

struct ShardPlan {
    std::vector<PlanNode> nodes;                ///< depth-first preorder; nodes[0] is the root
    std::vector<int32_t> shard_of_feature;      ///< per scene feature; -1: the feature has no triangles
    std::vector<uint64_t> shard_triangles;      ///< per shard
    size_t shards() const { return shard_triangles.size(); }
};

/// What the plan needs of a feature, gathered one triangle at a time.
struct FeatureSummary {
    uint64_t count = 0;       ///< triangles
    double weight = 0;        ///< textured area (the cut's weight)
    double area = 0;          ///< all area (zero-area triangles a little)
    Vec3d point{0, 0, 0};     ///< area-weighted sum of triangle centroids
};
static_assert(sizeof(FeatureSummary) == 48);

/// Every feature's summary: the newest features' in memory while their
/// triangles come, older ones in a scratch file in `scratch_dir`
/// (core/windowed_records.h), so a city's worth is never held.
struct FeatureSummaries {
    explicit FeatureSummaries(std::filesystem::path scratch_dir = {}, size_t window = size_t{1} << 16)
        : records(std::move(scratch_dir), window) {}
    WindowedRecords<FeatureSummary> records;
    void add(const Triangle& t);
};

/// Cuts `scene` into shards of at most `max_triangles` triangles (a single
/// feature larger than that is a shard of its own). Deterministic.
ShardPlan planShards(const Scene& scene, uint64_t max_triangles);
/// The same from the summaries of `features` features (freed as the cut
/// starts). The cut works on disk, in `scratch_dir`: a group of features is
/// sorted along an axis with core/external_sort.h and cut where its running
/// weight is closest to half, as atlas/subdivide.h's splitIntoFourAt cuts
/// points in memory (the same groups, bit for bit), so its memory is a few
/// tens of MB (`memory_bytes` for its sorts, an eighth of that for each
/// group of features it holds) and 4 bytes a feature (the result's
/// shard_of_feature) whatever the city. An error only when the scratch disk fails.
Status planShards(FeatureSummaries&& summaries, size_t features, uint64_t max_triangles,
                  const std::filesystem::path& scratch_dir, ShardPlan* out, size_t memory_bytes = size_t{32} << 20);

/// The whole tree from the plan's top and the shards' trees (each numbered
/// from 0 at its root, with levels from 0, without triangles): nodes in
/// depth-first preorder of the whole tree, levels from its root, the top's
/// nodes made as buildAtlasTree makes inner nodes (bounds, distances, atlas
/// paths), then every atlas placed again (placement.h: the shards' sizes come
/// out as they were, the offsets become the whole tree's). `shard_root` gets
/// each shard's root id in the result; `built` marks the shards' nodes.
/// Stats: the nodes, leaves and depth of the whole tree; the rest as the
/// caller sums them.
void assembleTree(const ShardPlan& plan, const std::vector<AtlasTree>& shards, const AtlasParams& params,
                  AtlasTree* out, std::vector<int32_t>* shard_root, std::vector<uint8_t>* built);

}  // namespace cityatlas::atlas
