// SPDX-License-Identifier: GPL-3.0-or-later
// The plan folder, the shard jobs and the merge of cli/shards.h.
#include "cli/shards.h"

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <type_traits>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/info.h>
#include <xxhash.h>
#ifdef CITYATLAS_WITH_MIMALLOC
#include <mimalloc.h>
#endif

#include "atlas/atlas_images.h"
#include "atlas/atlas_report.h"
#include "atlas/computed_layers.h"
#include "atlas/raycast.h"
#include "tiles/computed_files.h"
#include "ingest/synth/facade_texture.h"
#include "tiles/texture_blocks.h"

extern char** environ;

namespace cityatlas::cli {
namespace fs = std::filesystem;
using nlohmann::json;
using atlas::Layer;
using format::TileMesh;

namespace {

constexpr int kPlanFormat = 5;  // 2: textures and their digests in textures.bin; 3: feature_bounds; 4: atlas_png; 5: texture_plan.bin
static_assert(std::is_trivially_copyable_v<Triangle>, "shard files hold triangles as bytes");

// --- Small serialization helpers. JSON numbers round-trip doubles exactly
// (nlohmann writes the shortest representation that reads back the same);
// infinities and NaN have no JSON form and are written as null.
json num(double d) { return std::isfinite(d) ? json(d) : json(nullptr); }
double numOr(const json& j, double fallback) { return j.is_null() ? fallback : j.get<double>(); }

json vec3(const Vec3d& v) { return json::array({num(v.x), num(v.y), num(v.z)}); }
Vec3d vec3From(const json& j, double fallback) {
    return {numOr(j.at(0), fallback), numOr(j.at(1), fallback), numOr(j.at(2), fallback)};
}

template <typename T>
void writeVector(std::ofstream& f, const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    const uint64_t n = v.size();
    f.write(reinterpret_cast<const char*>(&n), sizeof n);
    f.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(n * sizeof(T)));
}
template <typename T>
bool readVector(std::ifstream& f, std::vector<T>* v) {
    uint64_t n = 0;
    if (!f.read(reinterpret_cast<char*>(&n), sizeof n) || n > (uint64_t{1} << 34) / sizeof(T)) return false;
    v->resize(n);
    return static_cast<bool>(f.read(reinterpret_cast<char*>(v->data()), static_cast<std::streamsize>(n * sizeof(T))));
}
// A column as writeVector writes a vector (its count, then its records), and
// back, a block at a time: a city's worth is never held.
template <typename T>
void writeColumn(std::ofstream& f, const PagedColumn<T>& c) {
    const uint64_t n = c.size();
    f.write(reinterpret_cast<const char*>(&n), sizeof n);
    std::vector<T> block;
    for (size_t first = 0; first < n; first += block.size()) {
        block.clear();
        for (size_t i = first; i < n && block.size() < (size_t{1} << 16); ++i) block.push_back(c[i]);
        f.write(reinterpret_cast<const char*>(block.data()), static_cast<std::streamsize>(block.size() * sizeof(T)));
    }
}
template <typename T>
bool readColumn(std::ifstream& f, PagedColumn<T>* c) {
    uint64_t n = 0;
    if (!f.read(reinterpret_cast<char*>(&n), sizeof n) || n > (uint64_t{1} << 34) / sizeof(T)) return false;
    std::vector<T> block;
    for (uint64_t first = 0; first < n; first += block.size()) {
        block.resize(static_cast<size_t>(std::min<uint64_t>(n - first, 1 << 16)));
        if (!f.read(reinterpret_cast<char*>(block.data()), static_cast<std::streamsize>(block.size() * sizeof(T))))
            return false;
        for (const T& r : block) c->push_back(r);
    }
    return true;
}
// The elements at `only` (ascending indices) of a vector writeVector wrote,
// read through a block at a time: a city's worth is never held.
template <typename T>
bool readVectorAt(std::ifstream& f, const std::vector<int32_t>& only, std::vector<T>* v) {
    uint64_t n = 0;
    if (!f.read(reinterpret_cast<char*>(&n), sizeof n) || n > (uint64_t{1} << 34) / sizeof(T)) return false;
    v->clear();
    v->reserve(only.size());
    std::vector<T> block;
    size_t k = 0;
    for (uint64_t first = 0; first < n; first += block.size()) {
        block.resize(static_cast<size_t>(std::min<uint64_t>(n - first, 1 << 16)));
        if (!f.read(reinterpret_cast<char*>(block.data()), static_cast<std::streamsize>(block.size() * sizeof(T))))
            return false;
        for (; k < only.size() && static_cast<uint64_t>(only[k]) < first + block.size(); ++k)
            v->push_back(block[static_cast<size_t>(static_cast<uint64_t>(only[k]) - first)]);
    }
    return k == only.size();
}

Status readJson(const fs::path& path, json* out) {
    std::ifstream f(path);
    if (!f) return Status::Io(fmt::format("{}: cannot open", path.string()));
    try {
        *out = json::parse(f);
    } catch (const std::exception& e) {
        return Status::Io(fmt::format("{}: not valid JSON: {}", path.string(), e.what()));
    }
    return Status::Ok();
}

Status writeJson(const fs::path& path, const json& j) {
    const std::string text = j.dump(-1, ' ', false, json::error_handler_t::replace);
    return tiles::writeBytes(path, text.data(), text.size());
}

// --- Parameters.
// The plan's atlas parameters: all that change the output (not the planner's thread count).
json planAtlasParamsJson(const atlas::AtlasParams& p) {
    json j = atlas::atlasParamsJson(p);
    j.erase("threads");
    return j;
}
atlas::AtlasParams atlasParamsFrom(const json& j) {
    atlas::AtlasParams p;
    if (!j.at("d_min_m").is_null()) p.d_min_m = j.at("d_min_m").get<double>();
    p.d_min_diagonal_fraction = j.at("d_min_diagonal_fraction");
    p.atlas_size_px = j.at("atlas_size_px");
    p.border_px = j.at("border_px");
    p.screen_width_px = j.at("screen_width_px");
    p.screen_height_px = j.at("screen_height_px");
    p.vertical_fov_deg = j.at("vertical_fov_deg");
    p.d_min_from_data = j.at("d_min_from_data");
    p.filter = atlas::filterFromName(j.at("filter").get<std::string>()).value();
    p.packing = atlas::packingMethodFromName(j.at("packing").get<std::string>()).value();
    p.unique_charts = j.value("unique_charts", false);
    p.critical_fraction = j.at("critical_fraction");
    p.cache_mb = j.at("cache_mb");
    return p;
}

json tilesParamsJson(const tiles::TilesParams& p) {
    return {{"position_bits", p.draco.position_bits},
            {"uv_bits", p.draco.uv_bits},
            {"uv_original_bits", p.draco.uv_original_bits},
            {"speed", p.draco.speed},
            {"position_error_target_m", p.position_error_target_m},
            {"uv_original_error_target_texels", p.uv_original_error_target_texels},
            {"bc_quality", std::string(tiles::bcQualityName(p.bc_quality))},
            {"node_triangles", p.node_triangles},
            {"feature_block_size", p.feature_block_size},
            {"all_originals", p.all_originals},
            {"split_originals", p.split_originals},
            {"atlas_png", p.atlas_png}};
}
tiles::TilesParams tilesParamsFrom(const json& j) {
    tiles::TilesParams p;
    p.draco.position_bits = j.at("position_bits");
    p.draco.uv_bits = j.at("uv_bits");
    p.draco.uv_original_bits = j.at("uv_original_bits");
    p.draco.speed = j.at("speed");
    p.position_error_target_m = j.at("position_error_target_m");
    p.uv_original_error_target_texels = j.at("uv_original_error_target_texels");
    p.bc_quality = tiles::bcQualityFromName(j.at("bc_quality").get<std::string>()).value();
    p.node_triangles = j.at("node_triangles");
    p.feature_block_size = j.at("feature_block_size");
    p.all_originals = j.at("all_originals");
    p.split_originals = j.at("split_originals");
    p.atlas_png = j.at("atlas_png");
    return p;
}

json globalsJson(const atlas::GlobalDecisions& g) {
    json candidates = json::array();
    for (const auto& c : g.d_min_choice.candidates) candidates.push_back({c.d_m, c.ratio, c.originals_within_mb});
    return {{"scene_diagonal_m", g.scene_diagonal_m},
            {"d_min_choice", {{"rule", g.d_min_choice.rule},
                              {"reason", g.d_min_choice.reason},
                              {"estimated_ratio", g.d_min_choice.estimated_ratio},
                              {"originals_within_m_mb", g.d_min_choice.originals_within_m_mb},
                              {"candidates", candidates}}},
            {"d_min_requested_m", g.d_min_requested_m},
            {"d_min_used_m", g.d_min_used_m},
            {"d_full_m", g.d_full_m},
            {"d_first_upsampled_m", g.d_first_upsampled_m},
            {"textured_triangles", g.textured_triangles},
            {"degenerate_uv_triangles", g.degenerate_uv_triangles},
            {"critical_triangles", g.critical_triangles},
            {"enlarged_for_split_budget", g.enlarged_for_split_budget}};
}
atlas::GlobalDecisions globalsFrom(const json& j) {
    atlas::GlobalDecisions g;
    g.scene_diagonal_m = j.at("scene_diagonal_m");
    const json& c = j.at("d_min_choice");
    g.d_min_choice.rule = c.at("rule");
    g.d_min_choice.reason = c.at("reason");
    g.d_min_choice.estimated_ratio = c.at("estimated_ratio");
    g.d_min_choice.originals_within_m_mb = c.at("originals_within_m_mb");
    for (const json& k : c.at("candidates")) g.d_min_choice.candidates.push_back({k.at(0), k.at(1), k.at(2)});
    g.d_min_requested_m = j.at("d_min_requested_m");
    g.d_min_used_m = j.at("d_min_used_m");
    g.d_full_m = j.at("d_full_m");
    g.d_first_upsampled_m = j.at("d_first_upsampled_m");
    g.textured_triangles = j.at("textured_triangles");
    g.degenerate_uv_triangles = j.at("degenerate_uv_triangles");
    g.critical_triangles = j.at("critical_triangles");
    g.enlarged_for_split_budget = j.at("enlarged_for_split_budget");
    return g;
}

// Per texture, its tileset number and whether the plan promoted it, as
// binary (texture_plan.bin): in plan.json they were two JSON arrays of a
// city's textures, ~30 bytes a texture as a DOM in the plan, every shard and
// the merge.
constexpr const char* kTexturePlanFile = "texture_plan.bin";

Status writeTexturePlan(const fs::path& dir, const tiles::TextureIndex& texture_index,
                        const std::vector<uint8_t>& promote) {
    const fs::path path = dir / kTexturePlanFile;
    std::ofstream f(path, std::ios::binary);
    if (!f) return Status::Io(fmt::format("{}: cannot create", path.string()));
    writeColumn(f, texture_index);
    writeVector(f, promote);
    f.close();
    if (!f) return Status::Io(fmt::format("{}: cannot write (disk full?)", path.string()));
    return Status::Ok();
}

// With `only` (ascending scene textures), theirs alone, in that order (a
// shard's); else the whole city's index, and the promotions unless
// `promote` is null (the merge: skipped, not held).
Status readTexturePlan(const fs::path& dir, tiles::TextureIndex* texture_index, std::vector<uint8_t>* promote,
                       const std::vector<int32_t>* only = nullptr) {
    const fs::path path = dir / kTexturePlanFile;
    std::ifstream f(path, std::ios::binary);
    if (!f) return Status::Io(fmt::format("{}: cannot open", path.string()));
    const Status bad = Status::Io(fmt::format("{}: truncated or not a texture plan of this cityatlas version", path.string()));
    *texture_index = tiles::makeTextureIndex(dir);
    if (only) {
        std::vector<int32_t> index;
        if (!readVectorAt(f, *only, &index) || !readVectorAt(f, *only, promote) || promote->size() != index.size())
            return bad;
        for (const int32_t t : index) texture_index->push_back(t);
        return Status::Ok();
    }
    if (!readColumn(f, texture_index)) return bad;
    const uint64_t n = texture_index->size();
    if (promote) return readVector(f, promote) && promote->size() == n ? Status::Ok() : bad;
    uint64_t promotions = 0;  // their count must agree, and the file hold them
    if (!f.read(reinterpret_cast<char*>(&promotions), sizeof promotions) || promotions != n) return bad;
    const std::streamoff at = f.tellg();
    std::error_code ec;
    const uint64_t bytes = fs::file_size(path, ec);
    return !ec && at >= 0 && static_cast<uint64_t>(at) + n <= bytes ? Status::Ok() : bad;
}

// --- Scene tables.
// Materials and the georeference as JSON (tables.json); the textures, a
// million at city scale, with their file digests in textures.bin, streamed both
// ways (as a DOM their JSON took ~0.4 KB each in the plan, every shard and the merge).
constexpr const char* kTextureTableMagic = "cityatlas-textures-1";

Status writeTextureTable(const fs::path& path, const TextureTable& textures, const DigestAt& digest) {
    std::ofstream f(path, std::ios::binary);
    if (!f) return Status::Io(fmt::format("{}: cannot create", path.string()));
    auto put = [&](auto v) { f.write(reinterpret_cast<const char*>(&v), sizeof v); };
    f.write(kTextureTableMagic, static_cast<std::streamsize>(std::strlen(kTextureTableMagic)));
    put(static_cast<uint64_t>(textures.size()));
    for (size_t t = 0; t < textures.size(); ++t) {
        const TextureRef r = textures.ref(t);
        const TextureDigest d = digest(t);
        put(static_cast<uint32_t>(r.path.size()));
        f.write(r.path.data(), static_cast<std::streamsize>(r.path.size()));
        put(static_cast<int32_t>(r.width_px)), put(static_cast<int32_t>(r.height_px)), put(static_cast<int32_t>(r.channels));
        put(static_cast<uint8_t>(r.wrap)), put(static_cast<uint8_t>(d.readable)), put(d.xxh3), put(d.bytes);
    }
    f.close();
    if (!f) return Status::Io(fmt::format("{}: cannot write (disk full?)", path.string()));
    return Status::Ok();
}

// With `only` (ascending scene textures), theirs alone, in that order.
Status readTextureTable(const fs::path& path, TextureTable* textures, RecordFile<TextureDigest>* digests,
                        const std::vector<int32_t>* only = nullptr) {
    std::ifstream f(path, std::ios::binary);
    if (!f) return Status::Io(fmt::format("{}: cannot open", path.string()));
    auto get = [&](auto* v) { return static_cast<bool>(f.read(reinterpret_cast<char*>(v), sizeof *v)); };
    const auto bad = [&](const char* what) { return Status::Io(fmt::format("{}: {}", path.string(), what)); };
    std::string magic(std::strlen(kTextureTableMagic), '\0');
    uint64_t n = 0;
    if (!f.read(magic.data(), static_cast<std::streamsize>(magic.size())) || magic != kTextureTableMagic || !get(&n))
        return bad("not a texture table of this cityatlas version");
    textures->clear();
    textures->setScratchDir(path.parent_path());  // a city's paths beside the plan, not in memory
    size_t k = 0;  // in `only`
    for (uint64_t t = 0; t < n; ++t) {
        uint32_t len = 0;
        int32_t w = 0, h = 0, c = 0;
        uint8_t wrap = 0, readable = 0;
        uint64_t bytes = 0;
        TextureDigest d;
        if (!get(&len) || len > (1u << 20)) return bad("truncated");
        const bool wanted = !only || (k < only->size() && static_cast<uint64_t>((*only)[k]) == t);
        if (!wanted) {
            if (!f.ignore(len + 3 * sizeof(int32_t) + 2 * sizeof(uint8_t) + sizeof d.xxh3 + sizeof bytes)) return bad("truncated");
            continue;
        }
        ++k;
        TextureRef r;
        r.path.resize(len);
        if (!f.read(r.path.data(), len) || !get(&w) || !get(&h) || !get(&c) || !get(&wrap) || !get(&readable) ||
            !get(&d.xxh3) || !get(&bytes))
            return bad("truncated");
        r.width_px = w, r.height_px = h, r.channels = c, r.wrap = static_cast<WrapMode>(wrap);
        d.bytes = bytes;
        d.readable = readable != 0;
        textures->push_back(std::move(r));
        if (digests)
            if (Status s = digests->append(d); !s.ok()) return s;
    }
    if (only && k != only->size()) return bad("names fewer textures than the shard's triangles use");
    return Status::Ok();
}

json tablesJson(const Scene& s) {
    json materials = json::array();
    for (const Material& m : s.materials) materials.push_back({m.diffuse[0], m.diffuse[1], m.diffuse[2], m.transparency});
    const Georeference& g = s.georef;
    json georef = {{"source_crs", g.source_crs},
                   {"origin_source", vec3(g.origin_source)},
                   {"grid_frame", g.grid_frame},
                   {"local_to_ecef", g.local_to_ecef ? json(*g.local_to_ecef) : json(nullptr)},
                   {"enu_to_ecef", g.enu_to_ecef ? json(*g.enu_to_ecef) : json(nullptr)}};
    return {{"materials", materials}, {"georef", georef}};
}
void tablesFromJson(const json& j, Scene* s) {
    for (const json& m : j.at("materials")) s->materials.push_back({{m.at(0), m.at(1), m.at(2)}, m.at(3)});
    const json& g = j.at("georef");
    s->georef.source_crs = g.at("source_crs");
    s->georef.origin_source = vec3From(g.at("origin_source"), 0);
    s->georef.grid_frame = g.at("grid_frame");
    if (!g.at("local_to_ecef").is_null()) s->georef.local_to_ecef = g.at("local_to_ecef").get<std::array<double, 16>>();
    if (!g.at("enu_to_ecef").is_null()) s->georef.enu_to_ecef = g.at("enu_to_ecef").get<std::array<double, 16>>();
}

// The plan's scene tables: tables.json and textures.bin (`digests` may be null).
Status readPlanTables(const fs::path& dir, Scene* s, RecordFile<TextureDigest>* digests) {
    json tables;
    if (Status st = readJson(dir / "tables.json", &tables); !st.ok()) return st;
    tablesFromJson(tables, s);
    return readTextureTable(dir / "textures.bin", &s->textures, digests);
}

// --- A shard's nodes and records (what the merge needs of them).
json nodeJson(const atlas::AtlasNode& n) {
    json layers = json::array();
    for (const atlas::NodeLayer& l : n.layers)
        layers.push_back({{"count", l.range.count}, {"atlas", !l.atlas_path.empty()}, {"width", l.width},
                          {"height", l.height}});
    return {{"parent", n.parent},
            {"children", n.children},
            {"level", n.level},
            {"bounds", n.bounds.empty() ? json(nullptr) : json::array({vec3(n.bounds.min), vec3(n.bounds.max)})},
            {"min_distance_m", n.min_distance_m},
            {"sharp_from_m", n.sharp_from_m},
            {"layers", layers},
            {"originals", n.originals}};
}
atlas::AtlasNode nodeFrom(const json& j) {
    atlas::AtlasNode n;
    n.parent = j.at("parent");
    n.children = j.at("children").get<std::array<int32_t, 4>>();
    n.level = j.at("level");
    if (!j.at("bounds").is_null()) {
        n.bounds.extend(vec3From(j.at("bounds").at(0), 0));
        n.bounds.extend(vec3From(j.at("bounds").at(1), 0));
    }
    n.min_distance_m = j.at("min_distance_m");
    n.sharp_from_m = j.at("sharp_from_m");
    for (size_t l = 0; l < atlas::kLayerCount; ++l) {
        const json& x = j.at("layers").at(l);
        n.layers[l].range.count = x.at("count");
        if (x.at("atlas").get<bool>()) n.layers[l].atlas_path = "atlas";  // named again by assembleTree
        n.layers[l].width = x.at("width");
        n.layers[l].height = x.at("height");
    }
    n.originals = j.at("originals").get<std::vector<int32_t>>();
    return n;
}

json recordJson(const tiles::NodeRecord& r) {
    json layers = json::array();
    for (const tiles::LayerRecord& l : r.layers)
        layers.push_back({{"present", l.present},
                          {"triangles", l.triangles},
                          {"triangles_source", l.triangles_source},
                          {"geometry_uri", l.geometry_uri},
                          {"geometry_bytes", l.geometry_bytes},
                          {"geometric_error_m", num(l.geometric_error_m)},
                          {"position_error_m", num(l.position_error_m)},
                          {"uv_atlas_error_texels", num(l.uv_atlas_error_texels)},
                          {"uv_original_error_texels", num(l.uv_original_error_texels)},
                          {"position_bits", l.position_bits},
                          {"uv_original_bits", l.uv_original_bits},
                          {"simplified", l.simplified},
                          {"left_out_over_cap", l.left_out_over_cap},
                          {"atlas_uri", l.atlas_uri},
                          {"atlas_bytes", l.atlas_bytes},
                          {"atlas_mips", l.atlas_mips},
                          {"atlas_psnr_db", num(l.atlas_psnr_db)},
                          {"atlas_texels", l.atlas_texels}});
    return {{"layers", layers}, {"features", r.features}, {"dropped", r.dropped}};
}
tiles::NodeRecord recordFrom(const json& j) {
    tiles::NodeRecord r;
    const double inf = std::numeric_limits<double>::infinity();
    for (size_t k = 0; k < atlas::kLayerCount; ++k) {
        const json& x = j.at("layers").at(k);
        tiles::LayerRecord& l = r.layers[k];
        l.present = x.at("present");
        l.triangles = x.at("triangles");
        l.triangles_source = x.at("triangles_source");
        l.geometry_uri = x.at("geometry_uri");
        l.geometry_bytes = x.at("geometry_bytes");
        l.geometric_error_m = numOr(x.at("geometric_error_m"), inf);
        l.position_error_m = numOr(x.at("position_error_m"), inf);
        l.uv_atlas_error_texels = numOr(x.at("uv_atlas_error_texels"), inf);
        l.uv_original_error_texels = numOr(x.at("uv_original_error_texels"), inf);
        l.position_bits = x.at("position_bits");
        l.uv_original_bits = x.at("uv_original_bits");
        l.simplified = x.at("simplified");
        l.left_out_over_cap = x.value("left_out_over_cap", size_t{0});  // absent before writer revision 11
        l.atlas_uri = x.at("atlas_uri");
        l.atlas_bytes = x.at("atlas_bytes");
        l.atlas_mips = x.at("atlas_mips");
        l.atlas_psnr_db = numOr(x.at("atlas_psnr_db"), inf);  // +inf: BC reproduced the atlas exactly
        l.atlas_texels = x.at("atlas_texels");
    }
    r.features = j.at("features").get<std::vector<uint32_t>>();
    r.dropped = j.at("dropped").get<std::vector<uint32_t>>();
    return r;
}

Status writeMesh(const fs::path& path, const TileMesh& m, double geometric_error_m, size_t triangles_source,
                 bool simplified) {
    std::ofstream f(path, std::ios::binary);
    const double head[3] = {geometric_error_m, static_cast<double>(triangles_source), simplified ? 1.0 : 0.0};
    f.write(reinterpret_cast<const char*>(head), sizeof head);
    writeVector(f, m.positions);
    writeVector(f, m.uv_original);
    writeVector(f, m.uv_atlas);
    writeVector(f, m.feature_id);
    writeVector(f, m.texture_id);
    writeVector(f, m.material_id);
    writeVector(f, m.indices);
    f.close();
    if (!f) return Status::Io(fmt::format("{}: cannot write", path.string()));
    return Status::Ok();
}
Status readMesh(const fs::path& path, tiles::NodeGeometry* g) {
    std::ifstream f(path, std::ios::binary);
    double head[3] = {0, 0, 0};
    TileMesh& m = g->mesh;
    const bool ok = f.read(reinterpret_cast<char*>(head), sizeof head) && readVector(f, &m.positions) &&
                    readVector(f, &m.uv_original) && readVector(f, &m.uv_atlas) && readVector(f, &m.feature_id) &&
                    readVector(f, &m.texture_id) && readVector(f, &m.material_id) && readVector(f, &m.indices);
    if (!ok) return Status::Io(fmt::format("{}: not a shard root mesh (truncated?)", path.string()));
    g->geometric_error_m = head[0];
    g->triangles_source = static_cast<size_t>(head[1]);
    g->simplified = head[2] != 0;
    return Status::Ok();
}

json statsJson(const atlas::AtlasStats& s) {
    return {{"atlases", s.atlases},
            {"critical_after_enlarge", s.critical_after_enlarge},
            {"triangles_split", s.triangles_split},
            {"triangles_added_by_split", s.triangles_added_by_split},
            {"packed_texels", s.packed_texels},
            {"leaf_atlas_texels", s.leaf_atlas_texels},
            {"original_texture_bytes", s.original_texture_bytes},
            {"atlas_texture_bytes", s.atlas_texture_bytes},
            {"leaves_below_resolution", s.leaves_below_resolution},
            {"textures_upsampled", s.textures_upsampled},
            {"textures_exact", s.textures_exact},
            {"textures_needing_originals", s.textures_needing_originals},
            {"texels", {s.texels.content_required, s.texels.content_native, s.texels.repeats, s.texels.borders,
                        s.texels.rounding, s.texels.empty, s.texels.inner}},
            {"bytes", {s.bytes.atlases, s.bytes.originals_used, s.bytes.originals_needed}}};
}
void addStats(const json& j, atlas::AtlasStats* s) {
    s->atlases += j.at("atlases").get<uint64_t>();
    s->critical_after_enlarge += j.at("critical_after_enlarge").get<uint64_t>();
    s->triangles_split += j.at("triangles_split").get<uint64_t>();
    s->triangles_added_by_split += j.at("triangles_added_by_split").get<uint64_t>();
    s->packed_texels += j.at("packed_texels").get<uint64_t>();
    s->leaf_atlas_texels += j.at("leaf_atlas_texels").get<uint64_t>();
    s->original_texture_bytes += j.at("original_texture_bytes").get<uint64_t>();
    s->atlas_texture_bytes += j.at("atlas_texture_bytes").get<uint64_t>();
    s->leaves_below_resolution += j.at("leaves_below_resolution").get<uint64_t>();
    s->textures_upsampled += j.at("textures_upsampled").get<uint64_t>();
    s->textures_exact += j.at("textures_exact").get<uint64_t>();
    s->textures_needing_originals += j.at("textures_needing_originals").get<uint64_t>();
    const json& t = j.at("texels");
    s->texels.content_required += t.at(0).get<uint64_t>();
    s->texels.content_native += t.at(1).get<uint64_t>();
    s->texels.repeats += t.at(2).get<uint64_t>();
    s->texels.borders += t.at(3).get<uint64_t>();
    s->texels.rounding += t.at(4).get<uint64_t>();
    s->texels.empty += t.at(5).get<uint64_t>();
    s->texels.inner += t.at(6).get<uint64_t>();
    const json& b = j.at("bytes");
    s->bytes.atlases += b.at(0).get<uint64_t>();
    s->bytes.originals_used += b.at(1).get<uint64_t>();
    s->bytes.originals_needed += b.at(2).get<uint64_t>();
}

std::string shardName(int k) { return fmt::format("shard-{}", k); }

// A shard file at its place in the merged folder: a hard link (the shard
// keeps its files for the next build to reuse), or a copy where links fail.
// One already there (a merge that stopped, then ran again) is replaced.
Status linkFile(const fs::path& from, const fs::path& to) {
    std::error_code ec;
    fs::create_directories(to.parent_path(), ec);
    if (!ec) fs::remove(to, ec);
    if (!ec) fs::create_hard_link(from, to, ec);
    if (ec) fs::copy_file(from, to, fs::copy_options::overwrite_existing, ec);
    if (ec) return Status::Io(fmt::format("{}: cannot link to {}: {}", from.string(), to.string(), ec.message()));
    return Status::Ok();
}

// The plan's computed textures (absent: none).
Status planComputed(const json& plan, std::vector<atlas::ComputedSpec>* out) {
    out->clear();
    if (!plan.contains("computed")) return Status::Ok();
    for (const json& c : plan.at("computed")) {
        atlas::ComputedSpec spec;
        if (Status s = atlas::computedSpecFromJson(c, &spec); !s.ok()) return s;
        out->push_back(spec);
    }
    return Status::Ok();
}

// Per node of a tree: its computed files by layer, each aligned with the plan's computed textures.
using ComputedFiles = std::vector<std::array<std::vector<format::ComputedFileEntry>, atlas::kLayerCount>>;

json computedFileJson(const format::ComputedFileEntry& f) {
    return f.file.uri.empty() ? json(nullptr)
                              : json::array({f.file.uri, f.file.bytes, f.width_px, f.height_px, f.mips});
}
format::ComputedFileEntry computedFileFrom(const json& j) {
    format::ComputedFileEntry f;
    if (j.is_null()) return f;
    f.file = {j.at(0).get<std::string>(), j.at(1).get<uint64_t>()};
    f.width_px = j.at(2), f.height_px = j.at(3), f.mips = j.at(4);
    return f;
}
json computedStatsJson(const atlas::ComputedStats& s) {
    return {s.texels, s.texels ? json(s.min) : json(nullptr), s.texels ? json(s.max) : json(nullptr), s.sum};
}
void addComputedStats(const json& j, atlas::ComputedStats* s) {
    atlas::ComputedStats x;
    x.texels = j.at(0);
    if (x.texels) x.min = j.at(1), x.max = j.at(2);
    x.sum = j.at(3);
    s->add(x);
}
std::string rootComputedFile(size_t k, int layer) { return fmt::format("root-computed-{}-{}.f32", k, layer); }

// Every computed texture of `tree` into `out_dir` (files[node][layer][k]):
// leaves evaluated against `caster`, inner nodes from their children, nodes
// in `given[k]` taken as they are. `roots[k]` (optional) gets the root's images.
Status writeComputedTextures(const std::vector<atlas::ComputedSpec>& specs, const atlas::AtlasTree& tree,
                             const atlas::RayCaster* caster, const Georeference& georef,
                             const std::vector<const atlas::VisibilityTarget*>& targets,
                             const std::vector<atlas::GivenComputed>* given, int threads, tiles::BcQuality quality,
                             const fs::path& out_dir, ComputedFiles* files,
                             std::vector<std::array<atlas::ScalarImage, atlas::kLayerCount>>* roots,
                             std::vector<atlas::ComputedStats>* stats, const ShardProgressFn& progress) {
    files->assign(tree.nodes.size(), {});
    for (auto& node : *files)
        for (auto& layer : node) layer.resize(specs.size());
    if (roots) roots->assign(specs.size(), {});
    stats->assign(specs.size(), {});
    for (size_t k = 0; k < specs.size(); ++k) {
        atlas::SurfaceField field;
        if (caster)
            if (Status s = atlas::makeSurfaceField(specs[k], *caster, georef, &field, k < targets.size() ? targets[k] : nullptr);
                !s.ok())
                return s;
        uint64_t done = 0;
        std::mutex progress_mutex;
        const std::string step = fmt::format("computed: {}", specs[k].name());
        const auto sink = [&](int32_t node, atlas::Layer layer, const atlas::ScalarImage& image) {
            if (image.width <= 0) return Status::Ok();
            if (progress) {
                const std::lock_guard<std::mutex> lock(progress_mutex);
                progress(step.c_str(), ++done, tree.nodes.size() * atlas::kLayerCount);
            }
            return tiles::writeComputedImage(image, quality, out_dir, tiles::computedUri(k, layer, node),
                                             &(*files)[static_cast<size_t>(node)][static_cast<size_t>(layer)][k]);
        };
        if (Status s = atlas::computeTreeImages(tree, specs[k].scale, field, threads, sink, given ? &(*given)[k] : nullptr,
                                                roots ? &(*roots)[k] : nullptr, &(*stats)[k]);
            !s.ok())
            return s;
    }
    return Status::Ok();
}
std::string layerFile(const char* what, int l) {
    return fmt::format("{}-{}.bin", what, atlas::layerName(static_cast<Layer>(l)));
}

}  // namespace

