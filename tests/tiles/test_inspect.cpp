// SPDX-License-Identifier: GPL-3.0-or-later
// inspectTileFolder on a tiny folder built here by hand (no tiles-stage
// writer involved, so the checker is tested against the contract in
// tiles/tileset.h and the schema, not against the writer): the folder is
// clean, and each single damage to a copy of it is one defect naming the file.
#include "tiles/inspect.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <unistd.h>
// GCC 12 reports a false -Wrestrict inside valijson's string handling (as for
// tiles/inspect.cpp, see tiles/CMakeLists.txt); the warning is raised where the
// code is inlined, so it stays off for the whole file.
#pragma GCC diagnostic ignored "-Wrestrict"
#include <valijson/adapters/nlohmann_json_adapter.hpp>
#include <valijson/schema.hpp>
#include <valijson/schema_parser.hpp>
#include <valijson/validation_results.hpp>
#include <valijson/validator.hpp>

#include "tiles/glb_writer.h"
#include "tiles/texture_codec.h"
#include "tiles/tileset.h"

namespace cityatlas::tiles {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// --- The valid folder -------------------------------------------------------

std::vector<uint8_t> readFile(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

void writeFile(const fs::path& p, const std::vector<uint8_t>& bytes) {
    std::ofstream f(p, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

void writeText(const fs::path& p, const std::string& text) {
    writeFile(p, std::vector<uint8_t>(text.begin(), text.end()));
}

// A gradient with a checker pattern, so BC blocks are not all flat.
Image8 testImage(int w, int h, int channels, int seed) {
    Image8 img{w, h, channels, std::vector<uint8_t>(size_t(w) * size_t(h) * size_t(channels))};
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            uint8_t* p = &img.pixels[(size_t(y) * size_t(w) + size_t(x)) * size_t(channels)];
            const bool check = ((x / 4) + (y / 4) + seed) % 2 == 0;
            p[0] = uint8_t((x * 255) / std::max(1, w - 1));
            p[1] = uint8_t((y * 255) / std::max(1, h - 1));
            p[2] = check ? 200 : 40;
            if (channels == 4) p[3] = check ? 255 : 96;
        }
    return img;
}

// A textured box standing on [min, max]: walls textured with `texture`
// (material -1), roof and floor untextured with material 0, as a leaf's
// geometry would be. Every face has its own four vertices (own uvs).
TileMesh boxMesh(const Vec3d& lo, const Vec3d& hi, uint32_t feature, int32_t texture) {
    TileMesh m;
    const Vec3d c[8] = {{lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {hi.x, hi.y, lo.z}, {lo.x, hi.y, lo.z},
                        {lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z}, {hi.x, hi.y, hi.z}, {lo.x, hi.y, hi.z}};
    const int faces[6][4] = {{0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}, {4, 5, 6, 7}, {3, 2, 1, 0}};
    const Vec2d uv[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (int f = 0; f < 6; ++f) {
        const auto base = static_cast<uint32_t>(m.positions.size());
        const bool wall = f < 4;
        for (int k = 0; k < 4; ++k) {
            m.positions.push_back(c[faces[f][k]]);
            m.uv_original.push_back(wall ? Vec2d{uv[k].x * 3, uv[k].y * 2} : Vec2d{0, 0});
            m.uv_atlas.push_back({0.05 + 0.15 * f + 0.1 * uv[k].x, 0.1 + 0.5 * uv[k].y});
            m.feature_id.push_back(feature);
            m.texture_id.push_back(wall ? texture : -1);
            m.material_id.push_back(wall ? -1 : 0);
        }
        for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) m.indices.push_back(base + i);
    }
    return m;
}

TileMesh merged(const TileMesh& a, const TileMesh& b) {
    TileMesh m = a;
    const auto n = static_cast<uint32_t>(m.positions.size());
    m.positions.insert(m.positions.end(), b.positions.begin(), b.positions.end());
    m.uv_atlas.insert(m.uv_atlas.end(), b.uv_atlas.begin(), b.uv_atlas.end());
    m.feature_id.insert(m.feature_id.end(), b.feature_id.begin(), b.feature_id.end());
    m.material_id.insert(m.material_id.end(), b.material_id.begin(), b.material_id.end());
    for (uint32_t i : b.indices) m.indices.push_back(n + i);
    m.uv_original.clear();  // inner nodes draw with their atlas only
    m.texture_id.clear();
    return m;
}

json boxJson(const Vec3d& lo, const Vec3d& hi) {
    return {(lo.x + hi.x) / 2, (lo.y + hi.y) / 2, (lo.z + hi.z) / 2, (hi.x - lo.x) / 2, 0, 0, 0, (hi.y - lo.y) / 2,
            0, 0, 0, (hi.z - lo.z) / 2};
}

constexpr double kFocal = 935.3074360871938;  // 1080 / 2 / tan(30 deg)
constexpr double kCorner = 2.0;
constexpr double kDMin = 100.0;
constexpr int kAtlas = 64;

// Writes node `id`'s geometry and atlas; returns its tile (children added by the caller).
json writeNode(const fs::path& dir, int id, int level, int quadrant, std::array<int, 2> offset, double min_distance,
               const TileMesh& mesh, const Vec3d& lo, const Vec3d& hi, const std::vector<uint32_t>& features,
               const std::vector<int>& blocks, uint64_t* geometry_bytes, uint64_t* atlas_bytes) {
    const Vec3d centre = 0.5 * (lo + hi);
    GlbResult glb;
    const Status st = encodeTileGlb(mesh, centre, DracoSettings{}, &glb);
    EXPECT_TRUE(st.ok()) << st.error;
    const std::string geometry = "geometry/opaque/" + std::to_string(id) + ".glb";
    writeFile(dir / geometry, glb.bytes);
    const std::vector<Image8> mips = mipChain(testImage(kAtlas, kAtlas, 3, id));
    const std::vector<uint8_t> dds = encodeDds(mips, BcQuality::Fast);
    const std::string atlas = "atlas/opaque/" + std::to_string(id) + ".dds";
    writeFile(dir / atlas, dds);
    *geometry_bytes += glb.bytes.size();
    *atlas_bytes += dds.size();
    json layer = {{"triangles", glb.triangles},
                  {"triangles_source", glb.triangles},
                  {"geometry", {{"uri", geometry}, {"bytes", glb.bytes.size()}}},
                  {"geometric_error_m", 0.0},
                  {"position_error_mm", glb.max_position_error_m * 1000},
                  {"position_bits", 14},
                  {"uv_atlas_error_texels", glb.max_uv_atlas_error * kAtlas},
                  {"simplified", false},
                  {"atlas",
                   {{"uri", atlas}, {"bytes", dds.size()}, {"format", "BC1"}, {"width_px", kAtlas},
                    {"height_px", kAtlas}, {"offset", offset}, {"mips", mips.size()}, {"psnr_db", 40.0}}}};
    json ca = {{"id", id},
               {"level", level},
               {"quadrant", quadrant},
               {"min_distance_m", min_distance},
               {"sharp_from_m", min_distance},
               {"world_texel_m", min_distance / (kFocal * kCorner)},
               {"centre", {centre.x, centre.y, centre.z}},
               {"layers", {{"opaque", layer}}},
               {"features", {{"count", features.size()}, {"dropped", json::array()}, {"tables", {0}}}},
               {"texture_blocks", blocks},
               {"bytes", glb.bytes.size() + dds.size()}};
    return {{"boundingVolume", {{"box", boxJson(lo, hi)}}},
            {"geometricError", min_distance / kFocal},
            {"refine", "REPLACE"},
            {"contents", {{{"uri", geometry}}}},
            {"extras", {{"cityatlas", ca}}}};
}

// A root (node 0) with two leaves (1: quadrant 0, 2: quadrant 3), opaque layers
// only, every atlas 64 x 64: the leaves' halves at (0, 0) and (32, 32) of the
// root's, so their offsets are (0, 0) and (64, 64); two original textures
// (BC1 32x32, BC3 16x8) in one block; two features.
void writeValidFolder(const fs::path& dir) {
    for (const char* sub : {"geometry/opaque", "atlas/opaque", "textures", "features"})
        fs::create_directories(dir / sub);
    const Vec3d lo1{0, 0, 0}, hi1{10, 10, 10}, lo2{20, 20, 0}, hi2{30, 30, 12};
    const TileMesh a = boxMesh(lo1, hi1, 0, 0), b = boxMesh(lo2, hi2, 1, 1);
    uint64_t geometry_bytes = 0, atlas_bytes = 0;
    json root = writeNode(dir, 0, 0, -1, {0, 0}, 2 * kDMin, merged(a, b), lo1, hi2, {0, 1}, {}, &geometry_bytes,
                          &atlas_bytes);
    root["children"] = {writeNode(dir, 1, 1, 0, {0, 0}, kDMin, a, lo1, hi1, {0}, {0}, &geometry_bytes, &atlas_bytes),
                        writeNode(dir, 2, 1, 3, {64, 64}, kDMin, b, lo2, hi2, {1}, {0}, &geometry_bytes, &atlas_bytes)};

    const std::vector<Image8> t0 = mipChain(testImage(32, 32, 3, 7)), t1 = mipChain(testImage(16, 8, 4, 8));
    std::vector<uint8_t> block = encodeDds(t0, BcQuality::Fast);
    const size_t t0_bytes = block.size();
    const std::vector<uint8_t> second = encodeDds(t1, BcQuality::Fast);
    block.insert(block.end(), second.begin(), second.end());
    writeFile(dir / "textures/0.bin", block);

    const std::string table = json({{"first", 0},
                                    {"features", {{{"id", 0}, {"gml_id", "BLDG_0"}, {"lod", 2}},
                                                  {{"id", 1}, {"gml_id", "BLDG_1"}, {"lod", 2}}}}})
                                  .dump() + "\n";
    writeText(dir / "features/0.json", table);

    json build = {{"d_min_m", kDMin},
                  {"d_min_requested_m", kDMin},
                  {"atlas_size_px", kAtlas},
                  {"border_px", 2},
                  {"tau", 1.0},
                  {"screen_width_px", 1920},
                  {"screen_height_px", 1080},
                  {"vertical_fov_deg", 60.0},
                  {"focal_px", kFocal},
                  {"corner_factor", kCorner},
                  {"filter", "lanczos3"},
                  {"packing", "maxrects"},
                  {"position_bits", 14},
                  {"position_error_target_mm", 2.0},
                  {"uv_bits", 12},
                  {"bc_quality", "fast"},
                  {"originals", "needed"},
                  {"d_min_chosen_by", "given"},
                  {"node_triangles", 32768},
                  {"geometry_encoder", "Draco"},
                  {"texture_encoder", "stb_dxt"}};
    json ca = {{"format_version", 1},
               {"georeference", {{"source_crs", ""},
                                 {"origin_source", {0.0, 0.0, 0.0}},
                                 {"grid_frame", false},
                                 {"local_to_ecef", nullptr},
                                 {"enu_to_ecef", nullptr}}},
               {"build", build},
               {"materials", {{{"diffuse", {0.5, 0.5, 0.5}}, {"transparency", 0.0}}}},
               {"textures",
                {{{"block", 0}, {"offset", 0}, {"bytes", t0_bytes}, {"width", 32}, {"height", 32}, {"format", "BC1"},
                  {"mips", t0.size()}, {"wrap", "wrap"}, {"original", "written"}},
                 {{"block", 0}, {"offset", t0_bytes}, {"bytes", second.size()}, {"width", 16}, {"height", 8},
                  {"format", "BC3"}, {"mips", t1.size()}, {"wrap", "clamp"}, {"original", "written"}}}},
               {"texture_blocks", {{{"uri", "textures/0.bin"}, {"bytes", block.size()}}}},
               {"features",
                {{"count", 2},
                 {"block_size", 4096},
                 {"tables", {{{"uri", "features/0.json"}, {"bytes", table.size()}}}}}},
               {"totals", {{"nodes", 3},
                           {"leaves", 2},
                           {"depth", 1},
                           {"bytes", {{"geometry", geometry_bytes},
                                      {"atlases", atlas_bytes},
                                      {"textures", block.size()},
                                      {"features", table.size()},
                                      {"originals_as_bc", t0_bytes + second.size()}}},
                           {"texture_ratio", static_cast<double>(atlas_bytes + block.size()) /
                                                 static_cast<double>(t0_bytes + second.size())}}}};
    json tileset = {{"asset", {{"version", "1.1"},
                               {"generator", "cityatlas 0.1.0"},
                               {"tilesetVersion", "0123456789abcdef"},
                               {"gltfUpAxis", "Z"}}},
                    {"geometricError", 2 * root["geometricError"].get<double>()},
                    {"root", root},
                    {"extras", {{"cityatlas", ca}}}};
    writeText(dir / "tileset.json", tileset.dump(1) + "\n");
}

std::string joined(const std::vector<std::string>& lines) {
    std::string s;
    for (const std::string& l : lines) s += "  " + l + "\n";
    return s;
}

// --- Fixture: the valid folder once, a fresh copy per damage -----------------

class Inspect : public ::testing::Test {
protected:
    static fs::path base_, valid_;

    static void SetUpTestSuite() {
        base_ = fs::temp_directory_path() / ("cityatlas_inspect_" + std::to_string(::getpid()));
        fs::remove_all(base_);
        valid_ = base_ / "valid";
        writeValidFolder(valid_);
    }
    static void TearDownTestSuite() {
        std::error_code ec;
        fs::remove_all(base_, ec);
    }

    // A copy of the valid folder named after the running test, with `change`
    // applied to its files and to its tileset.json (written back afterwards).
    static fs::path damaged(const std::function<void(const fs::path& dir, json& tileset)>& change) {
        const fs::path dir = base_ / ::testing::UnitTest::GetInstance()->current_test_info()->name();
        fs::remove_all(dir);
        fs::copy(valid_, dir, fs::copy_options::recursive);
        std::ifstream in(dir / "tileset.json");
        json ts = json::parse(in);
        in.close();
        change(dir, ts);
        writeText(dir / "tileset.json", ts.dump(1) + "\n");
        return dir;
    }

    // Inspects `dir` and expects a defect that starts with `file` and contains `what`.
    static InspectResult expectDefect(const fs::path& dir, const std::string& file, const std::string& what) {
        const InspectResult r = inspectTileFolder(dir, 2);
        EXPECT_FALSE(r.ok());
        const bool found = std::any_of(r.defects.begin(), r.defects.end(), [&](const std::string& d) {
            return d.rfind(file, 0) == 0 && d.find(what) != std::string::npos;
        });
        EXPECT_TRUE(found) << "no defect starting with '" << file << "' and containing '" << what << "' in:\n"
                           << joined(r.defects);
        for (const std::string& d : r.defects) std::cout << "    defect: " << d << "\n";
        return r;
    }
};
fs::path Inspect::base_, Inspect::valid_;

json& leafLayer(json& ts, int child) {
    return ts["root"]["children"][child]["extras"]["cityatlas"]["layers"]["opaque"];
}

// --- Tests ------------------------------------------------------------------

TEST(InspectSchema, IsADraft7SchemaValijsonParses) {
    const json& schema = tilesetSchema();
    EXPECT_EQ(schema.at("$schema"), "http://json-schema.org/draft-07/schema#");
    valijson::Schema parsed;
    valijson::SchemaParser parser(valijson::SchemaParser::kDraft7);
    valijson::adapters::NlohmannJsonAdapter adapter(schema);
    ASSERT_NO_THROW(parser.populateSchema(adapter, parsed));
    // Every "$ref" is local and names a definition that exists.
    std::function<void(const json&)> refs = [&](const json& j) {
        if (j.is_object() && j.contains("$ref")) {
            const std::string ref = j["$ref"];
            ASSERT_EQ(ref.rfind("#/definitions/", 0), 0u) << ref;
            EXPECT_TRUE(schema.at("definitions").contains(ref.substr(14))) << ref;
        }
        if (j.is_structured())
            for (const json& c : j) refs(c);
    };
    refs(schema);
    // Not vacuous: an empty object fails with the four required members.
    valijson::Validator validator;
    valijson::ValidationResults results;
    const json empty = json::object();
    valijson::adapters::NlohmannJsonAdapter doc(empty);
    EXPECT_FALSE(validator.validate(parsed, doc, &results));
    EXPECT_GE(results.numErrors(), 1u);
}

TEST_F(Inspect, ValidFolderHasNoDefects) {
    const InspectResult r = inspectTileFolder(valid_, 0);
    EXPECT_TRUE(r.ok()) << joined(r.defects);
    EXPECT_EQ(r.nodes, 3u);
    EXPECT_EQ(r.leaves, 2u);
    ASSERT_EQ(r.levels.size(), 2u);
    EXPECT_EQ(r.levels[0].nodes, 1u);
    EXPECT_EQ(r.levels[1].nodes, 2u);
    EXPECT_EQ(r.levels[1].leaves, 2u);
    EXPECT_EQ(r.levels[0].triangles, 24u);
    EXPECT_EQ(r.levels[1].triangles, 24u);
    EXPECT_DOUBLE_EQ(r.levels[0].min_distance_m, 2 * kDMin);
    EXPECT_DOUBLE_EQ(r.levels[1].world_texel_min_m, kDMin / (kFocal * kCorner));
    EXPECT_EQ(r.textures, 2u);
    EXPECT_EQ(r.texture_blocks, 1u);
    EXPECT_EQ(r.features, 2u);
    EXPECT_EQ(r.files_checked, 1u + 3u + 3u + 1u + 1u);  // tileset.json, glbs, atlases, block, table
    EXPECT_EQ(r.bytes_textures, fs::file_size(valid_ / "textures/0.bin"));
    // The same verdict on one thread.
    EXPECT_TRUE(inspectTileFolder(valid_, 1).ok());
}

TEST_F(Inspect, MissingOrUnparsableTileset) {
    const InspectResult none = inspectTileFolder(base_ / "no_such_folder");
    ASSERT_EQ(none.defects.size(), 1u) << joined(none.defects);
    EXPECT_EQ(none.defects[0].rfind("tileset.json: missing", 0), 0u) << none.defects[0];
    const fs::path dir = damaged([](const fs::path&, json&) {});
    writeText(dir / "tileset.json", "{\"asset\": ");
    const InspectResult bad = inspectTileFolder(dir);
    ASSERT_EQ(bad.defects.size(), 1u) << joined(bad.defects);
    EXPECT_EQ(bad.defects[0].rfind("tileset.json: not valid JSON", 0), 0u) << bad.defects[0];
}

TEST_F(Inspect, DeletedGeometry) {
    expectDefect(damaged([](const fs::path& d, json&) { fs::remove(d / "geometry/opaque/1.glb"); }),
                 "geometry/opaque/1.glb", "missing");
}

TEST_F(Inspect, TruncatedGlb) {
    const std::string glb = "geometry/opaque/2.glb";
    expectDefect(damaged([&](const fs::path& d, json&) { fs::resize_file(d / glb, fs::file_size(d / glb) / 2); }),
                 glb, "bytes, tileset.json says");
    // Truncated with tileset.json agreeing on the size: the decoder must refuse it.
    expectDefect(damaged([&](const fs::path& d, json& ts) {
                     const auto half = fs::file_size(d / glb) / 2;
                     fs::resize_file(d / glb, half);
                     leafLayer(ts, 1)["geometry"]["bytes"] = half;
                 }),
                 glb, "");
}

TEST_F(Inspect, CorruptedDdsHeader) {
    expectDefect(damaged([](const fs::path& d, json&) {
                     std::fstream f(d / "atlas/opaque/0.dds", std::ios::in | std::ios::out | std::ios::binary);
                     f.seekp(84);
                     f.write("XXXX", 4);
                 }),
                 "atlas/opaque/0.dds", "FourCC");
}

TEST_F(Inspect, DdsSizeInTilesetWrong) {
    expectDefect(damaged([](const fs::path&, json& ts) {
                     json& a = leafLayer(ts, 0)["atlas"];
                     a["bytes"] = a["bytes"].get<int64_t>() + 16;
                 }),
                 "atlas/opaque/1.dds", "tileset.json says");
    // File and index agree on a length the header does not give (16 bytes appended).
    expectDefect(damaged([](const fs::path& d, json& ts) {
                     std::vector<uint8_t> b = readFile(d / "atlas/opaque/1.dds");
                     b.resize(b.size() + 16, 0);
                     writeFile(d / "atlas/opaque/1.dds", b);
                     leafLayer(ts, 0)["atlas"]["bytes"] = b.size();
                 }),
                 "atlas/opaque/1.dds", "its DDS header makes");
    // A size the DDS does not have.
    expectDefect(damaged([](const fs::path&, json& ts) { leafLayer(ts, 0)["atlas"]["height_px"] = 32; }),
                 "atlas/opaque/1.dds", "64x32");
}

TEST_F(Inspect, TextureOffsetOutsideBlock) {
    expectDefect(damaged([](const fs::path&, json& ts) {
                     json& t = ts["extras"]["cityatlas"]["textures"][1];
                     t["offset"] = ts["extras"]["cityatlas"]["texture_blocks"][0]["bytes"].get<int64_t>() + 100;
                 }),
                 "textures/0.bin", "outside the block");
    // Inside the block but not at a DDS header.
    expectDefect(damaged([](const fs::path&, json& ts) { ts["extras"]["cityatlas"]["textures"][1]["offset"] = 200; }),
                 "textures/0.bin", "texture 1");
}

TEST_F(Inspect, MissingFeatureTable) {
    expectDefect(damaged([](const fs::path& d, json&) { fs::remove(d / "features/0.json"); }), "features/0.json",
                 "missing");
    // A table holding the wrong ids.
    expectDefect(damaged([](const fs::path& d, json& ts) {
                     const std::string t = json({{"first", 0}, {"features", {{{"id", 0}}, {{"id", 7}}}}}).dump();
                     writeText(d / "features/0.json", t);
                     ts["extras"]["cityatlas"]["features"]["tables"][0]["bytes"] = t.size();
                 }),
                 "features/0.json", "id 7");
}

TEST_F(Inspect, SchemaViolationNamesTheJsonPath) {
    const InspectResult r =
        expectDefect(damaged([](const fs::path&, json& ts) { ts["root"]["children"][1]["refine"] = "ADD"; }),
                     "tileset.json: /root/children/1/refine:", "");
    // Only the leaf error, not one line per ancestor.
    EXPECT_EQ(r.defects.size(), 1u) << joined(r.defects);
    expectDefect(damaged([](const fs::path&, json& ts) { ts["root"]["children"][0]["geometricError"] = -1; }),
                 "tileset.json: /root/children/0/geometricError:", "");
}

TEST_F(Inspect, UriLeavingTheFolder) {
    const std::string uri = "geometry/../../outside.glb";
    expectDefect(damaged([&](const fs::path& d, json& ts) {
                     fs::copy_file(d / "geometry/opaque/2.glb", d.parent_path() / "outside.glb",
                                   fs::copy_options::overwrite_existing);
                     leafLayer(ts, 1)["geometry"]["uri"] = uri;
                     ts["root"]["children"][1]["contents"][0]["uri"] = uri;
                 }),
                 "tileset.json: /root/children/1: tile not checked: contents: uri \"" + uri + "\"",
                 "is not a relative path inside the folder");
    // A symlink whose target is outside: the canonical path decides.
    expectDefect(damaged([](const fs::path& d, json&) {
                     fs::copy_file(d / "geometry/opaque/2.glb", d.parent_path() / "outside.glb",
                                   fs::copy_options::overwrite_existing);
                     fs::remove(d / "geometry/opaque/2.glb");
                     fs::create_symlink(d.parent_path() / "outside.glb", d / "geometry/opaque/2.glb");
                 }),
                 "geometry/opaque/2.glb", "outside the folder");
}

TEST_F(Inspect, ChildBoxOutsideParent) {
    expectDefect(damaged([](const fs::path&, json& ts) {
                     ts["root"]["children"][1]["boundingVolume"]["box"][0] = 125.0;  // x centre 25 -> 125
                 }),
                 "tileset.json: /root/children/1 (node 2)", "not inside its parent's");
    // Rounding-sized overhang is tolerated.
    const fs::path ok = damaged([](const fs::path&, json& ts) {
        json& box = ts["root"]["children"][1]["boundingVolume"]["box"];
        box[3] = box[3].get<double>() + 1e-7;
    });
    const InspectResult r = inspectTileFolder(ok);
    EXPECT_TRUE(r.ok()) << joined(r.defects);
}

TEST_F(Inspect, WrongTotals) {
    expectDefect(damaged([](const fs::path&, json& ts) { ts["extras"]["cityatlas"]["totals"]["nodes"] = 4; }),
                 "tileset.json: /extras/cityatlas/totals/nodes", "4");
    expectDefect(damaged([](const fs::path&, json& ts) {
                     json& b = ts["extras"]["cityatlas"]["totals"]["bytes"]["geometry"];
                     b = b.get<int64_t>() + 1;
                 }),
                 "tileset.json: /extras/cityatlas/totals/bytes/geometry", "");
}

TEST_F(Inspect, TreeInconsistencies) {
    expectDefect(damaged([](const fs::path&, json& ts) {
                     ts["root"]["children"][1]["extras"]["cityatlas"]["quadrant"] = 0;
                 }),
                 "tileset.json: /root/children/1 (node 2)", "quadrant 0");
    expectDefect(damaged([](const fs::path&, json& ts) { ts["root"]["children"][0]["geometricError"] = 1.0; }),
                 "tileset.json: /root/children/0 (node 1)", "geometricError");
    expectDefect(damaged([](const fs::path&, json& ts) {
                     ts["root"]["children"][1]["extras"]["cityatlas"]["id"] = 1;
                 }),
                 "tileset.json: /root/children/1 (node 1)", "id used twice");
    expectDefect(damaged([](const fs::path&, json& ts) {
                     leafLayer(ts, 0)["geometric_error_m"] = 1.0;  // world texel is ~0.05 m
                 }),
                 "tileset.json: /root/children/0 (node 1)", "geometric_error_m");
    expectDefect(damaged([](const fs::path&, json& ts) { leafLayer(ts, 0)["triangles"] = 13; }),
                 "geometry/opaque/1.glb", "12 triangles, tileset.json says 13");
    expectDefect(damaged([](const fs::path&, json& ts) {
                     ts["root"]["transform"] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
                 }),
                 "tileset.json: /root/transform", "local_to_ecef");
    expectDefect(damaged([](const fs::path&, json& ts) { leafLayer(ts, 0)["atlas"]["offset"][0] = 1; }),
                 "tileset.json: /root/children/0 (node 1)", "offset [1, 0] is odd");
    // Node 2's half moved onto node 1's, and past the root's atlas.
    expectDefect(damaged([](const fs::path&, json& ts) { leafLayer(ts, 1)["atlas"]["offset"] = {32, 32}; }),
                 "tileset.json: /root/children/1 (node 2)", "overlaps a sibling's");
    expectDefect(damaged([](const fs::path&, json& ts) { leafLayer(ts, 1)["atlas"]["offset"] = {96, 64}; }),
                 "tileset.json: /root/children/1 (node 2)", "leaves its parent's 64x64 atlas");
    // A parent that serves from closer than twice its children's sharp_from.
    expectDefect(damaged([](const fs::path&, json& ts) {
                     ts["root"]["children"][1]["extras"]["cityatlas"]["sharp_from_m"] = 1.5 * kDMin;
                 }),
                 "tileset.json: /root/children/1 (node 2)", "more than half its parent's");
    // A listed block that holds none of the leaf's textures... node 1 uses texture 0 only: lists block 0, fine;
    // and the texture ratio the index claims.
    expectDefect(damaged([](const fs::path&, json& ts) { ts["extras"]["cityatlas"]["totals"]["texture_ratio"] = 9.0; }),
                 "tileset.json: /extras/cityatlas/totals/texture_ratio", "the index gives");
}

// Garbage in place of a GLB (same length, so it reaches the decoder), with
// and without a valid GLB header in front: a defect, never a crash.
TEST_F(Inspect, GarbageGlbNeverCrashes) {
    const std::string glb = "geometry/opaque/0.glb";
    for (uint32_t seed = 1; seed <= 6; ++seed) {
        const fs::path dir = damaged([&](const fs::path& d, json&) {
            std::vector<uint8_t> b = readFile(d / glb);
            uint64_t z = seed * 0x9e3779b97f4a7c15ull;
            // Odd seeds keep the 20-byte GLB header and JSON chunk header, so the parser goes further.
            for (size_t i = seed % 2 ? 20 : 0; i < b.size(); ++i) {
                z ^= z << 13, z ^= z >> 7, z ^= z << 17;
                b[i] = uint8_t(z);
            }
            writeFile(d / glb, b);
        });
        expectDefect(dir, glb, "");
    }
}

// Damage inside tileset.json itself: a 200k-character uri (std::regex would
// overflow its stack on it), deep nesting, wrong types where numbers belong.
TEST_F(Inspect, HostileTilesetNeverCrashes) {
    expectDefect(
        damaged([](const fs::path&, json& ts) { leafLayer(ts, 0)["geometry"]["uri"] = std::string(200000, 'a'); }),
        "aaaa", "longer than");
    const fs::path deep = damaged([](const fs::path&, json& ts) {
        json j = 1;
        for (int i = 0; i < 5000; ++i) j = json::array({j});
        ts["root"]["children"][0]["extras"]["deep"] = j;
    });
    expectDefect(deep, "tileset.json", "nested deeper");
    const InspectResult r = expectDefect(damaged([](const fs::path&, json& ts) {
                                             ts["root"]["children"][0]["extras"]["cityatlas"]["level"] = "one";
                                             ts["extras"]["cityatlas"]["textures"][0] = nullptr;
                                             ts["root"]["children"][1]["boundingVolume"] = 3;
                                         }),
                                         "tileset.json: /root/children/0", "");
    EXPECT_GE(r.defects.size(), 3u);
    expectDefect(damaged([](const fs::path&, json& ts) { ts.erase("root"); }), "tileset.json: /root", "");
    expectDefect(damaged([](const fs::path&, json& ts) { ts["extras"]["cityatlas"]["build"] = "fast"; }),
                 "tileset.json: /extras/cityatlas", "nothing further checked");
}

// The report does not depend on the thread count.
TEST_F(Inspect, DeterministicDefects) {
    const fs::path dir = damaged([](const fs::path& d, json& ts) {
        fs::remove(d / "geometry/opaque/1.glb");
        fs::remove(d / "atlas/opaque/2.dds");
        ts["extras"]["cityatlas"]["totals"]["leaves"] = 5;
        ts["root"]["children"][0]["boundingVolume"]["box"][2] = -50.0;
    });
    const InspectResult one = inspectTileFolder(dir, 1), many = inspectTileFolder(dir, 4);
    EXPECT_GE(one.defects.size(), 4u);
    EXPECT_EQ(one.defects, many.defects);
}

}  // namespace
}  // namespace cityatlas::tiles
