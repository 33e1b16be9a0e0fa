// SPDX-License-Identifier: GPL-3.0-or-later
#include "tiles/node_blockmaps.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <fmt/format.h>

#include "atlas/blockmap.h"
#include "format/blockmap.h"
#include "format/dds.h"
#include "tiles/blockmap_writer.h"
#include "tiles/tileset.h"

namespace cityatlas::tiles {
namespace fs = std::filesystem;

std::string_view blockMapModeName(BlockMapMode mode) { return mode == BlockMapMode::Complement ? "complement" : "off"; }

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

}  // namespace

Status writeNodeBlockMaps(const Scene& scene, const atlas::AtlasTree& tree, std::span<const NodeCost> costs,
                          BcQuality quality, size_t cache_mb, const fs::path& out_dir, const BlockMapProgressFn& progress,
                          std::vector<std::optional<format::BlockMapEntry>>* entries, NodeBlockMapStats* stats) {
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
    const double ppm = tree.projection.pixelsPerMetreAt1m();

    std::vector<int32_t> queue{0};  // top-down, breadth first: a branch stops at its first "no"
    std::vector<uint32_t> features;
    std::vector<Triangle> triangles;
    for (size_t q = 0; q < queue.size(); ++q) {
        if (progress) progress(q, queue.size());
        const int32_t id = queue[q];
        const atlas::AtlasNode& node = tree.nodes[static_cast<size_t>(id)];
        ++stats->tried;
        auto lap = std::chrono::steady_clock::now();
        auto split = [&lap](double* into) {
            const auto now = std::chrono::steady_clock::now();
            *into += std::chrono::duration<double>(now - lap).count();
            lap = now;
        };
        // Passes 1 and 2: the buildings and their planes.
        gatherNode(tree, node, by_feature, &features, &triangles);
        if (triangles.empty()) continue;
        atlas::BlockMapParams params;
        params.cell_m = node.min_distance_m / ppm;
        // The roof's BC1 plane alone (half a byte a cell, stored as it is) is a
        // lower bound of the file: a grid too fine to pay is declined unbuilt.
        if (roofBytesAtLeast(triangles, params.cell_m) > costs[static_cast<size_t>(id)].bytes &&
            !costs[static_cast<size_t>(id)].dropped) {
            ++stats->declined_bytes;
            continue;
        }
        format::BlockMap bm;
        // A grid beyond the file's limits is refused before any memory is asked for.
        const Status planes = atlas::buildBlockMap(triangles, params, &bm);
        split(&stats->seconds_planes);
        if (!planes.ok()) {
            if (planes.code != StatusCode::kUnsupported) return planes.within(fmt::format("node {}: ", id));
            ++stats->declined_grid;
            continue;
        }
        // Pass 3: the rule, on the file's size (known before the colours: BC1's follows the image's).
        if (!blockMapPays(blockMapFileSize(bm, true), costs[static_cast<size_t>(id)])) {
            ++stats->declined_bytes;
            continue;
        }
        // Passes 4 and 5: colours, the file.
        atlas::BlockMapColourStats colour;
        atlas::colourBlockMap(triangles, surfaces, &bm, &colour);
        stats->unreadable_samples += colour.unreadable_samples;
        split(&stats->seconds_colours);
        const std::vector<uint8_t> bytes = blockMapFileBytes(bm, quality);
        split(&stats->seconds_encode);
        // Pass 6: the measured error, over the buildings it holds and the ones it misses alike.
        const atlas::BlockMapError error = atlas::measureBlockMapError(triangles, bm);
        split(&stats->seconds_error);
        format::BlockMapEntry e;
        e.file = {fmt::format("blockmap/{}.bin", id), bytes.size()};
        if (stats->built == 0) {  // the folder only when there is a BlockMap to put in it
            std::error_code ec;
            fs::create_directories(out_dir / "blockmap", ec);
            if (ec) return Status::Io(fmt::format("{}: cannot create: {}", (out_dir / "blockmap").string(), ec.message()));
        }
        if (Status s = writeBytes(out_dir / e.file.uri, bytes.data(), bytes.size()); !s.ok()) return s;
        split(&stats->seconds_encode);
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
        ++stats->built;
        stats->bytes += e.file.bytes;
        stats->gpu_bytes += e.gpu_bytes;
        (*entries)[static_cast<size_t>(id)] = std::move(e);
        for (const int32_t c : node.children)
            if (c >= 0) queue.push_back(c);
    }
    if (progress) progress(queue.size(), queue.size());
    stats->seconds = secondsSince(t0);
    return Status::Ok();
}

}  // namespace cityatlas::tiles