nlohmann::json diagnosticsToJson(const Diagnostics& d) {
    json w = json::array();
    for (const auto& [code, e] : d.entries()) {
        json examples = json::array();
        for (const DiagnosticExample& x : e.examples) examples.push_back({x.file, x.line, x.gml_id, x.detail});
        w.push_back({{"code", code}, {"count", e.count}, {"examples", examples}});
    }
    return w;
}
// The shard's warnings into the build's: the counts add up, the first examples are kept.
void addDiagnostics(const nlohmann::json& w, Diagnostics& d) {
    for (const json& e : w) {
        const std::string code = e.at("code");
        const auto& examples = e.at("examples");
        const uint64_t count = e.at("count");
        for (uint64_t k = 0; k < count; ++k) {
            DiagnosticExample x;
            if (k < examples.size()) {
                const json& ex = examples.at(k);
                x = {ex.at(0), ex.at(1), ex.at(2), ex.at(3)};
            }
            d.warn(code.c_str(), x);
        }
    }
}

namespace {

// A shard's content key: everything its files depend on (cli/shards.h,
// "Incremental rebuilds"), hashed field by field (a triangle's padding bytes
// are not part of it).
class ShardKey {
public:
    ShardKey() : state_(XXH3_createState(), &XXH3_freeState) { XXH3_64bits_reset(state_.get()); }
    void add(const void* data, size_t n) { XXH3_64bits_update(state_.get(), data, n); }
    void add(const std::string& s) {
        const uint64_t n = s.size();
        add(&n, sizeof n);
        add(s.data(), s.size());
    }
    template <typename T>
    void addValue(const T& v) {
        static_assert(std::is_arithmetic_v<T>);
        add(&v, sizeof v);
    }
    void add(const Triangle& t) {
        for (const Vec3d& p : t.position_local) addValue(p.x), addValue(p.y), addValue(p.z);
        for (const Vec2d& u : t.uv) addValue(u.x), addValue(u.y);
        addValue(t.texture), addValue(t.material), addValue(t.feature), addValue(static_cast<uint8_t>(t.semantic));
    }
    std::string digest() const { return fmt::format("{:016x}", XXH3_64bits_digest(state_.get())); }

private:
    std::unique_ptr<XXH3_state_t, decltype(&XXH3_freeState)> state_;
};

}  // namespace

