// SPDX-License-Identifier: GPL-3.0-or-later
#include "format/tileset_index.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace cityatlas::format {
namespace {
using nlohmann::json;

// Thrown inside the parser only; parseTilesetIndex turns it into a Status.
struct ParseError {
    std::string message;
};

[[noreturn]] void fail(const std::string& message) { throw ParseError{message}; }

const json& member(const json& object, const char* key, const std::string& where) {
    if (!object.is_object()) fail(fmt::format("{}: not an object", where));
    const auto it = object.find(key);
    if (it == object.end()) fail(fmt::format("{}: \"{}\" missing", where, key));
    return *it;
}

double number(const json& object, const char* key, const std::string& where) {
    const json& v = member(object, key, where);
    if (!v.is_number() || !std::isfinite(v.get<double>())) fail(fmt::format("{}: \"{}\" is not a finite number", where, key));
    return v.get<double>();
}

int64_t integer(const json& object, const char* key, const std::string& where, int64_t lo, int64_t hi) {
    const json& v = member(object, key, where);
    if (!v.is_number_integer()) fail(fmt::format("{}: \"{}\" is not an integer", where, key));
    const auto i = v.get<int64_t>();
    if (i < lo || i > hi) fail(fmt::format("{}: \"{}\" = {} outside [{}, {}]", where, key, i, lo, hi));
    return i;
}

std::string uri(const json& object, const std::string& where) {
    const json& v = member(object, "uri", where);
    if (!v.is_string() || v.get<std::string>().empty()) fail(fmt::format("{}: \"uri\" is not a non-empty string", where));
    const std::string u = v.get<std::string>();
    // Relative and inside the folder: the client joins it to a base path or URL.
    if (u.front() == '/' || u.find("..") != std::string::npos || u.find("://") != std::string::npos ||
        u.find('\\') != std::string::npos)
        fail(fmt::format("{}: uri \"{}\" is not a relative path inside the folder", where, u));
    return u;
}

BlockId addBlock(TilesetIndex& index, BlockInfo info) {
    index.bytes_total += info.bytes;
    index.bytes_by_kind[static_cast<int>(info.kind)] += info.bytes;
    index.blocks.push_back(std::move(info));
    return static_cast<BlockId>(index.blocks.size() - 1);
}

void parseBuild(const json& build, BuildInfo* b) {
    const std::string w = "extras.cityatlas.build";
    b->d_min_m = number(build, "d_min_m", w);
    b->atlas_size_px = static_cast<int>(integer(build, "atlas_size_px", w, 1, 1 << 16));
    b->screen_width_px = static_cast<int>(integer(build, "screen_width_px", w, 1, 1 << 20));
    b->screen_height_px = static_cast<int>(integer(build, "screen_height_px", w, 1, 1 << 20));
    b->vertical_fov_deg = number(build, "vertical_fov_deg", w);
    b->focal_px = number(build, "focal_px", w);
    b->corner_factor = number(build, "corner_factor", w);
    b->tau = number(build, "tau", w);
    if (!(b->focal_px > 0) || !(b->corner_factor >= 1) || !(b->tau > 0))
        fail(w + ": focal_px and tau must be positive and corner_factor >= 1");
}

Box3d boxOf(const json& tile, const std::string& where) {
    const json& bv = member(tile, "boundingVolume", where);
    const json& box = member(bv, "box", where + ".boundingVolume");
    if (!box.is_array() || box.size() != 12) fail(where + ": boundingVolume.box is not 12 numbers");
    double v[12];
    for (size_t i = 0; i < 12; ++i) {
        if (!box[i].is_number()) fail(where + ": boundingVolume.box is not 12 numbers");
        v[i] = box[i].get<double>();
    }
    // Axis-aligned half axes, as the writer gives them; an oriented box gets its axis-aligned hull.
    const Vec3d c{v[0], v[1], v[2]};
    const Vec3d h{std::abs(v[3]) + std::abs(v[6]) + std::abs(v[9]), std::abs(v[4]) + std::abs(v[7]) + std::abs(v[10]),
                  std::abs(v[5]) + std::abs(v[8]) + std::abs(v[11])};
    Box3d b;
    b.min = c - h;
    b.max = c + h;
    return b;
}

void parseNode(const json& tile, int32_t parent, int level, TilesetIndex& index,
               std::vector<std::pair<int32_t, std::vector<int64_t>>>& leaf_blocks) {
    const auto id = static_cast<int32_t>(index.nodes.size());
    const std::string w = fmt::format("node {}", id);
    if (level > 64) fail(w + ": deeper than 64 levels");
    const json& ca = member(member(tile, "extras", w), "cityatlas", w + ".extras");
    if (integer(ca, "id", w, 0, INT32_MAX) != id) fail(w + ": extras.cityatlas.id is not the preorder index");
    index.nodes.emplace_back();
    {
        TileNode& n = index.nodes.back();
        n.id = id;
        n.parent = parent;
        n.level = level;
        n.bounds = boxOf(tile, w);
        n.min_distance_m = number(ca, "min_distance_m", w);
        n.world_texel_m = number(ca, "world_texel_m", w);
        const json& c = member(ca, "centre", w);
        if (!c.is_array() || c.size() != 3 || !c[0].is_number() || !c[1].is_number() || !c[2].is_number())
            fail(w + ": centre is not 3 numbers");
        n.centre = {c[0].get<double>(), c[1].get<double>(), c[2].get<double>()};
        if (const auto f = ca.find("features"); f != ca.end() && f->is_object())
            n.features = static_cast<uint64_t>(integer(*f, "count", w + ".features", 0, INT64_MAX));
    }
    const json& layers = member(ca, "layers", w);
    if (!layers.is_object()) fail(w + ": layers is not an object");
    for (int li = 0; li < kLayerCount; ++li) {
        const auto it = layers.find(layerName(li));
        if (it == layers.end()) continue;
        const std::string lw = fmt::format("{} layer {}", w, layerName(li));
        NodeLayer nl;
        nl.present = true;
        nl.triangles = static_cast<uint32_t>(integer(*it, "triangles", lw, 0, UINT32_MAX));
        nl.geometric_error_m = number(*it, "geometric_error_m", lw);
        nl.position_error_mm = number(*it, "position_error_mm", lw);
        const json& g = member(*it, "geometry", lw);
        nl.geometry = addBlock(index, {BlockKind::Geometry, id, li, -1, uri(g, lw + " geometry"),
                                       static_cast<uint64_t>(integer(g, "bytes", lw + " geometry", 1, INT64_MAX))});
        const json& a = member(*it, "atlas", lw);
        if (!a.is_null()) {
            nl.atlas = addBlock(index, {BlockKind::Atlas, id, li, -1, uri(a, lw + " atlas"),
                                        static_cast<uint64_t>(integer(a, "bytes", lw + " atlas", 1, INT64_MAX))});
            nl.atlas_width_px = static_cast<int>(integer(a, "width_px", lw + " atlas", 1, 1 << 16));
            nl.atlas_height_px = static_cast<int>(integer(a, "height_px", lw + " atlas", 1, 1 << 16));
            nl.atlas_channels = member(a, "format", lw + " atlas") == "BC3" ? 4 : 3;
        }
        index.nodes[static_cast<size_t>(id)].layers[static_cast<size_t>(li)] = nl;
    }
    std::vector<int64_t> blocks;
    if (const auto tb = ca.find("texture_blocks"); tb != ca.end()) {
        if (!tb->is_array()) fail(w + ": texture_blocks is not an array");
        for (const json& b : *tb) {
            if (!b.is_number_integer() || b.get<int64_t>() < 0) fail(w + ": texture_blocks holds a non-index");
            blocks.push_back(b.get<int64_t>());
        }
    }
    const auto children = tile.find("children");
    if (children != tile.end()) {
        if (!children->is_array()) fail(w + ": children is not an array");
        for (const json& child : *children) {
            const auto child_id = static_cast<int32_t>(index.nodes.size());
            index.nodes[static_cast<size_t>(id)].children.push_back(child_id);
            parseNode(child, id, level + 1, index, leaf_blocks);
        }
    }
    if (!blocks.empty()) {
        if (!index.nodes[static_cast<size_t>(id)].leaf()) fail(w + ": an inner node lists texture blocks");
        leaf_blocks.emplace_back(id, std::move(blocks));
    }
    index.depth = std::max(index.depth, level);
}

}  // namespace

