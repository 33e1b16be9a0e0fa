// SPDX-License-Identifier: GPL-3.0-or-later
#include "tiles/node_blockmaps.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include "atlas/blockmap.h"
#include "format/blockmap.h"
#include "format/dds.h"
#include "tiles/blockmap_writer.h"
#include "tiles/tileset.h"

namespace cityatlas::tiles {
namespace fs = std::filesystem;

std::string_view blockMapModeName(BlockMapMode mode) {
    switch (mode) {
        case BlockMapMode::Complement: return "complement";
        case BlockMapMode::Replace: return "replace";
        case BlockMapMode::Off: break;
    }
    return "off";
}

int replacedLevels(const atlas::AtlasTree& tree, std::span<const std::optional<format::BlockMapEntry>> entries) {
    // The shallowest level holding a node that keeps its geometry (a leaf, or no BlockMap) ends the run.
    int first_kept = std::numeric_limits<int>::max();
    for (size_t i = 0; i < tree.nodes.size(); ++i)
        if (tree.nodes[i].leaf() || i >= entries.size() || !entries[i]) first_kept = std::min(first_kept, tree.nodes[i].level);
    return first_kept == std::numeric_limits<int>::max() ? -1 : first_kept - 1;
}

bool blockMapPays(uint64_t blockmap_bytes, const NodeCost& node) { return node.dropped || blockmap_bytes <= node.bytes; }

namespace {

/// The tree's triangles by feature (CSR): a node's BlockMap takes its
/// buildings in full, wherever the cuts put their triangles.
struct TrianglesByFeature {
    std::vector<uint32_t> first;  ///< per feature + 1
    std::vector<uint32_t> order;  ///< tree triangle indices, grouped by feature