Status forEachSpilled(const fs::path& spill, const std::function<void(const Triangle&)>& fn, const char* step,
                      const ShardProgressFn& progress) {
    std::ifstream f(spill, std::ios::binary);
    if (!f) return Status::Io(fmt::format("{}: cannot open", spill.string()));
    std::error_code ec;
    const uint64_t total = fs::file_size(spill, ec);
    uint64_t done = 0;
    std::vector<Triangle> chunk(1 << 14);
    while (f) {
        f.read(reinterpret_cast<char*>(chunk.data()), static_cast<std::streamsize>(chunk.size() * sizeof(Triangle)));
        const auto got = static_cast<size_t>(f.gcount());
        if (got % sizeof(Triangle) != 0) return Status::Io(fmt::format("{}: truncated", spill.string()));
        for (size_t i = 0; i < got / sizeof(Triangle); ++i) fn(chunk[i]);
        done += got;
        if (progress && step) progress(step, done, total);
    }
    if (f.bad()) return Status::Io(fmt::format("{}: cannot read", spill.string()));
    return Status::Ok();
}

Status readSpill(const fs::path& spill, std::vector<Triangle>* out) {
    std::error_code ec;
    const auto bytes = fs::file_size(spill, ec);
    if (ec || bytes % sizeof(Triangle) != 0) return Status::Io(fmt::format("{}: not a triangle spill file", spill.string()));
    out->resize(bytes / sizeof(Triangle));
    std::ifstream f(spill, std::ios::binary);
    f.read(reinterpret_cast<char*>(out->data()), static_cast<std::streamsize>(bytes));
    if (!f) return Status::Io(fmt::format("{}: cannot read", spill.string()));
    return Status::Ok();
}

