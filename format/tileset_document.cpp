// SPDX-License-Identifier: GPL-3.0-or-later
// tileset.json <-> TilesetDocument. The reader names the node or entry of
// every problem; the writer emits exactly the fields the reader reads, so the
// round trip is the identity on the writer's output.
#include "format/tileset_document.h"

#include <cmath>
#include <limits>
#include <sstream>

#include <fmt/format.h>

#include "format/json_splice.h"
#include "format/tileset_document_json.h"

namespace cityatlas::format {
namespace {
using nlohmann::json;

// Thrown inside the reader only; the entry points turn it into a Status.
struct ParseError {
    std::string message;
};

[[noreturn]] void fail(const std::string& message) { throw ParseError{message}; }

const json* find(const json& object, const char* key, const std::string& where) {
    if (!object.is_object()) fail(fmt::format("{}: not an object", where));
    const auto it = object.find(key);
    return it == object.end() ? nullptr : &*it;
}

const json& member(const json& object, const char* key, const std::string& where) {
    const json* v = find(object, key, where);
    if (!v) fail(fmt::format("{}: \"{}\" missing", where, key));
    return *v;
}

double numberOf(const json& v, const char* key, const std::string& where) {
    if (!v.is_number() || !std::isfinite(v.get<double>())) fail(fmt::format("{}: \"{}\" is not a finite number", where, key));
    return v.get<double>();
}
double number(const json& object, const char* key, const std::string& where) {
    return numberOf(member(object, key, where), key, where);
}
double optNumber(const json& object, const char* key, const std::string& where, double fallback) {
    const json* v = find(object, key, where);
    return v ? numberOf(*v, key, where) : fallback;
}

int64_t integerOf(const json& v, const char* key, const std::string& where, int64_t lo, int64_t hi) {
    if (!v.is_number_integer()) fail(fmt::format("{}: \"{}\" is not an integer", where, key));
    // A large unsigned value reads as a negative int64_t; compare as what it is.
    if (v.is_number_unsigned() && v.get<uint64_t>() > static_cast<uint64_t>(INT64_MAX))
        fail(fmt::format("{}: \"{}\" = {} outside [{}, {}]", where, key, v.get<uint64_t>(), lo, hi));
    const auto i = v.get<int64_t>();
    if (i < lo || i > hi) fail(fmt::format("{}: \"{}\" = {} outside [{}, {}]", where, key, i, lo, hi));
    return i;
}
int64_t integer(const json& object, const char* key, const std::string& where, int64_t lo, int64_t hi) {
    return integerOf(member(object, key, where), key, where, lo, hi);
}
int64_t optInteger(const json& object, const char* key, const std::string& where, int64_t lo, int64_t hi,
                   int64_t fallback) {
    const json* v = find(object, key, where);
    return v ? integerOf(*v, key, where, lo, hi) : fallback;
}
uint64_t count(const json& object, const char* key, const std::string& where) {
    return static_cast<uint64_t>(integer(object, key, where, 0, INT64_MAX));
}
uint64_t optCount(const json& object, const char* key, const std::string& where) {
    return static_cast<uint64_t>(optInteger(object, key, where, 0, INT64_MAX, 0));
}
int optSmall(const json& object, const char* key, const std::string& where, int fallback = 0) {
    return static_cast<int>(optInteger(object, key, where, INT32_MIN, INT32_MAX, fallback));
}

std::string textOf(const json& v, const char* key, const std::string& where) {
    if (!v.is_string()) fail(fmt::format("{}: \"{}\" is not a string", where, key));
    return v.get<std::string>();
}
std::string text(const json& object, const char* key, const std::string& where) {
    return textOf(member(object, key, where), key, where);
}
std::string optText(const json& object, const char* key, const std::string& where, std::string fallback = {}) {
    const json* v = find(object, key, where);
    return v ? textOf(*v, key, where) : fallback;
}
bool optFlag(const json& object, const char* key, const std::string& where) {
    const json* v = find(object, key, where);
    if (!v) return false;
    if (!v->is_boolean()) fail(fmt::format("{}: \"{}\" is not true or false", where, key));
    return v->get<bool>();
}

const json& arrayMember(const json& object, const char* key, const std::string& where) {
    const json& v = member(object, key, where);
    if (!v.is_array()) fail(fmt::format("{}: \"{}\" is not an array", where, key));
    return v;
}

template <class T>
std::vector<T> indices(const json* v, const char* key, const std::string& where) {
    std::vector<T> out;
    if (!v) return out;
    if (!v->is_array()) fail(fmt::format("{}: \"{}\" is not an array", where, key));
    for (const json& e : *v) {
        if (!e.is_number_integer() || e.get<int64_t>() < 0 ||
            (e.is_number_unsigned() && e.get<uint64_t>() > static_cast<uint64_t>(std::numeric_limits<T>::max())) ||
            e.get<int64_t>() > static_cast<int64_t>(std::numeric_limits<T>::max()))
            fail(fmt::format("{}: {} holds a non-index", where, key));
        out.push_back(static_cast<T>(e.get<int64_t>()));
    }
    return out;
}

template <size_t N>
std::array<double, N> numbers(const json& v, const char* what, const std::string& where) {
    if (!v.is_array() || v.size() != N) fail(fmt::format("{}: {} is not {} numbers", where, what, N));
    std::array<double, N> a{};
    for (size_t i = 0; i < N; ++i) {
        if (!v[i].is_number() || !std::isfinite(v[i].get<double>()))
            fail(fmt::format("{}: {} is not {} numbers", where, what, N));
        a[i] = v[i].get<double>();
    }
    return a;
}
std::optional<std::array<double, 16>> optMatrix(const json& object, const char* key, const std::string& where) {
    const json* v = find(object, key, where);
    if (!v || v->is_null()) return std::nullopt;
    return numbers<16>(*v, key, where);
}
Vec3d vec3(const json& v, const char* what, const std::string& where) {
    const auto a = numbers<3>(v, what, where);
    return {a[0], a[1], a[2]};
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
FileEntry fileEntry(const json& object, const std::string& where) {
    FileEntry f;
    f.uri = uri(object, where);
    f.bytes = static_cast<uint64_t>(integer(object, "bytes", where, 1, INT64_MAX));
    return f;
}

LayerEntry readLayer(const json& L, const std::string& lw) {
    LayerEntry l;
    l.triangles = static_cast<uint64_t>(integer(L, "triangles", lw, 0, UINT32_MAX));
    l.triangles_source = optCount(L, "triangles_source", lw);
    l.geometric_error_m = number(L, "geometric_error_m", lw);
    l.position_error_mm = number(L, "position_error_mm", lw);
    l.position_bits = optSmall(L, "position_bits", lw);
    l.uv_atlas_error_texels = optNumber(L, "uv_atlas_error_texels", lw, 0);
    l.simplified = optFlag(L, "simplified", lw);
    l.left_out_over_cap = optCount(L, "left_out_over_cap", lw);
    l.geometry = fileEntry(member(L, "geometry", lw), lw + " geometry");
    const json& a = member(L, "atlas", lw);
    if (!a.is_null()) {
        const std::string aw = lw + " atlas";
        AtlasEntry e;
        e.file = fileEntry(a, aw);
        e.width_px = static_cast<int>(integer(a, "width_px", aw, 1, 1 << 16));
        e.height_px = static_cast<int>(integer(a, "height_px", aw, 1, 1 << 16));
        e.format = text(a, "format", aw);
        if (const json* o = find(a, "offset", aw)) {
            if (!o->is_array() || o->size() != 2) fail(aw + ": offset is not 2 integers");
            e.offset = {integerOf((*o)[0], "offset", aw, 0, INT64_MAX), integerOf((*o)[1], "offset", aw, 0, INT64_MAX)};
        }
        e.mips = optSmall(a, "mips", aw);
        // null: the BC level equals the atlas exactly (infinite PSNR); JSON has no infinity.
        const json* psnr = find(a, "psnr_db", aw);
        e.psnr_db = psnr && psnr->is_null() ? std::numeric_limits<double>::infinity() : optNumber(a, "psnr_db", aw, 0);
        l.atlas = e;
    }
    if (const json* u = find(L, "uv_original_error_texels", lw)) {
        l.uv_original_error_texels = numberOf(*u, "uv_original_error_texels", lw);
        l.uv_original_bits = optSmall(L, "uv_original_bits", lw);
    }
    if (const json* c = find(L, "computed", lw)) {
        if (!c->is_array()) fail(lw + ": computed is not an array");
        for (size_t k = 0; k < c->size(); ++k) {
            const json& e = (*c)[k];
            ComputedFileEntry f;
            if (!e.is_null()) {
                const std::string cw = fmt::format("{} computed {}", lw, k);
                f.file = fileEntry(e, cw);
                f.width_px = static_cast<int>(integer(e, "width_px", cw, 1, 1 << 16));
                f.height_px = static_cast<int>(integer(e, "height_px", cw, 1, 1 << 16));
                f.mips = optSmall(e, "mips", cw);
            }
            l.computed.push_back(f);
        }
    }
    return l;
}

std::vector<ComputedTextureEntry> readComputed(const json& c_all) {
    std::vector<ComputedTextureEntry> out;
    if (!c_all.is_array()) fail("extras.cityatlas.computed is not an array");
    for (size_t k = 0; k < c_all.size(); ++k) {
        const json& e = c_all[k];
        const std::string cw = fmt::format("computed texture {}", k);
        ComputedTextureEntry c;
        c.name = text(e, "name", cw);
        const json& p = member(e, "parameters", cw);
        if (!p.is_object()) fail(cw + ": parameters is not an object");
        c.parameters_json = p.dump();
        c.scale = static_cast<int>(integer(e, "scale", cw, 1, 4));
        c.format = text(e, "format", cw);
        const json& r = member(e, "range", cw);
        if (!r.is_array() || r.size() != 2) fail(cw + ": range is not 2 numbers");
        c.range = {numberOf(r[0], "range", cw), numberOf(r[1], "range", cw)};
        if (const json* st = find(e, "statistics", cw)) {
            c.texels = optCount(*st, "texels", cw);
            c.min = optNumber(*st, "min", cw, 0), c.max = optNumber(*st, "max", cw, 0);
            c.mean = optNumber(*st, "mean", cw, 0);
        }
        c.bytes = optCount(e, "bytes", cw);
        out.push_back(c);
    }
    return out;
}

BuildEntry readBuild(const json& build) {
    const std::string w = "extras.cityatlas.build";
    BuildEntry b;
    b.d_min_m = number(build, "d_min_m", w);
    b.d_min_requested_m = optNumber(build, "d_min_requested_m", w, 0);
    b.atlas_size_px = static_cast<int>(integer(build, "atlas_size_px", w, 1, 1 << 16));
    b.border_px = optSmall(build, "border_px", w);
    b.tau = number(build, "tau", w);
    b.screen_width_px = static_cast<int>(integer(build, "screen_width_px", w, 1, 1 << 20));
    b.screen_height_px = static_cast<int>(integer(build, "screen_height_px", w, 1, 1 << 20));
    b.vertical_fov_deg = number(build, "vertical_fov_deg", w);
    b.focal_px = number(build, "focal_px", w);
    b.corner_factor = number(build, "corner_factor", w);
    if (!(b.focal_px > 0) || !(b.corner_factor >= 1) || !(b.tau > 0))
        fail(w + ": focal_px and tau must be positive and corner_factor >= 1");
    b.filter = optText(build, "filter", w);
    b.packing = optText(build, "packing", w);
    b.unique_charts = optFlag(build, "unique_charts", w);
    b.position_bits = optSmall(build, "position_bits", w);
    b.position_error_target_mm = optNumber(build, "position_error_target_mm", w, 0);
    b.uv_bits = optSmall(build, "uv_bits", w);
    b.bc_quality = optText(build, "bc_quality", w);
    b.originals = optText(build, "originals", w);
    b.d_min_chosen_by = optText(build, "d_min_chosen_by", w);
    b.node_triangles = optCount(build, "node_triangles", w);
    b.geometry_encoder = optText(build, "geometry_encoder", w);
    b.texture_encoder = optText(build, "texture_encoder", w);
    b.blockmaps = optText(build, "blockmaps", w, "off");
    return b;
}

GeoreferenceEntry readGeoreference(const json& geo) {
    const std::string w = "extras.cityatlas.georeference";
    GeoreferenceEntry g;
    g.source_crs = optText(geo, "source_crs", w);
    if (const json* o = find(geo, "origin_source", w)) g.origin_source = vec3(*o, "origin_source", w);
    g.grid_frame = optFlag(geo, "grid_frame", w);
    g.local_to_ecef = optMatrix(geo, "local_to_ecef", w);
    g.enu_to_ecef = optMatrix(geo, "enu_to_ecef", w);
    return g;
}

TextureEntry readTexture(const json& t, const std::string& tw, const std::vector<FileEntry>& blocks) {
    TextureEntry e;
    e.block = static_cast<int32_t>(integer(t, "block", tw, -1, static_cast<int64_t>(blocks.size()) - 1));
    e.offset = count(t, "offset", tw);
    e.bytes = count(t, "bytes", tw);
    e.width = static_cast<int>(integer(t, "width", tw, 1, 1 << 16));
    e.height = static_cast<int>(integer(t, "height", tw, 1, 1 << 16));
    e.mips = static_cast<int>(integer(t, "mips", tw, 1, 32));
    e.format = text(t, "format", tw);
    e.wrap = text(t, "wrap", tw);
    e.original = optText(t, "original", tw);
    if (e.block >= 0 && (e.offset > blocks[static_cast<size_t>(e.block)].bytes ||
                         e.bytes > blocks[static_cast<size_t>(e.block)].bytes - e.offset))
        fail(fmt::format("{}: bytes {}..{} run past the end of texture block {}", tw, e.offset, e.offset + e.bytes,
                         e.block));
    return e;
}

TotalsEntry readTotals(const json& t) {
    const std::string w = "extras.cityatlas.totals";
    TotalsEntry s;
    s.nodes = optCount(t, "nodes", w);
    s.leaves = optCount(t, "leaves", w);
    s.depth = optCount(t, "depth", w);
    if (const json* b = find(t, "bytes", w)) {
        const std::string bw = w + ".bytes";
        s.bytes_geometry = optCount(*b, "geometry", bw);
        s.bytes_atlases = optCount(*b, "atlases", bw);
        s.bytes_textures = optCount(*b, "textures", bw);
        s.bytes_features = optCount(*b, "features", bw);
        s.bytes_originals_as_bc = optCount(*b, "originals_as_bc", bw);
        s.bytes_blockmaps = optCount(*b, "blockmaps", bw);
    }
    s.texture_ratio = optNumber(t, "texture_ratio", w, 0);
    return s;
}

BlockMapEntry readBlockMap(const json& b, const std::string& w) {
    BlockMapEntry e;
    e.file = {uri(b, w), count(b, "bytes", w)};
    e.gpu_bytes = optCount(b, "gpu_bytes", w);
    const json& grid = arrayMember(b, "grid", w);
    const json& wall = arrayMember(b, "wall_px", w);
    if (grid.size() != 2 || wall.size() != 2) fail(w + ": grid and wall_px are not two integers");
    for (size_t k = 0; k < 2; ++k) {
        e.grid[k] = integerOf(grid[k], "grid", w, 1, int64_t{1} << 24);
        e.wall_px[k] = integerOf(wall[k], "wall_px", w, 0, int64_t{1} << 24);
    }
    e.texel_m = number(b, "texel_m", w);
    if (!(e.texel_m > 0)) fail(w + ": \"texel_m\" is not positive");
    e.origin = vec3(member(b, "origin", w), "origin", w);
    e.z_top_m = number(b, "z_top_m", w);
    e.columns = count(b, "columns", w);
    e.hausdorff_m = optNumber(b, "hausdorff_m", w, 0);
    e.voxel_bound_m = optNumber(b, "voxel_bound_m", w, 0);
    e.min_distance_m = number(b, "min_distance_m", w);
    e.features = count(b, "features", w);
    e.features_missing = indices<uint32_t>(find(b, "features_missing", w), "features_missing", w);
    return e;
}

void readTileInto(const json& tile, const std::string& w, TileEntry& n) {
    n.box = numbers<12>(member(member(tile, "boundingVolume", w), "box", w + ".boundingVolume"), "boundingVolume.box", w);
    n.geometric_error = optNumber(tile, "geometricError", w, 0);
    n.refine = optText(tile, "refine", w, "REPLACE");
    n.transform = optMatrix(tile, "transform", w);
    if (const json* c = find(tile, "contents", w)) {
        if (!c->is_array()) fail(w + ": contents is not an array");
        for (const json& e : *c) n.contents.push_back(uri(e, w + " contents"));
    }
    const json& ca = member(member(tile, "extras", w), "cityatlas", w + ".extras");
    n.id = static_cast<int32_t>(integer(ca, "id", w, 0, INT32_MAX));
    n.level = optSmall(ca, "level", w);
    n.quadrant = optSmall(ca, "quadrant", w, -1);
    n.min_distance_m = number(ca, "min_distance_m", w);
    n.sharp_from_m = optNumber(ca, "sharp_from_m", w, 0);
    n.world_texel_m = number(ca, "world_texel_m", w);
    n.centre = vec3(member(ca, "centre", w), "centre", w);
    if (const json* f = find(ca, "features", w); f && f->is_object()) {
        n.feature_count = count(*f, "count", w + ".features");
        n.features_dropped = indices<uint32_t>(find(*f, "dropped", w), "dropped", w);
        n.feature_tables = indices<uint32_t>(find(*f, "tables", w), "tables", w);
    }
    const json& layers = member(ca, "layers", w);
    if (!layers.is_object()) fail(w + ": layers is not an object");
    for (int li = 0; li < kTileLayers; ++li) {
        const char* name = li == 1 ? "alpha" : "opaque";
        if (const auto it = layers.find(name); it != layers.end())
            n.layers[static_cast<size_t>(li)] = readLayer(*it, fmt::format("{} layer {}", w, name));
    }
    n.texture_blocks = indices<int64_t>(find(ca, "texture_blocks", w), "texture_blocks", w);
    n.bytes = optCount(ca, "bytes", w);
    if (const json* b = find(ca, "blockmap", w)) n.blockmap = readBlockMap(*b, w + " blockmap");
}

void readTree(const json& tile, int32_t parent, int depth, TilesetDocument& doc) {
    const auto id = static_cast<int32_t>(doc.tiles.size());
    const std::string w = fmt::format("node {}", id);
    if (depth > 64) fail(w + ": deeper than 64 levels");
    doc.tiles.emplace_back();
    {
        TileEntry& n = doc.tiles.back();
        readTileInto(tile, w, n);
        if (n.id != id) fail(w + ": extras.cityatlas.id is not the preorder index");
        if (!find(member(member(tile, "extras", w), "cityatlas", w), "level", w)) n.level = depth;
        n.parent = parent;
    }
    if (const json* children = find(tile, "children", w)) {
        if (!children->is_array()) fail(w + ": children is not an array");
        for (const json& child : *children) {
            doc.tiles[static_cast<size_t>(id)].children.push_back(static_cast<int32_t>(doc.tiles.size()));
            readTree(child, id, depth + 1, doc);
        }
    }
    const TileEntry& n = doc.tiles[static_cast<size_t>(id)];
    if (!n.texture_blocks.empty() && !n.leaf()) fail(w + ": an inner node lists texture blocks");
    for (const int64_t b : n.texture_blocks)
        if (b >= static_cast<int64_t>(doc.texture_blocks.size()))
            fail(fmt::format("{}: texture block {} does not exist ({} blocks)", w, b, doc.texture_blocks.size()));
}

// --- Writing -------------------------------------------------------------------

json matrixOrNull(const std::optional<std::array<double, 16>>& m) { return m ? json(*m) : json(nullptr); }
json file(const FileEntry& f) { return {{"uri", f.uri}, {"bytes", f.bytes}}; }
json xyz(const Vec3d& v) { return json::array({v.x, v.y, v.z}); }

json layerJson(const LayerEntry& l) {
    json atlas = nullptr;
    if (l.atlas) {
        const AtlasEntry& a = *l.atlas;
        atlas = {{"uri", a.file.uri},       {"bytes", a.file.bytes},  {"format", a.format},
                 {"width_px", a.width_px},  {"height_px", a.height_px}, {"offset", json(a.offset)},
                 {"mips", a.mips},          {"psnr_db", a.psnr_db}};
    }
    json j = {{"triangles", l.triangles},
              {"triangles_source", l.triangles_source},
              {"geometry", file(l.geometry)},
              {"geometric_error_m", l.geometric_error_m},
              {"position_error_mm", l.position_error_mm},
              {"position_bits", l.position_bits},
              {"uv_atlas_error_texels", l.uv_atlas_error_texels},
              {"simplified", l.simplified},
              {"atlas", atlas}};
    if (l.left_out_over_cap > 0) j["left_out_over_cap"] = l.left_out_over_cap;
    if (l.uv_original_error_texels) {
        j["uv_original_error_texels"] = *l.uv_original_error_texels;
        j["uv_original_bits"] = l.uv_original_bits;
    }
    if (!l.computed.empty()) {
        json c = json::array();
        for (const ComputedFileEntry& f : l.computed)
            c.push_back(f.file.uri.empty() ? json(nullptr)
                                           : json{{"uri", f.file.uri}, {"bytes", f.file.bytes}, {"width_px", f.width_px},
                                                  {"height_px", f.height_px}, {"mips", f.mips}});
        j["computed"] = c;
    }
    return j;
}

// The long arrays are written into the dump where these stand (format/json_splice.h).
constexpr const char* kSplicePrefix = "cityatlas-splice-";
std::string droppedPlaceholder(int32_t tile) { return fmt::format("{}dropped-{}", kSplicePrefix, tile); }
std::string missingPlaceholder(int32_t tile) { return fmt::format("{}missing-{}", kSplicePrefix, tile); }
std::string childrenPlaceholder(int32_t tile) { return fmt::format("{}children-{}", kSplicePrefix, tile); }

json blockMapJson(const BlockMapEntry& b, int32_t tile) {
    return {{"uri", b.file.uri},
            {"bytes", b.file.bytes},
            {"gpu_bytes", b.gpu_bytes},
            {"grid", json(b.grid)},
            {"texel_m", b.texel_m},
            {"origin", xyz(b.origin)},
            {"z_top_m", b.z_top_m},
            {"columns", b.columns},
            {"wall_px", json(b.wall_px)},
            {"hausdorff_m", b.hausdorff_m},
            {"voxel_bound_m", b.voxel_bound_m},
            {"min_distance_m", b.min_distance_m},
            {"features", b.features},
            {"features_missing", b.features_missing.empty() ? json::array() : json(missingPlaceholder(tile))}};
}

// One tile without its children's text: they stand as a placeholder (writeTile).
json tileJson(const TilesetDocument& doc, int32_t id) {
    const TileEntry& n = doc.tiles[static_cast<size_t>(id)];
    json layers = json::object();
    for (int li = 0; li < kTileLayers; ++li)
        if (const auto& l = n.layers[static_cast<size_t>(li)]) layers[li == 1 ? "alpha" : "opaque"] = layerJson(*l);
    json ca = {{"id", n.id},
               {"level", n.level},
               {"quadrant", n.quadrant},
               {"min_distance_m", n.min_distance_m},
               {"sharp_from_m", n.sharp_from_m},
               {"world_texel_m", n.world_texel_m},
               {"centre", xyz(n.centre)},
               {"layers", layers},
               {"features", {{"count", n.feature_count},
                             {"dropped", n.features_dropped.empty() ? json::array() : json(droppedPlaceholder(id))},
                             {"tables", json(n.feature_tables)}}},
               {"texture_blocks", json(n.texture_blocks)},
               {"bytes", n.bytes}};
    if (n.blockmap) ca["blockmap"] = blockMapJson(*n.blockmap, id);
    json t = json::object();
    t["boundingVolume"] = {{"box", json(n.box)}};
    t["geometricError"] = n.geometric_error;
    t["refine"] = n.refine;
    if (n.transform) t["transform"] = *n.transform;
    if (!n.contents.empty()) {
        json contents = json::array();
        for (const std::string& u : n.contents) contents.push_back({{"uri", u}});
        t["contents"] = contents;
    }
    if (!n.children.empty()) t["children"] = childrenPlaceholder(id);
    t["extras"] = {{"cityatlas", ca}};
    return t;
}

// Tile `id` and its subtree, each tile's text made as it goes out: as one DOM
// a city's tiles took ~10 kB each (a million buildings: ~250 MB at once).
void writeTile(const TilesetDocument& doc, int32_t id, size_t pad, std::ostream& out) {
    const TileEntry& n = doc.tiles[static_cast<size_t>(id)];
    std::vector<SplicedArray> arrays;
    if (!n.features_dropped.empty())
        arrays.push_back({.placeholder = droppedPlaceholder(id), .count = n.features_dropped.size(),
                          .element = [&n](size_t i) { return std::to_string(n.features_dropped[i]); }});
    if (n.blockmap && !n.blockmap->features_missing.empty())
        arrays.push_back({.placeholder = missingPlaceholder(id), .count = n.blockmap->features_missing.size(),
                          .element = [&n](size_t i) { return std::to_string(n.blockmap->features_missing[i]); }});
    if (!n.children.empty())
        arrays.push_back({.placeholder = childrenPlaceholder(id),
                          .count = n.children.size(),
                          .write = [&](size_t i, size_t p, std::ostream& o) { writeTile(doc, n.children[i], p, o); }});
    spliceArrays(tileJson(doc, id).dump(1, ' ', false, json::error_handler_t::replace), 1, kSplicePrefix, arrays, out,
                 pad);
}

json buildJson(const BuildEntry& b) {
    json j = {{"d_min_m", b.d_min_m},
            {"d_min_requested_m", b.d_min_requested_m},
            {"atlas_size_px", b.atlas_size_px},
            {"border_px", b.border_px},
            {"tau", b.tau},
            {"screen_width_px", b.screen_width_px},
            {"screen_height_px", b.screen_height_px},
            {"vertical_fov_deg", b.vertical_fov_deg},
            {"focal_px", b.focal_px},
            {"corner_factor", b.corner_factor},
            {"filter", b.filter},
            {"packing", b.packing},
            {"position_bits", b.position_bits},
            {"position_error_target_mm", b.position_error_target_mm},
            {"uv_bits", b.uv_bits},
            {"bc_quality", b.bc_quality},
            {"originals", b.originals},
            {"d_min_chosen_by", b.d_min_chosen_by},
            {"node_triangles", b.node_triangles},
            {"geometry_encoder", b.geometry_encoder},
            {"texture_encoder", b.texture_encoder}};
    if (b.unique_charts) j["unique_charts"] = true;  // written only when on: default folders keep their bytes
    if (b.blockmaps != "off") j["blockmaps"] = b.blockmaps;
    return j;
}

}  // namespace

Status readTileEntry(const json& tile, const std::string& where, TileEntry* out) {
    *out = TileEntry{};
    try {
        readTileInto(tile, where, *out);
    } catch (const ParseError& e) {
        *out = TileEntry{};
        return Status::Invalid(e.message);
    } catch (const json::exception& e) {
        *out = TileEntry{};
        return Status::Invalid(fmt::format("{}: unexpected value: {}", where, e.what()));
    }
    return Status::Ok();
}

Status readTilesetDocument(const std::string& text, const std::string& where, TilesetDocument* out) {
    *out = TilesetDocument{};
    json j;
    try {
        j = json::parse(text);
    } catch (const json::parse_error& e) {
        return Status::Invalid(fmt::format("{}: not JSON (byte {}): {}", where, e.byte, e.what()));
    } catch (const json::exception& e) {  // out_of_range: a number beyond double (1e999)
        return Status::Invalid(fmt::format("{}: not JSON: {}", where, e.what()));
    }
    try {
        TilesetDocument& doc = *out;
        const json& asset = member(j, "asset", "tileset");
        doc.version = optText(asset, "version", "asset");
        doc.generator = optText(asset, "generator", "asset");
        if (const json* v = find(asset, "tilesetVersion", "asset"); v && v->is_string()) doc.tileset_version = *v;
        doc.gltf_up_axis = optText(asset, "gltfUpAxis", "asset", "Y");
        doc.geometric_error = optNumber(j, "geometricError", "tileset", 0);

        const json& ca = member(member(j, "extras", "tileset"), "cityatlas", "tileset.extras");
        doc.format_version = integer(ca, "format_version", "extras.cityatlas", 0, INT32_MAX);
        if (doc.format_version != 1)
            fail(fmt::format("extras.cityatlas.format_version {} is not 1 (this reader reads 1)", doc.format_version));
        doc.build = readBuild(member(ca, "build", "extras.cityatlas"));
        doc.georeference = readGeoreference(member(ca, "georeference", "extras.cityatlas"));

        for (const json& m : arrayMember(ca, "materials", "extras.cityatlas")) {
            MaterialEntry me;
            const json& d = member(m, "diffuse", "material");
            if (!d.is_array()) fail("material: \"diffuse\" is not an array");
            for (size_t k = 0; k < 3 && k < d.size(); ++k) me.diffuse[k] = numberOf(d[k], "diffuse", "material");
            me.transparency = number(m, "transparency", "material");
            doc.materials.push_back(me);
        }
        const json& blocks = arrayMember(ca, "texture_blocks", "extras.cityatlas");
        for (size_t k = 0; k < blocks.size(); ++k)
            doc.texture_blocks.push_back(fileEntry(blocks[k], fmt::format("texture block {}", k)));
        const json& textures = arrayMember(ca, "textures", "extras.cityatlas");
        for (size_t t = 0; t < textures.size(); ++t)
            doc.textures.push_back(readTexture(textures[t], fmt::format("texture {}", t), doc.texture_blocks));

        const json& features = member(ca, "features", "extras.cityatlas");
        const std::string fw = "extras.cityatlas.features";
        doc.feature_count = count(features, "count", fw);
        doc.feature_block_size = integer(features, "block_size", fw, 1, INT32_MAX);
        const json& tables = arrayMember(features, "tables", fw);
        for (size_t k = 0; k < tables.size(); ++k) {
            const std::string tw = fmt::format("feature table {}", k);
            doc.feature_tables.push_back(fileEntry(tables[k], tw));
            // Bounds come with every table or with none (older folders).
            if (const json* b = find(tables[k], "bounds", tw)) doc.feature_bounds.push_back(fileEntry(*b, tw + " bounds"));
            else if (!doc.feature_bounds.empty()) fail(fmt::format("{}: no \"bounds\" where table 0 has them", tw));
        }
        if (!doc.feature_bounds.empty() && doc.feature_bounds.size() != doc.feature_tables.size())
            fail("feature table 0: \"bounds\" where a later table has none");
        if (const json* totals = find(ca, "totals", "extras.cityatlas")) doc.totals = readTotals(*totals);
        if (const json* computed = find(ca, "computed", "extras.cityatlas")) doc.computed = readComputed(*computed);
        readTree(member(j, "root", "tileset"), -1, 0, doc);
    } catch (const ParseError& e) {
        *out = TilesetDocument{};
        return Status::Invalid(fmt::format("{}: {}", where, e.message));
    } catch (const json::exception& e) {
        *out = TilesetDocument{};
        return Status::Invalid(fmt::format("{}: unexpected value: {}", where, e.what()));
    }
    return Status::Ok();
}

namespace {

json textureJson(const TextureEntry& e) {
    return {{"block", e.block},   {"offset", e.offset}, {"bytes", e.bytes}, {"width", e.width},      {"height", e.height},
            {"format", e.format}, {"mips", e.mips},     {"wrap", e.wrap},   {"original", e.original}};
}

// The textures array as dump(1) writes it with its key at `depth`, one entry
// at a time: a million entries as one JSON value would take ~1 GB.
}  // namespace

void writeTilesetDocument(const TilesetDocument& doc, std::ostream& os) {
    json materials = json::array();
    for (const MaterialEntry& m : doc.materials)
        materials.push_back({{"diffuse", json(m.diffuse)}, {"transparency", m.transparency}});
    const std::string placeholder = std::string(kSplicePrefix) + "textures";
    const json textures = placeholder;
    json blocks = json::array(), tables = json::array();
    for (const FileEntry& b : doc.texture_blocks) blocks.push_back(file(b));
    for (size_t k = 0; k < doc.feature_tables.size(); ++k) {
        json t = file(doc.feature_tables[k]);
        if (k < doc.feature_bounds.size()) t["bounds"] = file(doc.feature_bounds[k]);
        tables.push_back(std::move(t));
    }
    const GeoreferenceEntry& g = doc.georeference;
    const TotalsEntry& s = doc.totals;
    json ca = {{"format_version", doc.format_version},
               {"georeference", {{"source_crs", g.source_crs},
                                 {"origin_source", xyz(g.origin_source)},
                                 {"grid_frame", g.grid_frame},
                                 {"local_to_ecef", matrixOrNull(g.local_to_ecef)},
                                 {"enu_to_ecef", matrixOrNull(g.enu_to_ecef)}}},
               {"build", buildJson(doc.build)},
               {"materials", materials},
               {"textures", textures},
               {"texture_blocks", blocks},
               {"features", {{"count", doc.feature_count}, {"block_size", doc.feature_block_size}, {"tables", tables}}},
               {"totals", {{"nodes", s.nodes},
                           {"leaves", s.leaves},
                           {"depth", s.depth},
                           {"bytes", {{"geometry", s.bytes_geometry},
                                      {"atlases", s.bytes_atlases},
                                      {"textures", s.bytes_textures},
                                      {"features", s.bytes_features},
                                      {"originals_as_bc", s.bytes_originals_as_bc}}},
                           {"texture_ratio", s.texture_ratio}}}};
    if (s.bytes_blockmaps) ca["totals"]["bytes"]["blockmaps"] = s.bytes_blockmaps;  // only when built: default folders keep their bytes
    if (!doc.computed.empty()) {
        json computed = json::array();
        for (const ComputedTextureEntry& c : doc.computed)
            computed.push_back({{"name", c.name},
                                {"parameters", json::parse(c.parameters_json)},
                                {"scale", c.scale},
                                {"format", c.format},
                                {"range", json(c.range)},
                                {"statistics", {{"texels", c.texels}, {"min", c.min}, {"max", c.max}, {"mean", c.mean}}},
                                {"bytes", c.bytes}});
        ca["computed"] = computed;
    }
    json tileset = json::object();
    tileset["asset"] = {{"version", doc.version},
                        {"generator", doc.generator},
                        {"tilesetVersion", doc.tileset_version},
                        {"gltfUpAxis", doc.gltf_up_axis}};
    tileset["geometricError"] = doc.geometric_error;
    const std::string root = std::string(kSplicePrefix) + "root";
    if (!doc.tiles.empty()) tileset["root"] = root;
    tileset["extras"] = {{"cityatlas", ca}};
    std::vector<SplicedArray> arrays;
    arrays.push_back({.placeholder = placeholder,
                      .count = doc.texture_at ? doc.texture_count : doc.textures.size(),
                      .element = [&](size_t i) {
                          return textureJson(doc.texture_at ? doc.texture_at(i) : doc.textures[i])
                              .dump(1, ' ', false, json::error_handler_t::replace);
                      }});
    arrays.push_back({.placeholder = root,
                      .count = 1,
                      .write = [&](size_t, size_t pad, std::ostream& out) { writeTile(doc, 0, pad, out); },
                      .single = true});
    spliceArrays(tileset.dump(1, ' ', false, json::error_handler_t::replace), 1, kSplicePrefix, arrays, os);
    os << '\n';
}

std::string writeTilesetDocument(const TilesetDocument& doc) {
    std::ostringstream out;
    writeTilesetDocument(doc, out);
    return out.str();
}

}  // namespace cityatlas::format