const char* layerName(int layer) { return layer == 1 ? "alpha" : "opaque"; }

const char* blockKindName(BlockKind kind) {
    switch (kind) {
        case BlockKind::Geometry: return "geometry";
        case BlockKind::Atlas: return "atlas";
        case BlockKind::Textures: return "textures";
    }
    return "?";
}

Status parseTilesetIndex(const std::string& text, const std::string& where, TilesetIndex* out) {
    *out = TilesetIndex{};
    json doc;
    try {
        doc = json::parse(text);
    } catch (const json::parse_error& e) {
        return Status::Invalid(fmt::format("{}: not JSON (byte {}): {}", where, e.byte, e.what()));
    } catch (const json::exception& e) {  // out_of_range: a number beyond double (1e999)
        return Status::Invalid(fmt::format("{}: not JSON: {}", where, e.what()));
    }
    try {
        TilesetIndex& index = *out;
        const json& asset = member(doc, "asset", "tileset");
        if (const auto v = asset.find("tilesetVersion"); v != asset.end() && v->is_string()) index.tileset_version = *v;
        const json& ca = member(member(doc, "extras", "tileset"), "cityatlas", "tileset.extras");
        const int64_t format = integer(ca, "format_version", "extras.cityatlas", 0, INT32_MAX);
        if (format != 1) fail(fmt::format("extras.cityatlas.format_version {} is not 1 (this client reads 1)", format));
        parseBuild(member(ca, "build", "extras.cityatlas"), &index.build);

        const json& geo = member(ca, "georeference", "extras.cityatlas");
        if (const auto crs = geo.find("source_crs"); crs != geo.end() && crs->is_string()) index.source_crs = *crs;
        if (const auto m = geo.find("local_to_ecef"); m != geo.end() && !m->is_null()) {
            if (!m->is_array() || m->size() != 16) fail("extras.cityatlas.georeference.local_to_ecef is not 16 numbers");
            std::array<double, 16> a{};
            for (size_t i = 0; i < 16; ++i) a[i] = (*m)[i].get<double>();
            index.local_to_ecef = a;
        }

        for (const json& m : member(ca, "materials", "extras.cityatlas")) {
            MaterialInfo mi;
            const json& d = member(m, "diffuse", "material");
            for (size_t k = 0; k < 3 && k < d.size(); ++k) mi.diffuse[k] = d[k].get<float>();
            mi.transparency = static_cast<float>(number(m, "transparency", "material"));
            index.materials.push_back(mi);
        }

        const json& blocks = member(ca, "texture_blocks", "extras.cityatlas");
        if (!blocks.is_array()) fail("extras.cityatlas.texture_blocks is not an array");
        for (size_t k = 0; k < blocks.size(); ++k) {
            const std::string bw = fmt::format("texture block {}", k);
            index.texture_block_ids.push_back(addBlock(
                index, {BlockKind::Textures, -1, -1, static_cast<int32_t>(k), uri(blocks[k], bw),
                        static_cast<uint64_t>(integer(blocks[k], "bytes", bw, 1, INT64_MAX))}));
        }
        const json& textures = member(ca, "textures", "extras.cityatlas");
        if (!textures.is_array()) fail("extras.cityatlas.textures is not an array");
        for (size_t t = 0; t < textures.size(); ++t) {
            const std::string tw = fmt::format("texture {}", t);
            TextureInfo ti;
            ti.block = static_cast<int32_t>(integer(textures[t], "block", tw, -1, static_cast<int64_t>(blocks.size()) - 1));
            ti.offset = static_cast<uint64_t>(integer(textures[t], "offset", tw, 0, INT64_MAX));
            ti.bytes = static_cast<uint64_t>(integer(textures[t], "bytes", tw, 0, INT64_MAX));
            ti.width = static_cast<int>(integer(textures[t], "width", tw, 1, 1 << 16));
            ti.height = static_cast<int>(integer(textures[t], "height", tw, 1, 1 << 16));
            ti.mips = static_cast<int>(integer(textures[t], "mips", tw, 1, 32));
            ti.channels = member(textures[t], "format", tw) == "BC3" ? 4 : 3;
            ti.wrap = member(textures[t], "wrap", tw) != "clamp";
            if (ti.block >= 0 && ti.offset + ti.bytes > index.blocks[index.texture_block_ids[static_cast<size_t>(ti.block)]].bytes)
                fail(fmt::format("{}: bytes {}..{} run past the end of texture block {}", tw, ti.offset, ti.offset + ti.bytes,
                                 ti.block));
            index.textures.push_back(ti);
        }

        const json& features = member(ca, "features", "extras.cityatlas");
        index.feature_count = static_cast<uint64_t>(integer(features, "count", "extras.cityatlas.features", 0, INT64_MAX));
        index.feature_block_size =
            static_cast<int>(integer(features, "block_size", "extras.cityatlas.features", 1, INT32_MAX));
        for (const json& t : member(features, "tables", "extras.cityatlas.features"))
            index.feature_tables.push_back(
                {uri(t, "feature table"), static_cast<uint64_t>(integer(t, "bytes", "feature table", 1, INT64_MAX))});

        std::vector<std::pair<int32_t, std::vector<int64_t>>> leaf_blocks;
        parseNode(member(doc, "root", "tileset"), -1, 0, index, leaf_blocks);
        for (const auto& [node, list] : leaf_blocks) {
            for (const int64_t b : list) {
                if (b >= static_cast<int64_t>(index.texture_block_ids.size()))
                    fail(fmt::format("node {}: texture block {} does not exist ({} blocks)", node, b,
                                     index.texture_block_ids.size()));
                index.nodes[static_cast<size_t>(node)].texture_blocks.push_back(index.texture_block_ids[static_cast<size_t>(b)]);
            }
        }
        if (!index.nodes[0].layers[0].present && !index.nodes[0].layers[1].present)
            fail("node 0: the root has no geometry");
    } catch (const ParseError& e) {
        *out = TilesetIndex{};
        return Status::Invalid(fmt::format("{}: {}", where, e.message));
    } catch (const json::exception& e) {
        *out = TilesetIndex{};
        return Status::Invalid(fmt::format("{}: unexpected value: {}", where, e.what()));
    }
    return Status::Ok();
}

}  // namespace cityatlas::format