PlanSink::PlanSink(fs::path spill, fs::path feature_spill_path)
    : feature_spill(std::move(feature_spill_path)),
      features(spill.parent_path()),
      bounds(spill.parent_path()),
      spill_(std::move(spill)),
      file_(spill_, std::ios::binary) {}

void PlanSink::addTriangles(std::vector<Triangle>& t) {
    for (const Triangle& tri : t) {
        stats.add(tri);
        features.add(tri);
        bounds.add(tri);
    }
    file_.write(reinterpret_cast<const char*>(t.data()), static_cast<std::streamsize>(t.size() * sizeof(Triangle)));
    triangles += t.size();
    t.clear();
}

Status PlanSink::finish() {
    if (Status s = feature_spill.finish(); !s.ok()) return s;
    file_.close();
    if (!file_) return Status::Io(fmt::format("{}: cannot write (disk full?)", spill_.string()));
    return Status::Ok();
}

Status addProceduralFacades(const fs::path& spill, const FeatureSpill& features, const ProceduralFacadeParams& params,
                            const fs::path& dir, Scene* tables, tiles::FeatureBoundsAccumulator* bounds, uint64_t* walls) {
    // Each feature's walls: lowest and highest point, and the box corner u starts from.
    struct Walls {
        double z0 = 1e300, z1 = -1e300, x0 = 1e300, y0 = 1e300;
    };
    std::vector<Walls> extent(features.size());
    if (Status s = forEachSpilled(spill, [&](const Triangle& t) {
            if (t.feature >= extent.size() || !isBareWall(t)) return;
            Walls& w = extent[t.feature];
            for (const Vec3d& p : t.position_local)
                w.z0 = std::min(w.z0, p.z), w.z1 = std::max(w.z1, p.z), w.x0 = std::min(w.x0, p.x), w.y0 = std::min(w.y0, p.y);
        });
        !s.ok())
        return s;
    // Attributes: a part takes its building's id (the palette) and, lacking its own, its storeys.
    struct Attributes {
        int32_t parent = -1;
        std::string id;
        std::optional<double> storeys, storey_height;
    };
    std::vector<Attributes> attributes(features.size());
    if (Status s = features.forEach([&](uint32_t id, Feature&& f) {
            if (id < attributes.size())
                attributes[id] = {f.parent, std::move(f.gml_id), storeysAttribute(f), storeyHeightAttribute(f)};
            return Status::Ok();
        });
        !s.ok())
        return s;
    std::vector<FacadeLayout> layout(features.size());
    std::vector<int32_t> texture_of_palette(facadePalettes().size(), -1);
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) return Status::Io(fmt::format("{}: cannot create: {}", dir.string(), ec.message()));
    for (size_t f = 0; f < features.size(); ++f) {
        if (extent[f].z1 < extent[f].z0) continue;
        size_t root = f;
        for (int guard = 0; attributes[root].parent >= 0 && static_cast<size_t>(attributes[root].parent) < attributes.size() &&
                            guard < 64;
             ++guard)
            root = static_cast<size_t>(attributes[root].parent);
        const Attributes& a = attributes[f];
        const Attributes& r = attributes[root];
        layout[f] = facadeLayout(r.id, extent[f].z0, extent[f].z1, a.storeys ? a.storeys : r.storeys,
                                 a.storey_height ? a.storey_height : r.storey_height, params);
        layout[f].origin = {extent[f].x0, extent[f].y0, 0};
        int32_t& texture = texture_of_palette[layout[f].palette];
        if (texture >= 0) continue;
        const fs::path png = dir / fmt::format("facade-{}.png", layout[f].palette);
        std::string error;
        if (!synth::writePng(png.string(), facadeCell(facadePalettes()[layout[f].palette], params.cell_px), &error))
            return Status::Io(error);
        texture = static_cast<int32_t>(tables->textures.size());
        tables->textures.push_back({png.string(), params.cell_px, params.cell_px, 3, WrapMode::Wrap});
    }
    // The spill again, bare walls textured.
    const fs::path rewritten = spill.string() + ".facades";
    std::ofstream out(rewritten, std::ios::binary);
    if (!out) return Status::Io(fmt::format("{}: cannot create", rewritten.string()));
    *walls = 0;
    if (Status s = forEachSpilled(spill, [&](const Triangle& t) {
            Triangle copy = t;
            if (copy.feature < layout.size() && isBareWall(copy) && extent[copy.feature].z1 >= extent[copy.feature].z0) {
                const FacadeLayout& l = layout[copy.feature];
                applyFacade(l, params, texture_of_palette[l.palette], &copy);
                ++*walls;
                if (bounds) bounds->add(copy);
            }
            out.write(reinterpret_cast<const char*>(&copy), sizeof copy);
        });
        !s.ok())
        return s;
    out.close();
    if (!out) return Status::Io(fmt::format("{}: cannot write (disk full?)", rewritten.string()));
    fs::rename(rewritten, spill, ec);
    if (ec) return Status::Io(fmt::format("{}: cannot rename to {}: {}", rewritten.string(), spill.string(), ec.message()));
    return Status::Ok();
}

namespace {

std::string targetFile(size_t k) { return fmt::format("computed-{}.target", k); }

// Which shards use which entries of a table (textures, materials), for the
// shards' keys. Most entries are one shard's (a wall's image), so per entry
// its first shard and the few other (shard, entry) pairs aside: a byte per
// shard and entry was shards x entries (160 shards x 10 M textures: 1.6 GB).
// The first shards in a column whose memory stops at 16 MiB (since stop 54;
// the triangles come in scene order, so their entries' pages mostly do too).
class ShardUse {
public:
    explicit ShardUse(size_t entries, const fs::path& scratch_dir)
        : first_(scratch_dir, "the entries' first shards", TextureTable::defaultMemoryBytes() / 4) {
        for (size_t e = 0; e < entries; ++e) first_.push_back(-1);
    }
    void add(size_t shard, size_t entry) {
        const int32_t f = first_[entry];
        if (f < 0) first_.set(entry, static_cast<int32_t>(shard));
        else if (static_cast<size_t>(f) != shard) also_.insert({shard, entry});  // no node made when present
    }
    bool used(size_t entry) const { return first_[entry] >= 0; }
    /// Per shard, the entries it uses, ascending.
    std::vector<std::vector<uint32_t>> byShard(size_t shards) const {
        std::vector<std::vector<uint32_t>> out(shards);
        for (size_t e = 0; e < first_.size(); ++e)
            if (const int32_t f = first_[e]; f >= 0) out[static_cast<size_t>(f)].push_back(static_cast<uint32_t>(e));
        for (const auto& [shard, entry] : also_) out[shard].push_back(static_cast<uint32_t>(entry));
        for (std::vector<uint32_t>& list : out) std::sort(list.begin(), list.end());
        return out;
    }

private:
    PagedColumn<int32_t> first_;
    std::set<std::pair<size_t, size_t>> also_;
};

// A visibility target's triangles (positions, in scene order).
Status readTarget(const fs::path& spill, const atlas::ComputedSpec& spec, std::vector<std::array<Vec3d, 3>>* out) {
    const std::set<uint32_t> features(spec.target_features.begin(), spec.target_features.end());
    out->clear();
    if (Status s = forEachSpilled(spill, [&](const Triangle& t) {
            if (features.count(t.feature)) out->push_back(t.position_local);
        });
        !s.ok())
        return s;
    if (out->empty())
        return Status::Usage(fmt::format("--computed visibility:{}: the building has no triangles in the inputs", spec.building));
    return Status::Ok();
}

// Each shard's occluders (writePlan): the other shards' triangles whose box
// meets the shard's box grown by the margin, in scene order, as positions;
// they enter the shard's key.
Status writeOccluders(const fs::path& dir, const fs::path& spill, const atlas::ShardPlan& plan,
                      const std::vector<atlas::ComputedSpec>& computed, const std::vector<Box3d>& shard_box,
                      std::vector<ShardKey>& keys, const ShardProgressFn& progress) {
    double horizon = 0;
    for (const atlas::ComputedSpec& c : computed) horizon = std::max(horizon, c.horizon_m);
    const double margin = occluderMargin(horizon);
    std::vector<Box3d> reach(shard_box.size());
    for (size_t k = 0; k < reach.size(); ++k)
        if (!shard_box[k].empty()) {
            const Vec3d m{margin, margin, margin};
            reach[k].extend(shard_box[k].min - m), reach[k].extend(shard_box[k].max + m);
        }
    std::vector<std::ofstream> files(plan.shards());
    for (size_t k = 0; k < files.size(); ++k) {
        const fs::path path = dir / fmt::format("{}.occ", shardName(static_cast<int>(k)));
        files[k].open(path, std::ios::binary);
        if (!files[k]) return Status::Io(fmt::format("{}: cannot create", path.string()));
    }
    const Status read = forEachSpilled(spill, [&](const Triangle& t) {
        if (t.feature >= plan.shard_of_feature.size() || plan.shard_of_feature[t.feature] < 0) return;
        const auto own = static_cast<size_t>(plan.shard_of_feature[t.feature]);
        Box3d box;
        for (const Vec3d& p : t.position_local) box.extend(p);
        for (size_t k = 0; k < reach.size(); ++k) {
            if (k == own || reach[k].empty()) continue;
            const Box3d& r = reach[k];
            // Infinite margins (horizon inf) reach everything.
            if (box.max.x < r.min.x || box.min.x > r.max.x || box.max.y < r.min.y || box.min.y > r.max.y ||
                box.max.z < r.min.z || box.min.z > r.max.z)
                continue;
            files[k].write(reinterpret_cast<const char*>(t.position_local.data()), sizeof t.position_local);
            for (const Vec3d& p : t.position_local) keys[k].addValue(p.x), keys[k].addValue(p.y), keys[k].addValue(p.z);
        }
    }, "plan: occluders", progress);
    if (!read.ok()) return read;
    for (size_t k = 0; k < files.size(); ++k) {
        files[k].close();
        if (!files[k]) return Status::Io(fmt::format("{}.occ: cannot write", (dir / shardName(static_cast<int>(k))).string()));
    }
    return Status::Ok();
}

}  // namespace

Status decideGlobalsFromSpill(const fs::path& spill, const Scene& tables, const atlas::AtlasParams& params,
                              atlas::GlobalDecisions* out, const ShardProgressFn& progress) {
    return atlas::decideGlobals(
        tables.textures, params,
        [&](const std::function<void(const Triangle&)>& fn, const char* step) {
            return forEachSpilled(spill, fn, fmt::format("plan: {}", step).c_str(), progress);
        },
        out);
}