    explicit TrianglesByFeature(const atlas::AtlasTree& tree, size_t features) : first(features + 1, 0) {
        for (const atlas::TreeTriangle& t : tree.triangles) ++first[t.tri.feature + 1];
        for (size_t f = 0; f < features; ++f) first[f + 1] += first[f];
        order.resize(tree.triangles.size());
        std::vector<uint32_t> next(first.begin(), first.end() - 1);
        for (size_t i = 0; i < tree.triangles.size(); ++i) order[next[tree.triangles[i].tri.feature]++] = static_cast<uint32_t>(i);
    }
};

/// Pass 1: the node's buildings (ascending) and their triangles, in full.
void gatherNode(const atlas::AtlasTree& tree, const atlas::AtlasNode& node, const TrianglesByFeature& by_feature,
                std::vector<uint32_t>* features, std::vector<Triangle>* triangles) {
    features->clear();
    for (const atlas::NodeLayer& layer : node.layers)
        for (uint32_t i = layer.range.first; i < layer.range.first + layer.range.count; ++i)
            features->push_back(tree.triangles[i].tri.feature);
    std::sort(features->begin(), features->end());
    features->erase(std::unique(features->begin(), features->end()), features->end());
    triangles->clear();
    for (const uint32_t f : *features)
        for (uint32_t k = by_feature.first[f]; k < by_feature.first[f + 1]; ++k)
            triangles->push_back(tree.triangles[by_feature.order[k]].tri);
}

// The BC1 roof plane's bytes of the grid buildBlockMap lays over `triangles`
// (format/dds.h); saturates for grids no file could hold.
uint64_t roofBytesAtLeast(const std::vector<Triangle>& triangles, double cell_m) {
    const auto [nx, ny] = atlas::blockMapGridSize(triangles, cell_m);
    if (!(nx * ny <= static_cast<double>(format::kBlockMapMaxCells))) return UINT64_MAX;
    return format::bcBlockBytes(std::max(1, static_cast<int>(nx)), std::max(1, static_cast<int>(ny)), 3);
}

double secondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// What one node's turn gave: its entry, or why none, and the seconds by pass.
struct NodeOutcome {
    std::optional<format::BlockMapEntry> entry;
    bool declined_bytes = false, declined_grid = false;
    uint64_t unreadable_samples = 0;
    double seconds_planes = 0, seconds_colours = 0, seconds_error = 0, seconds_encode = 0;
    Status status = Status::Ok();
};

/// The passes for one node (the file comment's list).
NodeOutcome buildNodeBlockMap(const atlas::AtlasTree& tree, int32_t id, const NodeCost& cost,
                              const TrianglesByFeature& by_feature, const atlas::SurfaceTables& surfaces,
                              atlas::BlockMapSample sample, BcQuality quality, const fs::path& out_dir) {
    NodeOutcome out;
    const atlas::AtlasNode& node = tree.nodes[static_cast<size_t>(id)];
    auto lap = std::chrono::steady_clock::now();
    auto split = [&lap](double* into) {
        const auto now = std::chrono::steady_clock::now();
        *into += std::chrono::duration<double>(now - lap).count();
        lap = now;
    };
    // Passes 1 and 2: the buildings and their planes.
    std::vector<uint32_t> features;
    std::vector<Triangle> triangles;
    gatherNode(tree, node, by_feature, &features, &triangles);
    if (triangles.empty()) return out;
    atlas::BlockMapParams params;
    params.cell_m = node.min_distance_m / tree.projection.pixelsPerMetreAt1m();
    params.sample = sample;
    // The roof's BC1 plane alone (half a byte a cell, stored as it is) is a
    // lower bound of the file: a grid too fine to pay is declined unbuilt.
    if (roofBytesAtLeast(triangles, params.cell_m) > cost.bytes && !cost.dropped) {
        out.declined_bytes = true;
        return out;
    }
    format::BlockMap bm;
    // A grid beyond the file's limits is refused before any memory is asked for.
    const Status planes = atlas::buildBlockMap(triangles, params, &bm);
    split(&out.seconds_planes);
    if (!planes.ok()) {
        if (planes.code != StatusCode::kUnsupported) out.status = planes.within(fmt::format("node {}: ", id));
        out.declined_grid = planes.code == StatusCode::kUnsupported;
        return out;
    }
    // Pass 3: the rule, on the file's size (known before the colours: BC1's follows the image's).
    if (!blockMapPays(blockMapFileSize(bm, true), cost)) {
        out.declined_bytes = true;
        return out;
    }
    // Passes 4 and 5: colours, the file.
    atlas::BlockMapColourStats colour;
    atlas::colourBlockMap(triangles, surfaces, &bm, &colour);
    out.unreadable_samples = colour.unreadable_samples;
    split(&out.seconds_colours);
    const std::vector<uint8_t> bytes = blockMapFileBytes(bm, quality);
    split(&out.seconds_encode);
    // Pass 6: the measured error, over the buildings it holds and the ones it misses alike.
    const atlas::BlockMapError error = atlas::measureBlockMapError(triangles, bm);
    split(&out.seconds_error);
    format::BlockMapEntry e;
    e.file = {fmt::format("blockmap/{}.bin", id), bytes.size()};
    std::error_code ec;
    fs::create_directories(out_dir / "blockmap", ec);  // only when there is a BlockMap to put in it
    if (ec) {
        out.status = Status::Io(fmt::format("{}: cannot create: {}", (out_dir / "blockmap").string(), ec.message()));
        return out;
    }
    if (Status s = writeBytes(out_dir / e.file.uri, bytes.data(), bytes.size()); !s.ok()) {
        out.status = s;
        return out;
    }
    split(&out.seconds_encode);
    e.gpu_bytes = bm.gpuBytes(!bm.roof.empty());
    e.grid = {bm.nx, bm.ny};
    e.texel_m = bm.cell_m;
    e.origin = bm.origin;
    e.z_top_m = bm.z_hi;
    e.columns = bm.columns.size();
    e.wall_px = {bm.wall_width, bm.wall_height};
    e.hausdorff_m = error.hausdorff_m;
    const double quantum = (bm.z_hi - bm.origin.z) / 65535.0;
    e.voxel_bound_m = 0.5 * std::sqrt(2.0 * bm.cell_m * bm.cell_m + quantum * quantum);
    e.min_distance_m = node.min_distance_m;
    e.features = bm.features.size();
    std::vector<uint32_t> held(bm.features.begin(), bm.features.end());
    std::sort(held.begin(), held.end());
    std::set_difference(features.begin(), features.end(), held.begin(), held.end(),
                        std::back_inserter(e.features_missing));
    out.entry = std::move(e);
    return out;
}

}  // namespace

Status writeNodeBlockMaps(const Scene& scene, const atlas::AtlasTree& tree, std::span<const NodeCost> costs,
                          int max_level, atlas::BlockMapSample sample, BcQuality quality, size_t cache_mb,
                          const fs::path& out_dir,
                          const BlockMapProgressFn& progress, std::vector<std::optional<format::BlockMapEntry>>* entries,
                          NodeBlockMapStats* stats) {
    const auto t0 = std::chrono::steady_clock::now();
    entries->assign(tree.nodes.size(), std::nullopt);
    *stats = {};
    if (tree.nodes.empty()) return Status::Ok();
    if (costs.size() != tree.nodes.size()) return Status::Io("blockmaps: node costs do not match the tree");
    const TrianglesByFeature by_feature(tree, scene.features.size());
    // Reduced textures are kept for every BlockMap of the build: the upper
    // nodes' samples read small mip levels, each texture decoded once.
    const std::shared_ptr<atlas::ReducedTextures> reduced = atlas::makeReducedTextures(scene.textures.size());
    const atlas::SurfaceTables surfaces{scene.textures, scene.materials, cache_mb, reduced.get()};

    // Top-down, a level at a time: a branch stops at its first "no".
    std::vector<int32_t> level_nodes{0};
    uint64_t done = 0, queued = 1;
    for (int level = 0; !level_nodes.empty() && (max_level < 0 || level <= max_level); ++level) {
        const auto level_start = std::chrono::steady_clock::now();
        std::vector<NodeOutcome> outcomes(level_nodes.size());
        tbb::parallel_for(size_t{0}, level_nodes.size(), [&](size_t k) {
            const auto id = static_cast<size_t>(level_nodes[k]);
            outcomes[k] = buildNodeBlockMap(tree, level_nodes[k], costs[id], by_feature, surfaces, sample, quality,
                                            out_dir);
        });
        BlockMapLevelStats& ls = stats->levels.emplace_back();
        ls.seconds = secondsSince(level_start);
        std::vector<int32_t> next;
        for (size_t k = 0; k < level_nodes.size(); ++k) {
            NodeOutcome& o = outcomes[k];
            if (!o.status.ok()) return o.status;
            const auto id = static_cast<size_t>(level_nodes[k]);
            ++stats->tried;
            ++ls.tried;
            stats->declined_bytes += o.declined_bytes;
            stats->declined_grid += o.declined_grid;
            stats->unreadable_samples += o.unreadable_samples;
            stats->seconds_planes += o.seconds_planes;
            stats->seconds_colours += o.seconds_colours;
            stats->seconds_error += o.seconds_error;
            stats->seconds_encode += o.seconds_encode;
            if (!o.entry) continue;
            ++stats->built;
            ++ls.built;
            stats->bytes += o.entry->file.bytes;
            stats->gpu_bytes += o.entry->gpu_bytes;
            ls.bytes += o.entry->file.bytes;
            ls.node_bytes += costs[id].bytes;
            ls.worst_hausdorff_m = std::max(ls.worst_hausdorff_m, o.entry->hausdorff_m);
            ls.missing += o.entry->features_missing.size();
            (*entries)[id] = std::move(o.entry);
            for (const int32_t c : tree.nodes[id].children)
                if (c >= 0) next.push_back(c);
        }
        done += level_nodes.size();
        queued += next.size();
        if (progress) progress(done, queued);
        level_nodes = std::move(next);
    }
    if (progress) progress(done, done);
    stats->seconds = secondsSince(t0);
    return Status::Ok();
}

}  // namespace cityatlas::tiles
