// SPDX-License-Identifier: GPL-3.0-or-later
#include "format/tileset_index.h"
#include "format/tileset_document.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace cityatlas::format {
namespace {

BlockId addBlock(TilesetIndex& index, BlockInfo info) {
    index.bytes_total += info.bytes;
    index.bytes_by_kind[static_cast<int>(info.kind)] += info.bytes;
    index.blocks.push_back(std::move(info));
    return static_cast<BlockId>(index.blocks.size() - 1);
}

// Axis-aligned half axes, as the writer gives them; an oriented box gets its axis-aligned hull.
Box3d boundsOf(const std::array<double, 12>& v) {
    const Vec3d c{v[0], v[1], v[2]};
    const Vec3d h{std::abs(v[3]) + std::abs(v[6]) + std::abs(v[9]), std::abs(v[4]) + std::abs(v[7]) + std::abs(v[10]),
                  std::abs(v[5]) + std::abs(v[8]) + std::abs(v[11])};
    Box3d b;
    b.min = c - h;
    b.max = c + h;
    return b;
}

BuildInfo buildOf(const BuildEntry& e) {
    BuildInfo b;
    b.d_min_m = e.d_min_m;
    b.atlas_size_px = e.atlas_size_px;
    b.screen_width_px = e.screen_width_px;
    b.screen_height_px = e.screen_height_px;
    b.vertical_fov_deg = e.vertical_fov_deg;
    b.focal_px = e.focal_px;
    b.corner_factor = e.corner_factor;
    b.tau = e.tau;
    return b;
}

// The client's index of a document: the same tree, every file a block
// (texture blocks first, then per node in preorder its layers' geometry and atlas).
TilesetIndex indexOf(const TilesetDocument& doc) {
    TilesetIndex index;
    index.tileset_version = doc.tileset_version;
    index.build = buildOf(doc.build);
    index.local_to_ecef = doc.georeference.local_to_ecef;
    index.source_crs = doc.georeference.source_crs;
    for (const MaterialEntry& m : doc.materials)
        index.materials.push_back({{static_cast<float>(m.diffuse[0]), static_cast<float>(m.diffuse[1]),
                                    static_cast<float>(m.diffuse[2])},
                                   static_cast<float>(m.transparency)});
    for (size_t k = 0; k < doc.texture_blocks.size(); ++k)
        index.texture_block_ids.push_back(addBlock(index, {BlockKind::Textures, -1, -1, static_cast<int32_t>(k),
                                                           doc.texture_blocks[k].uri, doc.texture_blocks[k].bytes}));
    for (const TextureEntry& t : doc.textures)
        index.textures.push_back({t.block, t.offset, t.bytes, t.width, t.height, t.format == "BC3" ? 4 : 3, t.mips,
                                  t.wrap != "clamp"});
    for (const ComputedTextureEntry& c : doc.computed) index.computed.push_back(c.name);
    index.feature_count = doc.feature_count;
    index.feature_block_size = static_cast<int>(doc.feature_block_size);
    for (size_t k = 0; k < doc.feature_tables.size(); ++k) {
        const FileEntry& f = doc.feature_tables[k];
        FeatureTableInfo t{f.uri, f.bytes, {}, 0};
        if (k < doc.feature_bounds.size()) t.bounds_uri = doc.feature_bounds[k].uri, t.bounds_bytes = doc.feature_bounds[k].bytes;
        index.feature_tables.push_back(std::move(t));
    }
    index.nodes.resize(doc.tiles.size());
    for (size_t i = 0; i < doc.tiles.size(); ++i) {
        const TileEntry& e = doc.tiles[i];
        TileNode& n = index.nodes[i];
        n.id = static_cast<int32_t>(i);
        n.parent = e.parent;
        n.level = e.parent < 0 ? 0 : index.nodes[static_cast<size_t>(e.parent)].level + 1;  // preorder: parent first
        n.children = e.children;
        n.bounds = boundsOf(e.box);
        n.centre = e.centre;
        n.min_distance_m = e.min_distance_m;
        n.world_texel_m = e.world_texel_m;
        n.features = e.feature_count;
        for (int li = 0; li < kLayerCount; ++li) {
            const auto& l = e.layers[static_cast<size_t>(li)];
            if (!l) continue;
            NodeLayer& nl = n.layers[static_cast<size_t>(li)];
            nl.present = true;
            nl.triangles = static_cast<uint32_t>(l->triangles);
            nl.geometric_error_m = l->geometric_error_m;
            nl.position_error_mm = l->position_error_mm;
            nl.geometry = addBlock(index, {BlockKind::Geometry, n.id, li, -1, l->geometry.uri, l->geometry.bytes});
            if (l->atlas) {
                nl.atlas = addBlock(index, {BlockKind::Atlas, n.id, li, -1, l->atlas->file.uri, l->atlas->file.bytes});
                nl.atlas_width_px = l->atlas->width_px;
                nl.atlas_height_px = l->atlas->height_px;
                nl.atlas_channels = l->atlas->format == "BC3" ? 4 : 3;
            }
            nl.computed.assign(doc.computed.size(), kNoBlock);
            for (size_t k = 0; k < l->computed.size() && k < doc.computed.size(); ++k)
                if (!l->computed[k].file.uri.empty())
                    nl.computed[k] = addBlock(index, {BlockKind::Computed, n.id, li, static_cast<int32_t>(k),
                                                      l->computed[k].file.uri, l->computed[k].file.bytes});
        }
        for (const int64_t b : e.texture_blocks) n.texture_blocks.push_back(index.texture_block_ids[static_cast<size_t>(b)]);
        if (e.blockmap) {
            const BlockMapEntry& bm = *e.blockmap;
            n.blockmap = addBlock(index, {BlockKind::BlockMap, n.id, -1, -1, bm.file.uri, bm.file.bytes});
            n.blockmap_min_distance_m = bm.min_distance_m;
            n.blockmap_bounds.extend(bm.origin);
            n.blockmap_bounds.extend({bm.origin.x + static_cast<double>(bm.grid[0]) * bm.texel_m,
                                      bm.origin.y + static_cast<double>(bm.grid[1]) * bm.texel_m, bm.z_top_m});
            n.blockmap_only = std::none_of(n.layers.begin(), n.layers.end(), [](const NodeLayer& l) { return l.present; });
        }
        index.depth = std::max(index.depth, n.level);
    }
    return index;
}

}  // namespace