Status writePlan(const fs::path& dir, const Scene& tables, const fs::path& spill, const atlas::ShardPlan& plan,
                 const atlas::GlobalDecisions& globals, const atlas::AtlasParams& atlas_params,
                 const tiles::TilesParams& tiles_params, const std::vector<atlas::ComputedSpec>& computed,
                 const DigestAt& texture_digest, const tiles::FeatureTables& ft,
                 std::vector<std::string>* keys_out, const ShardProgressFn& progress) {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) return Status::Io(fmt::format("{}: cannot create: {}", dir.string(), ec.message()));
    json feature_tables = json::array(), feature_bounds = json::array();
    for (const format::FileEntry& e : ft.tables) feature_tables.push_back({e.uri, e.bytes});
    for (const format::FileEntry& e : ft.bounds) feature_bounds.push_back({e.uri, e.bytes});
    if (Status s = writeJson(dir / "tables.json", tablesJson(tables)); !s.ok()) return s;
    if (Status s = writeTextureTable(dir / "textures.bin", tables.textures, texture_digest); !s.ok()) return s;

    // Each shard's triangles in scene order, in one pass over the spill, with their keys.
    std::vector<std::ofstream> files(plan.shards());
    for (size_t k = 0; k < files.size(); ++k) {
        files[k].open(dir / fmt::format("{}.tri", shardName(static_cast<int>(k))), std::ios::binary);
        if (!files[k]) return Status::Io(fmt::format("{}: cannot create", (dir / shardName(static_cast<int>(k))).string()));
    }
    std::vector<ShardKey> keys(plan.shards());
    ShardUse textures_used(tables.textures.size(), dir), materials_used(tables.materials.size(), dir);
    uint64_t scene_triangles = 0, orphans = 0;
    std::vector<Box3d> shard_box(plan.shards());
    const Status read = forEachSpilled(spill, [&](const Triangle& t) {
        // Readers give every triangle a feature of the table; one that is not (a
        // reader's bug) has no shard and is counted rather than read out of bounds.
        if (t.feature >= plan.shard_of_feature.size() || plan.shard_of_feature[t.feature] < 0) {
            ++orphans;
            return;
        }
        const auto k = static_cast<size_t>(plan.shard_of_feature[t.feature]);
        files[k].write(reinterpret_cast<const char*>(&t), sizeof t);
        keys[k].add(t);
        for (const Vec3d& p : t.position_local) shard_box[k].extend(p);
        ++scene_triangles;
        if (t.texture >= 0) textures_used.add(k, static_cast<size_t>(t.texture));
        if (t.material >= 0) materials_used.add(k, static_cast<size_t>(t.material));
    }, "plan: shard files", progress);
    if (!read.ok()) return read;
    if (orphans > 0)
        return Status::Invalid(fmt::format("{}: {} triangles name no feature of the table (an ingest error)", spill.string(),
                                           orphans));
    for (size_t k = 0; k < files.size(); ++k) {
        files[k].close();
        if (!files[k]) return Status::Io(fmt::format("{}.tri: cannot write", (dir / shardName(static_cast<int>(k))).string()));
    }
    if (!computed.empty())
        if (Status s = writeOccluders(dir, spill, plan, computed, shard_box, keys, progress); !s.ok()) return s;
    // A visibility target's triangles go to every shard whatever its horizon.
    std::string targets_key;
    for (size_t k = 0; k < computed.size(); ++k) {
        if (computed[k].model != atlas::ComputedModel::Visibility) continue;
        std::vector<std::array<Vec3d, 3>> target;
        if (Status s = readTarget(spill, computed[k], &target); !s.ok()) return s;
        if (Status s = tiles::writeBytes(dir / targetFile(k), target.data(), target.size() * sizeof target[0]); !s.ok())
            return s;
        ShardKey tk;
        for (const auto& t : target)
            for (const Vec3d& p : t) tk.addValue(p.x), tk.addValue(p.y), tk.addValue(p.z);
        targets_key += " " + tk.digest();
    }
    json top = json::array();
    for (const atlas::PlanNode& n : plan.nodes)
        top.push_back({{"parent", n.parent}, {"children", n.children}, {"level", n.level}, {"shard", n.shard}});
    std::vector<uint8_t> used(tables.textures.size(), 0);
    for (size_t t = 0; t < used.size(); ++t) used[t] = textures_used.used(t) ? 1 : 0;
    const tiles::TextureIndex texture_index =
        tiles::tilesetTextureIndex(used, tables.textures, atlas_params.atlas_size_px, tiles_params.split_originals, dir);
    std::vector<uint8_t>().swap(used);
    if (Status s = writeTexturePlan(dir, texture_index, globals.promote); !s.ok()) return s;
    json j = {{"format", kPlanFormat},
              {"kind", "cityatlas-shard-plan"},
              {"atlas", planAtlasParamsJson(atlas_params)},
              {"tiles", tilesParamsJson(tiles_params)},
              {"globals", globalsJson(globals)},
              {"top", top},
              {"shard_triangles", plan.shard_triangles},
              {"scene_triangles", scene_triangles},
              {"feature_tables", feature_tables},
              {"feature_bounds", feature_bounds},
              {"feature_count", ft.features}};
    if (!computed.empty()) {
        json c = json::array();
        for (const atlas::ComputedSpec& spec : computed) c.push_back(atlas::computedSpecJson(spec));
        j["computed"] = c;
    }
    // Besides its triangles, a shard depends on the parameters, the distance
    // every node is built for, its level, and the textures and materials it
    // uses: their entries, tileset numbers, promotions and file contents.
    const std::string common = fmt::format("{} {} {} {} writer {} computed {}{}", kPlanFormat, j.at("atlas").dump(),
                                           j.at("tiles").dump(), globals.d_min_used_m, tiles::kWriterRevision,
                                           j.value("computed", json::array()).dump(), targets_key);
    std::vector<int> level(plan.shards(), 0);
    for (const atlas::PlanNode& n : plan.nodes)
        if (n.shard >= 0) level[static_cast<size_t>(n.shard)] = n.level;
    std::vector<std::string> key_list;
    const std::vector<std::vector<uint32_t>> textures_of = textures_used.byShard(keys.size());
    const std::vector<std::vector<uint32_t>> materials_of = materials_used.byShard(keys.size());
    for (size_t k = 0; k < keys.size(); ++k) {
        ShardKey& key = keys[k];
        key.add(common);
        key.addValue(level[k]);
        for (const uint32_t t : textures_of[k]) {
            const TextureRef r = tables.textures.ref(t);
            const TextureDigest d = texture_digest(t);
            key.add(fmt::format("texture {} {} {} {} {} {} {} {} {}", t, r.path, r.width_px, r.height_px, r.channels,
                                static_cast<int>(r.wrap), texture_index[t], globals.promote[t],
                                d.readable ? hexDigest(d.xxh3) : "unreadable"));
        }
        for (const uint32_t m : materials_of[k])
            key.add(fmt::format("material {} {} {} {} {}", m, tables.materials[m].diffuse[0],
                                tables.materials[m].diffuse[1], tables.materials[m].diffuse[2],
                                tables.materials[m].transparency));
        key_list.push_back(key.digest());
    }
    j["shard_keys"] = key_list;
    // Inputs, textures and the output folder are named as the user gave them:
    // relative ones start here, wherever a shard or the merge runs.
    j["working_directory"] = fs::current_path().string();
    if (keys_out) *keys_out = key_list;
    return writeJson(dir / "plan.json", j);  // last: a plan folder with plan.json is complete
}

Status enterBuildDirectory(std::string* plan) {
    std::error_code ec;
    const fs::path abs = fs::absolute(*plan, ec).lexically_normal();
    if (ec) return Status::Io(fmt::format("{}: {}", *plan, ec.message()));
    *plan = abs.string();
    if (!fs::exists(abs / "plan.json")) return Status::Ok();  // the command names what is missing
    json j;
    if (Status s = readJson(abs / "plan.json", &j); !s.ok()) return s;
    const std::string dir = j.value("working_directory", std::string());
    if (!dir.empty() && ::chdir(dir.c_str()) != 0)
        return Status::Io(fmt::format("{}: the build's directory {} (where its relative paths start) is not reachable "
                                      "here: {}",
                                      (abs / "plan.json").string(), dir, std::strerror(errno)));
    return Status::Ok();
}

Status reuseShards(const fs::path& dir, const fs::path& cache, std::vector<int>* reused) {
    json plan;
    if (Status s = readJson(dir / "plan.json", &plan); !s.ok()) return s;
    const auto keys = plan.at("shard_keys").get<std::vector<std::string>>();
    for (size_t k = 0; k < keys.size(); ++k) {
        const fs::path from = cache / keys[k];
        if (!fs::exists(from / "manifest.json")) continue;
        const fs::path to = dir / shardName(static_cast<int>(k));
        std::error_code ec;
        fs::remove_all(to, ec);
        // Hard links: no bytes copied (the cache sits beside the new folder, on the same filesystem).
        fs::copy(from, to, fs::copy_options::recursive | fs::copy_options::create_hard_links, ec);
        if (ec) {
            fs::remove_all(to, ec);
            fs::copy(from, to, fs::copy_options::recursive, ec);
        }
        if (ec) return Status::Io(fmt::format("{}: cannot reuse it: {}", from.string(), ec.message()));
        reused->push_back(static_cast<int>(k));
    }
    return Status::Ok();
}

namespace {
// The scene textures `triangles` name, ascending; each triangle's texture
// becomes its position in that list.
std::vector<int32_t> renumberTextures(std::vector<Triangle>* triangles) {
    std::vector<int32_t> used;
    for (const Triangle& t : *triangles)
        if (t.texture >= 0) used.push_back(t.texture);
    std::sort(used.begin(), used.end());
    used.erase(std::unique(used.begin(), used.end()), used.end());
    for (Triangle& t : *triangles)
        if (t.texture >= 0) t.texture = static_cast<int32_t>(std::lower_bound(used.begin(), used.end(), t.texture) - used.begin());
    return used;
}
}  // namespace

Status runShard(const fs::path& dir, int shard, int threads, const ShardProgressFn& progress) {
    json plan;
    if (Status s = readJson(dir / "plan.json", &plan); !s.ok()) return s;
    if (plan.value("format", 0) != kPlanFormat)
        return Status::Invalid(fmt::format("{}: a plan of another cityatlas version", (dir / "plan.json").string()));
    const auto shards = plan.at("shard_triangles").size();
    if (shard < 0 || static_cast<size_t>(shard) >= shards)
        return Status::Usage(fmt::format("shard {}: the plan has shards 0..{}", shard, shards - 1));
    Scene scene;
    {
        json tables;
        if (Status s = readJson(dir / "tables.json", &tables); !s.ok()) return s;
        tablesFromJson(tables, &scene);
    }
    {
        const fs::path tri = dir / fmt::format("{}.tri", shardName(shard));
        std::ifstream f(tri, std::ios::binary | std::ios::ate);
        if (!f) return Status::Io(fmt::format("{}: cannot open", tri.string()));
        const auto bytes = static_cast<uint64_t>(f.tellg());
        if (bytes % sizeof(Triangle) != 0 ||
            bytes / sizeof(Triangle) != plan.at("shard_triangles").at(static_cast<size_t>(shard)).get<uint64_t>())
            return Status::Io(fmt::format("{}: truncated (expected the plan's triangle count)", tri.string()));
        scene.triangles.resize(bytes / sizeof(Triangle));
        f.seekg(0);
        f.read(reinterpret_cast<char*>(scene.triangles.data()), static_cast<std::streamsize>(bytes));
        if (!f) return Status::Io(fmt::format("{}: cannot read", tri.string()));
    }
    // The shard root's level in the whole tree.
    int level = 0;
    for (const json& n : plan.at("top"))
        if (n.at("shard").get<int>() == shard) level = n.at("level");
    atlas::AtlasParams ap = atlasParamsFrom(plan.at("atlas"));
    ap.threads = threads;
    ap.base_level = level;
    ap.keep_root_halves = true;
    tiles::TilesParams tp = tilesParamsFrom(plan.at("tiles"));
    tp.threads = threads;
    // The shard's textures alone: its triangles name a few thousand of the
    // city's millions. The table, tileset numbers and promotions are read for
    // those, and the triangles renumbered to them in the same order (every
    // comparison of texture numbers, and so the build, stays the same); the
    // scene texture numbers the shard writes out are the city's again.
    const std::vector<int32_t> city_texture = renumberTextures(&scene.triangles);
    if (Status s = readTextureTable(dir / "textures.bin", &scene.textures, nullptr, &city_texture); !s.ok()) return s;
    atlas::GlobalDecisions globals = globalsFrom(plan.at("globals"));
    tiles::TextureIndex texture_index;
    if (Status s = readTexturePlan(dir, &texture_index, &globals.promote, &city_texture); !s.ok()) return s;
    auto cityTextures = [&](std::vector<int32_t> local) {
        for (int32_t& t : local) t = city_texture[static_cast<size_t>(t)];
        return local;
    };

    const fs::path part = dir / (shardName(shard) + ".part"), done = dir / shardName(shard);
    std::error_code ec;
    fs::remove_all(part, ec);
    fs::create_directories(part, ec);
    if (ec) return Status::Io(fmt::format("{}: cannot create: {}", part.string(), ec.message()));
    Diagnostics diagnostics;
    atlas::AtlasTree tree;
    tiles::AtlasHandOff hand_off(tp.bc_quality, part, tp.atlas_png ? part / kAtlasPngFolder : fs::path());
    const auto report = [&](const char* step, uint64_t d, uint64_t t) {
        if (progress) progress(step, d, t);
    };
    if (Status s = atlas::buildAtlasTree(scene, ap, part, diagnostics, report, &tree, hand_off.sink(),
                                         &scene.triangles, &globals);
        !s.ok())
        return s;
    const tiles::EncodedAtlases encoded = hand_off.take(tree.nodes.size());
    // Computed textures (issue 19), against the shard's triangles and its occluders.
    std::vector<atlas::ComputedSpec> computed;
    if (Status s = planComputed(plan, &computed); !s.ok()) return s;
    ComputedFiles computed_files;
    std::vector<atlas::ComputedStats> computed_stats;
    StageClock computed_clock;
    if (!computed.empty()) {
        std::vector<std::array<Vec3d, 3>> triangles;
        // The tree holds the shard's triangles now (buildAtlasTree took the scene's).
        triangles.reserve(tree.triangles.size());
        for (const atlas::TreeTriangle& t : tree.triangles) triangles.push_back(t.tri.position_local);
        const fs::path occ = dir / fmt::format("{}.occ", shardName(shard));
        std::ifstream f(occ, std::ios::binary);
        std::array<Vec3d, 3> t;
        while (f.read(reinterpret_cast<char*>(t.data()), sizeof t)) triangles.push_back(t);
        if (!f.eof()) return Status::Io(fmt::format("{}: cannot read", occ.string()));
        const std::unique_ptr<atlas::RayCaster> caster = atlas::RayCaster::build(triangles, threads);
        // Visibility targets: the target alone, and the scene with the target's
        // triangles first (a copy of one among the occluders loses the tie).
        std::vector<std::unique_ptr<atlas::RayCaster>> target_casters;
        std::vector<std::unique_ptr<atlas::VisibilityTarget>> target_data;
        std::vector<const atlas::VisibilityTarget*> targets(computed.size(), nullptr);
        for (size_t k = 0; k < computed.size(); ++k) {
            if (computed[k].model != atlas::ComputedModel::Visibility) continue;
            std::vector<uint8_t> bytes;
            if (Status s = tiles::readBytes(dir / targetFile(k), &bytes); !s.ok()) return s;
            std::vector<std::array<Vec3d, 3>> target(bytes.size() / sizeof(std::array<Vec3d, 3>));
            std::memcpy(target.data(), bytes.data(), target.size() * sizeof target[0]);
            auto data = std::make_unique<atlas::VisibilityTarget>();
            for (const auto& t : target)
                for (const Vec3d& p : t) data->box.extend(p);
            std::vector<std::array<Vec3d, 3>> all = target;
            all.insert(all.end(), triangles.begin(), triangles.end());
            data->is_target.assign(all.size(), 0);
            std::fill(data->is_target.begin(), data->is_target.begin() + static_cast<std::ptrdiff_t>(target.size()), 1);
            target_casters.push_back(atlas::RayCaster::build(target, threads));
            data->target = target_casters.back().get();
            target_casters.push_back(atlas::RayCaster::build(all, threads));
            data->scene = target_casters.back().get();
            data->grid = computed[k].grid;
            data->horizon_m = computed[k].horizon_m;
            targets[k] = data.get();
            target_data.push_back(std::move(data));
        }
        std::vector<std::array<Vec3d, 3>>().swap(triangles);
        std::vector<std::array<atlas::ScalarImage, atlas::kLayerCount>> roots;
        if (Status s = writeComputedTextures(computed, tree, caster.get(), scene.georef, targets, nullptr, threads, tp.bc_quality,
                                             part, &computed_files, &roots, &computed_stats, report);
            !s.ok())
            return s;
        for (size_t k = 0; k < computed.size(); ++k)
            for (int l = 0; l < atlas::kLayerCount; ++l)
                if (roots[k][static_cast<size_t>(l)].width > 0)
                    if (Status s = atlas::writeScalarImage(roots[k][static_cast<size_t>(l)], part / rootComputedFile(k, l));
                        !s.ok())
                        return s;
    }
    const StageCost computed_cost = computed_clock.lap();
    tiles::SubtreeFiles files;
    StageClock tiles_clock;
    if (Status s = tiles::writeSubtreeFiles(scene, tree, part, tp, texture_index, part, report, &encoded, &files); !s.ok())
        return s;
    const StageCost tiles_cost = tiles_clock.lap();

    json nodes = json::array(), records = json::array(), leaf_textures = json::object(), leaf_tiles = json::object();
    const std::vector<std::vector<int32_t>> used = tiles::leafTextures(tree);
    const std::vector<std::vector<int32_t>> tiles_used = tiles::leafTiles(scene, tree, texture_index, tp.split_originals);
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
        atlas::AtlasNode& node = tree.nodes[i];
        node.originals = cityTextures(std::move(node.originals));
        nodes.push_back(nodeJson(node));
        records.push_back(recordJson(files.records[i]));
        if (!used[i].empty()) leaf_textures[std::to_string(i)] = cityTextures(used[i]);
        if (!tiles_used[i].empty()) leaf_tiles[std::to_string(i)] = tiles_used[i];
    }
    for (int l = 0; l < atlas::kLayerCount; ++l) {
        if (const auto& g = files.root_geometry[static_cast<size_t>(l)]; g && !g->empty())
            if (Status s = writeMesh(part / layerFile("root-geometry", l), g->mesh, g->geometric_error_m,
                                     g->triangles_source, g->simplified);
                !s.ok())
                return s;
        if (const auto& h = tree.root_halves[static_cast<size_t>(l)])
            if (Status s = atlas::writeCanvas(*h, part / layerFile("root-halves", l)); !s.ok()) return s;
    }
    std::vector<json> steps;
    for (const auto& s : tree.stats.steps) steps.push_back({s.name, s.seconds, s.cpu_seconds, s.peak_rss_mb});
    if (!computed.empty())
        steps.push_back({"computed textures", computed_cost.seconds, computed_cost.cpu_seconds, computed_cost.peak_rss_mb});
    steps.push_back({"tiles: geometry and atlases", tiles_cost.seconds, tiles_cost.cpu_seconds, tiles_cost.peak_rss_mb});
    json manifest = {{"shard", shard},
                           {"nodes", nodes},
                           {"records", records},
                           {"root_subtree_features", files.root_subtree_features},
                           {"leaf_textures", leaf_textures},
                           {"leaf_tiles", leaf_tiles},
                           {"stats", statsJson(tree.stats)},
                           {"warnings", diagnosticsToJson(diagnostics)}};
    if (!computed.empty()) {
        json by_node = json::array(), stats = json::array();
        for (const auto& node : computed_files) {
            json layers = json::array();
            for (const auto& layer : node) {
                json list = json::array();
                for (const format::ComputedFileEntry& f : layer) list.push_back(computedFileJson(f));
                layers.push_back(list);
            }
            by_node.push_back(layers);
        }
        for (const atlas::ComputedStats& st : computed_stats) stats.push_back(computedStatsJson(st));
        manifest["computed_files"] = by_node;
        manifest["computed_stats"] = stats;
    }
    if (Status s = writeJson(part / "manifest.json", manifest); !s.ok()) return s;
    // Timings apart: the manifest stays the same for the same shard, wherever and whenever it ran.
    json encode = json::array();
    for (const tiles::NodeRecord& r : files.records)
        for (const tiles::LayerRecord& l : r.layers) encode.push_back(l.atlas_encode_seconds);
    if (Status s = writeJson(part / "steps.json", {{"steps", steps}, {"atlas_encode_seconds", encode}}); !s.ok()) return s;
    fs::remove_all(done, ec);
    fs::rename(part, done, ec);
    if (ec) return Status::Io(fmt::format("{}: cannot rename to {}: {}", part.string(), done.string(), ec.message()));
    return Status::Ok();
}

namespace {

// The path of this executable, for worker processes and job scripts.
Status selfPath(std::string* out) {
    char self[4096];
    const ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    if (n <= 0) return Status::Io("cannot find this executable (/proc/self/exe)");
    self[n] = '\0';
    *out = self;
    return Status::Ok();
}

std::string shellQuote(const std::string& s) {
    std::string q = "'";
    for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return q + "'";
}

// Runs a program (no shell), its stdout captured; the status names it.
Status runCapture(const std::vector<std::string>& args, std::string* out) {
    int pipe_fd[2];
    if (pipe(pipe_fd) != 0) return Status::Io(fmt::format("pipe: {}", std::strerror(errno)));
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, pipe_fd[1], STDOUT_FILENO);
    posix_spawn_file_actions_addclose(&actions, pipe_fd[0]);
    std::vector<std::string> copy = args;
    std::vector<char*> argv;
    for (std::string& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = 0;
    const int e = posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    close(pipe_fd[1]);
    if (e != 0) {
        close(pipe_fd[0]);
        return Status::Io(fmt::format("cannot run {}: {}", args[0], std::strerror(e)));
    }
    char buf[4096];
    ssize_t n;
    while ((n = read(pipe_fd[0], buf, sizeof buf)) > 0) out->append(buf, static_cast<size_t>(n));
    close(pipe_fd[0]);
    int status = 0;
    waitpid(pid, &status, 0);
    if (!(WIFEXITED(status) && WEXITSTATUS(status) == 0))
        return Status::Io(fmt::format("{} {}", args[0], WIFEXITED(status) ? fmt::format("exited with {}", WEXITSTATUS(status))
                                                                           : fmt::format("was killed by signal {}", WTERMSIG(status))));
    return Status::Ok();
}

}  // namespace

std::vector<int> shardsToBuild(const fs::path& dir) {
    json plan;
    std::vector<int> todo;
    if (!readJson(dir / "plan.json", &plan).ok()) return todo;
    const int total = static_cast<int>(plan.at("shard_triangles").size());
    for (int k = 0; k < total; ++k)
        if (!fs::exists(dir / shardName(k) / "manifest.json")) todo.push_back(k);
    return todo;
}

void returnFreedMemory() {
#ifdef CITYATLAS_WITH_MIMALLOC
    mi_collect(true);  // mimalloc keeps freed pages for reuse; the workers need them more
#endif
}