const char* layerName(int layer) { return layer == 1 ? "alpha" : "opaque"; }

const char* blockKindName(BlockKind kind) {
    switch (kind) {
        case BlockKind::Geometry: return "geometry";
        case BlockKind::Atlas: return "atlas";
        case BlockKind::Textures: return "textures";
        case BlockKind::Computed: return "computed";
        case BlockKind::BlockMap: return "blockmap";
    }
    return "?";
}

Status parseTilesetIndex(const std::string& text, const std::string& where, TilesetIndex* out) {
    *out = TilesetIndex{};
    TilesetDocument doc;
    if (Status st = readTilesetDocument(text, where, &doc); !st.ok()) return st;
    // A node without geometry is one `--blockmaps replace` left to its
    // BlockMap: it has one, and children to draw closer than its distance.
    for (size_t i = 0; i < doc.tiles.size(); ++i) {
        const TileEntry& t = doc.tiles[i];
        if (t.layers[0] || t.layers[1]) continue;
        if (doc.build.blockmaps != "replace")
            return Status::Invalid(fmt::format("{}: node {}: {} no geometry", where, i, i == 0 ? "the root has" : "has"));
        if (!t.blockmap || t.leaf())
            return Status::Invalid(fmt::format("{}: node {}: no geometry, and {}", where, i,
                                               t.blockmap ? "no children to draw closer than its BlockMap's distance"
                                                          : "no BlockMap to stand for it (build --blockmaps replace)"));
    }
    *out = indexOf(doc);
    return Status::Ok();
}

}  // namespace cityatlas::format