Status runShards(const fs::path& dir, int workers, int threads, const ShardProgressFn& progress) {
    json plan;
    if (Status s = readJson(dir / "plan.json", &plan); !s.ok()) return s;
    const int total = static_cast<int>(plan.at("shard_triangles").size());
    std::vector<int> todo = shardsToBuild(dir);
    const int shards = static_cast<int>(todo.size());
    if (workers <= 0) {
        for (int i = 0; i < shards; ++i) {
            const int k = todo[static_cast<size_t>(i)];
            if (progress) progress("shards", static_cast<uint64_t>(i), static_cast<uint64_t>(shards));
            if (Status s = runShard(dir, k, threads, {}); !s.ok())
                return Status::Io(fmt::format("shard {} of {}: {}", k, total, s.error));
        }
        if (progress) progress("shards", static_cast<uint64_t>(shards), static_cast<uint64_t>(shards));
        return Status::Ok();
    }
    // Worker processes: this executable's `shard` command, each with its share of the cores.
    returnFreedMemory();
    const int cores = threads > 0 ? threads : static_cast<int>(tbb::info::default_concurrency());
    const int running_max = std::max(1, std::min(workers, shards));
    const int per_worker = std::max(1, cores / running_max);
    std::string self;
    if (Status s = selfPath(&self); !s.ok()) return s;
    std::map<pid_t, int> running;
    int next = 0, finished = 0;
    Status first_error = Status::Ok();
    while (finished < shards) {
        while (first_error.ok() && next < shards && static_cast<int>(running.size()) < running_max) {
            std::vector<std::string> args = {self, "shard", dir.string(), "--index", std::to_string(todo[static_cast<size_t>(next)]),
                                             "--threads", std::to_string(per_worker), "--quiet"};
            std::vector<char*> argv;
            for (std::string& a : args) argv.push_back(a.data());
            argv.push_back(nullptr);
            pid_t pid = 0;
            if (const int e = posix_spawn(&pid, self.c_str(), nullptr, nullptr, argv.data(), environ); e != 0)
                return Status::Io(fmt::format("cannot start a shard worker ({}): {}", self, std::strerror(e)));
            running[pid] = todo[static_cast<size_t>(next++)];
        }
        if (running.empty()) break;
        int status = 0;
        const pid_t pid = waitpid(-1, &status, 0);
        if (pid < 0) return Status::Io(fmt::format("waiting for shard workers: {}", std::strerror(errno)));
        const auto it = running.find(pid);
        if (it == running.end()) continue;
        const int k = it->second;
        running.erase(it);
        ++finished;
        if (progress) progress("shards", static_cast<uint64_t>(finished), static_cast<uint64_t>(shards));
        if (first_error.ok() && !(WIFEXITED(status) && WEXITSTATUS(status) == 0))
            first_error = Status::Io(fmt::format("shard {} of {}: its worker (cityatlas shard) {}", k, total,
                                                 WIFEXITED(status) ? fmt::format("exited with {}", WEXITSTATUS(status))
                                                                   : fmt::format("was killed by signal {}", WTERMSIG(status))));
        if (!first_error.ok() && next < shards) {
            // Start no more, stop the others (their work is lost with the build) and wait for them.
            finished += shards - next, next = shards;
            for (const auto& [other, _] : running) kill(other, SIGTERM);
        }
    }
    return first_error;
}

Status submitSlurm(const fs::path& dir, int shards, const std::vector<std::string>& sbatch_args, const fs::path& logs,
                   bool wait, SlurmJobs* jobs) {
    std::string self;
    if (Status s = selfPath(&self); !s.ok()) return s;
    const fs::path plan = fs::absolute(dir), log_dir = fs::absolute(logs);
    std::error_code ec;
    fs::remove_all(log_dir, ec);
    fs::create_directories(log_dir, ec);
    if (ec) return Status::Io(fmt::format("{}: cannot create: {}", log_dir.string(), ec.message()));
    const std::string shard_script = fmt::format(
        "#!/bin/sh\n# cityatlas: one shard of a sharded build (cli/shards.h)\nexec {} shard {} --index \"$SLURM_ARRAY_TASK_ID\" --quiet\n",
        shellQuote(self), shellQuote(plan.string()));
    const std::string merge_script = fmt::format(
        "#!/bin/sh\n# cityatlas: the merge of a sharded build, after its shards\nexec {} merge {} --quiet\n",
        shellQuote(self), shellQuote(plan.string()));
    if (Status s = tiles::writeBytes(plan / "shard.sh", shard_script.data(), shard_script.size()); !s.ok()) return s;
    if (Status s = tiles::writeBytes(plan / "merge.sh", merge_script.data(), merge_script.size()); !s.ok()) return s;
    auto jobId = [](const std::string& out) { return out.substr(0, out.find_first_of(";\n")); };
    (void)shards;
    const std::vector<int> todo = shardsToBuild(plan);  // reused ones are there already
    std::string out;
    if (!todo.empty()) {
        std::string indices;
        for (int k : todo) indices += (indices.empty() ? "" : ",") + std::to_string(k);
        std::vector<std::string> a = {"sbatch", "--parsable", "--job-name=cityatlas-shards",
                                      fmt::format("--array={}", indices),
                                      fmt::format("--output={}", (log_dir / "shard-%a.log").string())};
        a.insert(a.end(), sbatch_args.begin(), sbatch_args.end());
        a.push_back((plan / "shard.sh").string());
        if (Status s = runCapture(a, &out); !s.ok())
            return Status::Io(fmt::format("--slurm: submitting the shards: {}", s.error));
        jobs->shards = jobId(out);
        if (jobs->shards.empty()) return Status::Io("--slurm: sbatch printed no job id for the shards");
    }
    std::vector<std::string> m = {"sbatch", "--parsable", "--job-name=cityatlas-merge",
                                  fmt::format("--output={}", (log_dir / "merge.log").string())};
    if (!todo.empty()) {
        m.push_back(fmt::format("--dependency=afterok:{}", jobs->shards));
        m.push_back("--kill-on-invalid-dep=yes");
    }
    m.insert(m.end(), sbatch_args.begin(), sbatch_args.end());
    if (wait) m.push_back("--wait");
    m.push_back((plan / "merge.sh").string());
    out.clear();
    const Status merged = runCapture(m, &out);
    jobs->merge = jobId(out);
    if (!merged.ok())
        return Status::Io(jobs->merge.empty()
                              ? fmt::format("--slurm: submitting the merge: {}", merged.error)
                              : fmt::format("--slurm: merge job {} did not succeed ({}); see {}", jobs->merge,
                                            merged.error, log_dir.string()));
    if (!wait) return Status::Ok();
    // sbatch --wait exits 0 for a job cancelled before it ran (a shard failed,
    // so afterok never held): the job's state says what happened.
    std::string state;
    if (Status s = runCapture({"scontrol", "-o", "show", "job", jobs->merge}, &state); !s.ok())
        return Status::Io(fmt::format("--slurm: cannot ask for merge job {}'s state: {}", jobs->merge, s.error));
    const auto field = [&](const char* key) {
        const auto at = state.find(key);
        if (at == std::string::npos) return std::string("?");
        const auto from = at + std::strlen(key);
        return state.substr(from, state.find_first_of(" \n", from) - from);
    };
    if (field("JobState=") != "COMPLETED" || field("ExitCode=") != "0:0")
        return Status::Io(fmt::format("--slurm: merge job {} did not succeed ({}, exit code {}{}); see {}", jobs->merge,
                                      field("JobState="), field("ExitCode="),
                                      field("Reason=") != "None" ? ", reason " + field("Reason=") : std::string(),
                                      log_dir.string()));
    return Status::Ok();
}

Status execMergeRunningShards(const fs::path& dir, int workers, int threads, bool quiet) {
    std::vector<std::string> args = {"cityatlas", "merge", dir.string(), "--run-shards", "--workers",
                                     std::to_string(workers), "--threads", std::to_string(threads)};
    if (quiet) args.emplace_back("--quiet");
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    std::fflush(stdout);
    std::fflush(stderr);
    // This executable by its path (so ps and top name it as before), or
    // through /proc/self/exe when its file was deleted or replaced since.
    std::string path;
    if (!selfPath(&path).ok() || path.ends_with(" (deleted)")) path = "/proc/self/exe";
    execv(path.c_str(), argv.data());
    return Status::Io(fmt::format("cannot start the merge (exec {}): {}", path, std::strerror(errno)));
}

Status mergeShards(const fs::path& dir, const fs::path& out_dir, const std::string& build_hash, Diagnostics& diagnostics,
                   const ShardProgressFn& progress, MergeResult* result, const fs::path& previous_cache) {
    json plan;
    if (Status s = readJson(dir / "plan.json", &plan); !s.ok()) return s;
    if (plan.value("format", 0) != kPlanFormat)
        return Status::Invalid(fmt::format("{}: a plan of another cityatlas version", (dir / "plan.json").string()));
    MergeResult& r = *result;
    r.texture_digests = RecordFile<TextureDigest>(dir, "the textures' digests");
    if (Status s = readPlanTables(dir, &r.tables, &r.texture_digests); !s.ok()) return s;
    r.scene_triangles = plan.at("scene_triangles");
    const atlas::AtlasParams ap = atlasParamsFrom(plan.at("atlas"));
    tiles::TilesParams tp = tilesParamsFrom(plan.at("tiles"));
    const atlas::GlobalDecisions globals = globalsFrom(plan.at("globals"));
    r.tiles_params = tp;
    r.atlas_png_dir = dir / kAtlasPngFolder;
    atlas::ShardPlan sp;
    for (const json& n : plan.at("top"))
        sp.nodes.push_back({n.at("parent"), n.at("children").get<std::array<int32_t, 4>>(), n.at("level"), n.at("shard")});
    sp.shard_triangles = plan.at("shard_triangles").get<std::vector<uint64_t>>();
    const size_t shards = sp.shards();
    r.shards = shards;

    // Each manifest typed as it is read: as JSON DOMs the sixteen manifests of
    // a million buildings took ~1 GB at once.
    struct Manifest {
        std::vector<tiles::NodeRecord> records;
        std::vector<std::pair<size_t, std::vector<int32_t>>> leaf_textures;  // shard node, textures
        std::vector<std::pair<size_t, std::vector<int32_t>>> leaf_tiles;     // shard node, tiles of split textures
        std::vector<uint32_t> root_subtree_features;
        json stats, warnings;
        json computed_files, computed_stats;  // absent without computed textures
    };
    std::vector<atlas::ComputedSpec> computed;
    if (Status s = planComputed(plan, &computed); !s.ok()) return s;
    std::vector<Manifest> manifests(shards);
    std::vector<atlas::AtlasTree> trees(shards);
    for (size_t k = 0; k < shards; ++k) {
        const fs::path m = dir / shardName(static_cast<int>(k)) / "manifest.json";
        if (!fs::exists(m)) return Status::Io(fmt::format("{}: shard {} has not finished", m.string(), k));
        json j;
        if (Status s = readJson(m, &j); !s.ok()) return s;
        try {
            for (const json& n : j.at("nodes")) trees[k].nodes.push_back(nodeFrom(n));
            Manifest& typed = manifests[k];
            for (const json& r : j.at("records")) typed.records.push_back(recordFrom(r));
            for (const auto& [node, list] : j.at("leaf_textures").items())
                typed.leaf_textures.emplace_back(std::stoul(node), list.get<std::vector<int32_t>>());
            for (const auto& [node, list] : j.at("leaf_tiles").items())
                typed.leaf_tiles.emplace_back(std::stoul(node), list.get<std::vector<int32_t>>());
            typed.root_subtree_features = j.at("root_subtree_features").get<std::vector<uint32_t>>();
            typed.stats = std::move(j.at("stats"));
            typed.warnings = std::move(j.at("warnings"));
            if (!computed.empty()) {
                typed.computed_files = std::move(j.at("computed_files"));
                typed.computed_stats = std::move(j.at("computed_stats"));
            }
        } catch (const std::exception& e) {
            return Status::Io(fmt::format("{}: not a shard manifest of this cityatlas version: {}", m.string(), e.what()));
        }
    }
    atlas::AtlasTree& tree = r.tree;
    std::vector<int32_t> shard_root;
    tiles::BuiltSubtrees built;
    atlas::assembleTree(sp, trees, ap, &tree, &shard_root, &built.built);
    std::vector<atlas::AtlasTree>().swap(trees);
    const size_t n_nodes = tree.nodes.size();

    // Every shard file moves to its node's number in the whole tree.
    built.records.resize(n_nodes);
    built.leaf_textures.resize(n_nodes);
    built.leaf_tiles.resize(n_nodes);
    ComputedFiles& computed_files = built.computed_files;
    computed_files.assign(computed.empty() ? 0 : n_nodes, {});
    for (auto& node : computed_files)
        for (auto& layer : node) layer.resize(computed.size());
    std::vector<atlas::GivenComputed> given_computed(computed.size());
    std::vector<atlas::ComputedStats> computed_stats(computed.size());
    std::error_code ec;
    for (const char* d : {"geometry/opaque", "geometry/alpha", "atlas/opaque", "atlas/alpha"}) {
        fs::create_directories(out_dir / d, ec);
        if (ec) return Status::Io(fmt::format("{}: cannot create: {}", (out_dir / d).string(), ec.message()));
    }
    atlas::GivenHalves given;
    for (size_t k = 0; k < shards; ++k) {
        const fs::path sd = dir / shardName(static_cast<int>(k));
        Manifest& m = manifests[k];
        const int32_t base = shard_root[k];
        const std::vector<tiles::NodeRecord>& records = m.records;
        for (size_t i = 0; i < records.size(); ++i) {
            tiles::NodeRecord rec = std::move(m.records[i]);
            const auto g = static_cast<size_t>(base) + i;
            for (size_t l = 0; l < atlas::kLayerCount; ++l) {
                tiles::LayerRecord& lr = rec.layers[l];
                const char* layer = atlas::layerName(static_cast<Layer>(l)).data();
                for (auto [uri, kind, ext] : {std::tuple{&lr.geometry_uri, "geometry", "glb"}, std::tuple{&lr.atlas_uri, "atlas", "dds"}}) {
                    if (uri->empty()) continue;
                    const std::string to = fmt::format("{}/{}/{}.{}", kind, layer, g, ext);
                    if (Status s = linkFile(sd / *uri, out_dir / to); !s.ok()) return s;
                    *uri = to;
                }
                // The atlas PNGs for the 3D Tiles export: named by the whole tree's node number, as assembleTree names them.
                if (tp.atlas_png && !lr.atlas_uri.empty())
                    if (Status s = linkFile(sd / kAtlasPngFolder / fmt::format("atlas/{}/{}.png", layer, i),
                                            r.atlas_png_dir / fmt::format("atlas/{}/{}.png", layer, g));
                        !s.ok())
                        return s;
            }
            built.records[g] = std::move(rec);
            if (computed.empty()) continue;
            const json& node_files = m.computed_files.at(i);
            for (size_t l = 0; l < atlas::kLayerCount; ++l)
                for (size_t c = 0; c < computed.size(); ++c) {
                    format::ComputedFileEntry f = computedFileFrom(node_files.at(l).at(c));
                    if (f.file.uri.empty()) continue;
                    const std::string to = tiles::computedUri(c, static_cast<Layer>(l), static_cast<int32_t>(g));
                    if (Status s = linkFile(sd / f.file.uri, out_dir / to); !s.ok()) return s;
                    f.file.uri = to;
                    computed_files[g][l][c] = f;
                }
        }
        for (size_t c = 0; c < computed.size(); ++c) {
            addComputedStats(m.computed_stats.at(c), &computed_stats[c]);
            given_computed[c][base];  // a shard root stands for its subtree even with no image
            for (int l = 0; l < atlas::kLayerCount; ++l)
                if (fs::exists(sd / rootComputedFile(c, l)))
                    if (Status s = atlas::readScalarImage(sd / rootComputedFile(c, l),
                                                          &given_computed[c][base][static_cast<size_t>(l)]);
                        !s.ok())
                        return s;
        }
        for (auto& [node, list] : m.leaf_textures) built.leaf_textures[static_cast<size_t>(base) + node] = std::move(list);
        for (auto& [node, list] : m.leaf_tiles) built.leaf_tiles[static_cast<size_t>(base) + node] = std::move(list);
        built.subtree_features[base] = std::move(m.root_subtree_features);
        given.nodes.insert(base);
        json timing = {{"steps", json::array()}, {"atlas_encode_seconds", json::array()}};  // a reused shard's were spent earlier
        if (fs::exists(sd / "steps.json"))
            if (Status s = readJson(sd / "steps.json", &timing); !s.ok()) return s;
        fs::remove(sd / "steps.json", ec);
        const json& encode = timing.at("atlas_encode_seconds");
        for (size_t i = 0; i < records.size() && encode.size() == records.size() * atlas::kLayerCount; ++i)
            for (size_t l = 0; l < atlas::kLayerCount; ++l)
                built.records[static_cast<size_t>(base) + i].layers[l].atlas_encode_seconds =
                    encode.at(i * atlas::kLayerCount + l).get<double>();
        for (const json& step : timing.at("steps")) {
            r.shard_cost.seconds += step.at(1).get<double>();
            r.shard_cost.cpu_seconds += step.at(2).get<double>();
            r.shard_cost.peak_rss_mb = std::max(r.shard_cost.peak_rss_mb, step.at(3).get<double>());
        }
        addStats(m.stats, &tree.stats);
        addDiagnostics(m.warnings, diagnostics);
        m = Manifest{};
    }
    if (Status s = readTexturePlan(dir, &built.texture_index, nullptr); !s.ok()) return s;
    built.feature_tables = tiles::FeatureTables{};
    for (const json& e : plan.at("feature_tables")) built.feature_tables->tables.push_back({e.at(0), e.at(1)});
    for (const json& e : plan.at("feature_bounds")) built.feature_tables->bounds.push_back({e.at(0), e.at(1)});
    built.feature_tables->features = plan.at("feature_count");
    // The shards, by content key, for the next build of this folder (reuseShards).
    const auto keys = plan.at("shard_keys").get<std::vector<std::string>>();
    plan = json();
    const fs::path cache = out_dir / kShardCache;
    fs::create_directories(cache, ec);
    if (ec) return Status::Io(fmt::format("{}: cannot create: {}", cache.string(), ec.message()));
    for (size_t k = 0; k < shards; ++k) {
        fs::remove_all(cache / keys[k], ec);
        fs::rename(dir / shardName(static_cast<int>(k)), cache / keys[k], ec);
        if (ec) return Status::Io(fmt::format("{}: cannot keep it in {}: {}", (dir / shardName(static_cast<int>(k))).string(),
                                              cache.string(), ec.message()));
    }

    // The stats of the whole tree: the plan's decisions, the shards' sums.
    atlas::AtlasStats& st = tree.stats;
    st.scene_diagonal_m = globals.scene_diagonal_m;
    st.d_min_choice = globals.d_min_choice;
    st.d_min_requested_m = globals.d_min_requested_m;
    st.d_min_used_m = globals.d_min_used_m;
    st.d_full_m = globals.d_full_m;
    st.d_first_upsampled_m = globals.d_first_upsampled_m;
    st.textured_triangles = globals.textured_triangles;
    st.degenerate_uv_triangles = globals.degenerate_uv_triangles;
    st.critical_triangles = globals.critical_triangles;
    st.enlarged_for_split_budget = globals.enlarged_for_split_budget;

    // A shard's folder (kept in the cache by now) by its root, for what the top reads of it when it needs it.
    const auto shardFolder = [&](int32_t root, fs::path* out) {
        const auto shard = std::find(shard_root.begin(), shard_root.end(), root);
        if (shard == shard_root.end()) return Status::Io(fmt::format("merge: node {} is no shard's root", root));
        *out = cache / keys[static_cast<size_t>(shard - shard_root.begin())];
        return Status::Ok();
    };
    given.load = [&](int32_t root, atlas::AtlasHalves* out) {
        fs::path sd;
        if (Status s = shardFolder(root, &sd); !s.ok()) return s;
        for (int l = 0; l < atlas::kLayerCount; ++l) {
            if (!fs::exists(sd / layerFile("root-halves", l))) continue;
            atlas::AtlasCanvas c;
            if (Status s = atlas::readCanvas(sd / layerFile("root-halves", l), &c); !s.ok()) return s;
            (*out)[static_cast<size_t>(l)] = std::move(c);
        }
        return Status::Ok();
    };
    // The top's atlases: the shard roots' halves placed, encoded as they are composed.
    tiles::AtlasHandOff hand_off(tp.bc_quality, out_dir, tp.atlas_png ? r.atlas_png_dir : fs::path());
    {
        atlas::RenderResult rendered;
        const auto report = [&](const char* step, uint64_t d, uint64_t t) {
            if (progress) progress(fmt::format("merge: {}", step).c_str(), d, t);
        };
        if (Status s = atlas::renderAtlases(r.tables, tree, out_dir, report, &rendered, hand_off.sink(), &given); !s.ok())
            return s;
        for (size_t i = 0; i < n_nodes; ++i)
            if (!built.built[i])
                for (const atlas::NodeLayer& l : tree.nodes[i].layers)
                    if (l.present()) {
                        ++st.atlases;
                        st.texels.inner += static_cast<uint64_t>(l.width) * l.height;
                        st.bytes.atlases += atlas::bcBytesWithMips(l.width, l.height, &l == &tree.nodes[i].layers[1] ? 4 : 3);
                    }
    }
    const tiles::EncodedAtlases encoded = hand_off.take(n_nodes);
    // The top's computed textures: the shard roots' images halved and placed.
    if (!computed.empty()) {
        ComputedFiles top;
        std::vector<atlas::ComputedStats> unused;
        const auto report = [&](const char* step, uint64_t d, uint64_t t) {
            if (progress) progress(fmt::format("merge: {}", step).c_str(), d, t);
        };
        if (Status s = writeComputedTextures(computed, tree, nullptr, r.tables.georef, {}, &given_computed, 0, tp.bc_quality,
                                             out_dir, &top, nullptr, &unused, report);
            !s.ok())
            return s;
        given_computed.clear();
        for (size_t i = 0; i < n_nodes; ++i)
            if (!built.built[i]) computed_files[i] = std::move(top[i]);
        for (size_t c = 0; c < computed.size(); ++c) {
            format::ComputedTextureEntry e;
            e.name = computed[c].name();
            e.parameters_json = computed[c].parameters().dump();
            e.scale = computed[c].scale;
            const atlas::ComputedStats& st = computed_stats[c];
            e.texels = st.texels;
            if (st.texels) e.min = st.min, e.max = st.max, e.mean = st.mean();
            built.computed.push_back(e);
        }
    }
    // Original-texture blocks by content: the textures' files, entries and the BC quality.
    tiles::BlockCache block_cache;
    block_cache.from = previous_cache.empty() ? fs::path() : previous_cache / "blocks";
    block_cache.to = out_dir / kBlockCache;
    block_cache.key = [&](const std::vector<tiles::TextureEntry>& textures) {
        ShardKey key;
        key.add(fmt::format("block {} writer {}", tiles::bcQualityName(tp.bc_quality), tiles::kWriterRevision));
        for (const tiles::TextureEntry& e : textures) {
            const auto t = static_cast<size_t>(e.scene_texture);
            const TextureRef ref = r.tables.textures.ref(t);
            const TextureDigest digest = r.texture_digests.read(t);  // a block's digests, one at a time (from the page cache)
            if (!digest.readable) return std::string();  // unknown content: not kept
            key.add(fmt::format("{} {} {} {} {} {}", ref.path, hexDigest(digest.xxh3), ref.width_px, ref.height_px,
                                ref.channels, static_cast<int>(ref.wrap)));
            if (e.tile >= 0)
                key.add(fmt::format("tile {} {} {} {} {}", e.tile, e.tile_rect.x0, e.tile_rect.y0, e.tile_rect.x1,
                                    e.tile_rect.y1));
        }
        return key.digest();
    };
    built.block_cache = &block_cache;
    // A shard's root geometry, when the top merges it.
    built.root_geometry = [&](int32_t root, std::array<std::unique_ptr<tiles::NodeGeometry>, atlas::kLayerCount>* out) {
        fs::path sd;
        if (Status s = shardFolder(root, &sd); !s.ok()) return s;
        for (int l = 0; l < atlas::kLayerCount; ++l) {
            if (!fs::exists(sd / layerFile("root-geometry", l))) continue;
            auto geo = std::make_unique<tiles::NodeGeometry>();
            if (Status s = readMesh(sd / layerFile("root-geometry", l), geo.get()); !s.ok()) return s;
            (*out)[static_cast<size_t>(l)] = std::move(geo);
        }
        return Status::Ok();
    };
    const Status written = tiles::writeTileset(
        r.tables, tree, out_dir, tp, out_dir, build_hash, diagnostics,
        [&](const char* step, uint64_t d, uint64_t t) {
            if (progress) progress(fmt::format("merge: {}", step).c_str(), d, t);
        },
        &r.tiles, &encoded, &built);
    r.blocks_reused = block_cache.reused;
    r.blocks_encoded = block_cache.encoded;
    r.texture_index = std::move(built.texture_index);
    r.leaf_textures = std::move(built.leaf_textures);
    r.leaf_tiles = std::move(built.leaf_tiles);
    return written;
}

}  // namespace cityatlas::cli
