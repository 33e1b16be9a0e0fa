// SPDX-License-Identifier: GPL-3.0-or-later
// The tile folder of a synthetic town, read back and compared with the Scene
// it came from: every node's geometry decoded (Draco) and matched vertex by
// vertex against the tree's triangles of its subtree (positions within the
// error the tileset reports, feature ids exact, texture coordinates within
// their quantization step); every atlas and original texture read back by
// OpenImageIO, an independent DDS decoder; the root draws every building or
// lists it as dropped. The same town is also moved to a northing of 9.9e6 m
// and to ECEF magnitudes, where float32 alone would be off by 0.5-1 m.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <set>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <OpenImageIO/imageio.h>

#include "atlas/atlas_tree.h"
#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"
#include "tests/ingest/test_support.h"
#include "tiles/glb_writer.h"
#include "tiles/inspect.h"
#include "tiles/texture_blocks.h"
#include "tiles/tileset.h"
#include "tests/tiles/built_town.h"

namespace cityatlas::tiles {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;

void forEachTile(const json& tile, const std::function<void(const json&)>& fn) {
    fn(tile);
    if (tile.contains("children"))
        for (const json& c : tile["children"]) forEachTile(c, fn);
}

// Corners of the tree's triangles of one layer in a node's subtree, by feature.
struct Corner {
    Vec3d position;
    Vec2d uv_original, uv_atlas_root;
    int32_t texture = -1, material = -1;
};
std::map<uint32_t, std::vector<Corner>> cornersByFeature(const atlas::AtlasTree& tree, int32_t node, atlas::Layer layer) {
    std::map<uint32_t, std::vector<Corner>> out;
    const atlas::TriangleRange r = tree.nodes[static_cast<size_t>(node)].layers[static_cast<size_t>(layer)].range;
    for (uint32_t i = r.first; i < r.first + r.count; ++i) {
        const atlas::TreeTriangle& t = tree.triangles[i];
        for (size_t k = 0; k < 3; ++k)
            out[t.tri.feature].push_back(
                {t.tri.position_local[k], t.tri.uv[k], t.atlas_uv[k], t.tri.texture,
                 t.tri.texture >= 0 ? -1 : t.tri.material});
    }
    return out;
}

double fracDistance(double a, double b) {  // distance modulo whole periods
    const double d = a - b;
    return std::abs(d - std::round(d));
}

// Decodes every node of `b` and checks it against the tree (see file comment).
void checkRoundTrip(const Built& b, double max_error_m) {
    const json& ca = b.tileset["extras"]["cityatlas"];
    const int A = ca["build"]["atlas_size_px"];
    const json& textures = ca["textures"];
    size_t nodes = 0, vertices = 0;
    forEachTile(b.tileset["root"], [&](const json& tile) {
        const json& n = tile["extras"]["cityatlas"];
        const auto id = n["id"].get<int32_t>();
        const atlas::AtlasNode& node = b.tree.nodes[static_cast<size_t>(id)];
        const bool leaf = !tile.contains("children");
        const Vec3d centre = vec3(n["centre"]);
        ++nodes;
        for (int li = 0; li < atlas::kLayerCount; ++li) {
            const auto layer = static_cast<atlas::Layer>(li);
            const std::string lname(atlas::layerName(layer));
            if (!n["layers"].contains(lname)) {
                EXPECT_EQ(node.layers[static_cast<size_t>(li)].range.count, 0u) << "node " << id << " lost " << lname;
                continue;
            }
            const json& L = n["layers"][lname];
            TileMesh m;
            const Status st = decodeTileGlb(readFile(b.dir / "tiles" / L["geometry"]["uri"].get<std::string>()), centre, &m);
            ASSERT_TRUE(st.ok()) << st.error;
            ASSERT_EQ(m.indices.size() / 3, L["triangles"].get<size_t>());
            const double pos_tol = L["position_error_mm"].get<double>() / 1000.0 + 1e-9;
            EXPECT_LE(pos_tol, max_error_m + 1e-9) << "node " << id;
            ASSERT_EQ(m.feature_id.size(), m.positions.size());
            ASSERT_EQ(m.material_id.size(), m.positions.size());
            ASSERT_EQ(leaf, !m.texture_id.empty()) << "texture ids belong to leaves only";
            ASSERT_EQ(leaf, !m.uv_original.empty()) << "original uvs belong to leaves only";
            // The layer's atlas as the index gives it: texel = root * A * 2^level - offset.
            const json& atlas = L["atlas"];
            const double aw = atlas.is_null() ? 1.0 : atlas["width_px"].get<double>();
            const double ah = atlas.is_null() ? 1.0 : atlas["height_px"].get<double>();
            const double ox = atlas.is_null() ? 0.0 : atlas["offset"][0].get<double>();
            const double oy = atlas.is_null() ? 0.0 : atlas["offset"][1].get<double>();
            const double scale = std::ldexp(static_cast<double>(A), n["level"].get<int>());
            const double atlas_tol = L["uv_atlas_error_texels"].get<double>() / std::max(aw, ah) + 1e-6;
            // Original uvs: within the writer's target (1/8 texel of the
            // vertex's own texture), however often the texture repeats (the
            // towns' paving repeats every 2.5 cm: uvs in the hundreds). A
            // renderer samples the original textures with them.
            const double target_texels = 0.125;  // TilesParams::uv_original_error_target_texels by default
            if (leaf) {
                EXPECT_LE(L["uv_original_error_texels"].get<double>(), target_texels) << "node " << id;
            }
            auto origTol = [&](int32_t ti) {
                const json& t = textures[static_cast<size_t>(ti)];
                return target_texels / std::max(t["width"].get<double>(), t["height"].get<double>()) + 1e-9;
            };
            const auto corners = cornersByFeature(b.tree, id, layer);
            for (size_t v = 0; v < m.positions.size(); ++v) {
                ++vertices;
                const auto it = corners.find(m.feature_id[v]);
                ASSERT_NE(it, corners.end()) << "node " << id << ": feature id " << m.feature_id[v]
                                             << " is not in the subtree";
                bool position_ok = false, uv_ok = false;
                for (const Corner& c : it->second) {
                    if (length(c.position - m.positions[v]) > pos_tol) continue;
                    position_ok = true;
                    if (c.material != m.material_id[v]) continue;
                    bool ok = true;
                    if (c.texture >= 0) {
                        const Vec2d local{(c.uv_atlas_root.x * scale - ox) / aw, (c.uv_atlas_root.y * scale - oy) / ah};
                        ok = std::abs(local.x - m.uv_atlas[v].x) <= atlas_tol && std::abs(local.y - m.uv_atlas[v].y) <= atlas_tol;
                        if (leaf) {
                            const int32_t ti = m.texture_id[v];
                            const json* te = ti >= 0 ? &textures[static_cast<size_t>(ti)] : nullptr;
                            ok = ok && te && ((*te)["block"].get<int>() >= 0 || (*te)["original"] == "exact") &&
                                 fracDistance(c.uv_original.x, m.uv_original[v].x) <= origTol(ti) &&
                                 fracDistance(c.uv_original.y, m.uv_original[v].y) <= origTol(ti);
                        }
                    } else {
                        ok = !leaf || m.texture_id[v] == -1;
                    }
                    if (ok) {
                        uv_ok = true;
                        break;
                    }
                }
                ASSERT_TRUE(position_ok) << "node " << id << " " << lname << " vertex " << v
                                         << " is farther than the reported error from every corner of its feature";
                ASSERT_TRUE(uv_ok) << "node " << id << " " << lname << " vertex " << v
                                   << ": no corner at this position has its texture coordinates and ids";
            }
        }
    });
    EXPECT_EQ(nodes, b.tree.nodes.size());
    EXPECT_GT(vertices, 0u);
}

TilesParams defaults() {
    TilesParams p;
    p.threads = 2;
    return p;
}

TEST(Tileset, TownRoundTripPositionsIdsAndTexcoords) {
    const auto b = buildTown("round_trip", 40, {}, defaults());
    ASSERT_FALSE(HasFailure());
    checkRoundTrip(*b, 0.002);
    EXPECT_LE(b->stats.max_position_error_m, 0.002);
    EXPECT_EQ(b->stats.nodes, b->tree.nodes.size());
}

// The georeferenced extremes: grid northing 9.9e6 m (UTM south) and ECEF
// magnitudes, with the local frame's coordinates themselves that large.
TEST(Tileset, PrecisionAtNorthing9p9e6) {
    const auto b = buildTown("northing", 25, {833000.0, 9.9e6, 0.0}, defaults());
    ASSERT_FALSE(HasFailure());
    checkRoundTrip(*b, 0.002);
    EXPECT_LE(b->stats.max_position_error_m, 0.002);
}

TEST(Tileset, PrecisionAtEcefMagnitudes) {
    const auto b = buildTown("ecef", 25, {3783265.180, 901649.797, 5038246.081}, defaults());
    ASSERT_FALSE(HasFailure());
    checkRoundTrip(*b, 0.002);
    EXPECT_LE(b->stats.max_position_error_m, 0.002);
}

// A small triangle budget forces simplified inner nodes: their error stays
// below their world texel, and the root draws every building or lists it.
// Every node's errors below its texel; the root's decoded feature ids plus its
// dropped list are every feature of the scene, with none in both.
void expectErrorsBelowTexelsAndEveryFeatureAccounted(const Built& b, const char* name) {
    EXPECT_LT(b.stats.max_geometric_error_fraction, 1.0);
    checkRoundTrip(b, 0.002);
    forEachTile(b.tileset["root"], [&](const json& tile) {
        const json& n = tile["extras"]["cityatlas"];
        for (const auto& [layer, L] : n["layers"].items())
            EXPECT_LT(L["geometric_error_m"].get<double>(), n["world_texel_m"].get<double>()) << "node " << n["id"];
    });
    const json& root = b.tileset["root"]["extras"]["cityatlas"];
    std::set<uint32_t> seen;
    for (const auto& [layer, L] : root["layers"].items()) {
        TileMesh m;
        ASSERT_TRUE(decodeTileGlb(readFile(b.dir / "tiles" / L["geometry"]["uri"].get<std::string>()),
                                  vec3(root["centre"]), &m)
                        .ok());
        for (uint32_t i : m.indices) seen.insert(m.feature_id[i]);
    }
    for (const json& d : root["features"]["dropped"]) {
        EXPECT_FALSE(seen.count(d.get<uint32_t>())) << "feature " << d << " is drawn and listed as dropped";
        seen.insert(d.get<uint32_t>());
    }
    std::set<uint32_t> all;
    for (const Triangle& t : b.scene.triangles) all.insert(t.feature);
    EXPECT_EQ(seen, all);
    std::cout << "[" << name << "] root draws " << root["features"]["count"] << " of " << all.size() << " features, "
              << root["features"]["dropped"].size() << " dropped; " << b.stats.nodes_simplified
              << " node layers simplified, largest error " << b.stats.max_geometric_error_fraction << " of a texel\n";
}

// With a small node budget, inner nodes are simplified, and a node still above
// its budget leaves out whole buildings smaller than its texel (below a pixel
// wherever it is drawn), smallest first; the errors stay below the texels and
// every building is drawn or listed.
TEST(Tileset, SimplifiedInnerNodesKeepErrorsBelowTexelsAndAccountForEveryFeature) {
    TilesParams p = defaults();
    p.node_triangles = 300;
    const auto b = buildTown("simplified", 60, {}, p, 100);
    ASSERT_FALSE(HasFailure());
    EXPECT_GT(b->stats.nodes_simplified, 0u);
    std::map<uint32_t, double> diagonal;
    {
        std::map<uint32_t, Box3d> box;
        for (const Triangle& t : b->scene.triangles)
            for (const Vec3d& q : t.position_local) box[t.feature].extend(q);
        for (const auto& [f, bx] : box) diagonal[f] = std::sqrt(dot(bx.max - bx.min, bx.max - bx.min));
    }
    size_t nodes_leaving_out = 0;
    forEachTile(b->tileset["root"], [&](const json& tile) {
        const json& n = tile["extras"]["cityatlas"];
        const double texel = n["world_texel_m"].get<double>();
        size_t triangles = 0;
        for (const auto& [layer, L] : n["layers"].items()) triangles += L["triangles"].get<size_t>();
        if (n["features"]["dropped"].empty()) return;
        ++nodes_leaving_out;
        // Only a node above its budget leaves buildings out, and only ones
        // smaller than its texel (meshopt alone drops none here: every corner
        // is an atlas seam).
        EXPECT_GT(triangles, 0u);
        double error = 0;
        for (const auto& [layer, L] : n["layers"].items()) error = std::max(error, L["geometric_error_m"].get<double>());
        for (const json& f : n["features"]["dropped"]) {
            EXPECT_LT(diagonal[f.get<uint32_t>()], texel) << "node " << n["id"] << " feature " << f;
            // A missing building's error is its size, and errors only grow upwards.
            EXPECT_GE(error, diagonal[f.get<uint32_t>()] - 1e-9) << "node " << n["id"] << " feature " << f;
        }
    });
    EXPECT_GT(nodes_leaving_out, 0u) << "no node left a building out: the test does not exercise the rule";
    expectErrorsBelowTexelsAndEveryFeatureAccounted(*b, "simplified");
}

// OpenImageIO decodes our DDS files on its own; compare with the PNG atlases
// and the original textures.
double psnrAgainst(const fs::path& dds, const fs::path& reference, int channels) {
    Image8 ref, got;
    std::string why;
    // Both as stored (straight alpha, as the client blends), not premultiplied by OpenImageIO.
    EXPECT_TRUE(readImage8(reference.string(), channels, &ref, &why)) << why;
    EXPECT_TRUE(readImage8(dds.string(), channels, &got, &why)) << dds << ": " << why;
    if (ref.width != got.width || ref.height != got.height) {
        ADD_FAILURE() << dds << " is " << got.width << "x" << got.height << ", expected " << ref.width << "x" << ref.height;
        return 0;
    }
    return psnrRgb(ref, got);
}

TEST(Tileset, DdsFilesDecodeWithOpenImageIo) {
    // The default 512 px facades at d_min 150 m: below their own resolution in
    // the leaves (at 150 m the 64 px ones would be capped, copied texel for
    // texel, and no original written), so the atlases are resampled and every
    // original is in a block. Unsplit (the default, said here): at this
    // fixture's 256 px atlases the 512 px facades could be tiles, and each DDS
    // is compared with its whole original (the tiles: GlTest.SplitOriginals...,
    // cli.split_originals).
    TilesParams params = defaults();
    params.split_originals = false;
    const auto b = buildTown("dds", 30, {}, params, 150, {}, nullptr, 512);
    ASSERT_FALSE(HasFailure());
    const json& ca = b->tileset["extras"]["cityatlas"];
    std::vector<double> psnr;
    forEachTile(b->tileset["root"], [&](const json& tile) {
        const json& n = tile["extras"]["cityatlas"];
        const atlas::AtlasNode& node = b->tree.nodes[n["id"].get<size_t>()];
        for (int li = 0; li < atlas::kLayerCount; ++li) {
            const std::string lname(atlas::layerName(static_cast<atlas::Layer>(li)));
            if (!n["layers"].contains(lname) || n["layers"][lname]["atlas"].is_null()) continue;
            const json& a = n["layers"][lname]["atlas"];
            auto in = OIIO::ImageInput::open((b->dir / "tiles" / a["uri"].get<std::string>()).string());
            ASSERT_TRUE(in) << a["uri"];
            int levels = 0;
            while (in->seek_subimage(0, levels)) ++levels;
            EXPECT_EQ(levels, a["mips"].get<int>()) << a["uri"];
            in.reset();
            psnr.push_back(psnrAgainst(b->dir / "tiles" / a["uri"].get<std::string>(),
                                       b->atlas_dir / node.layers[static_cast<size_t>(li)].atlas_path, li == 0 ? 3 : 4));
        }
    });
    ASSERT_FALSE(psnr.empty());
    std::sort(psnr.begin(), psnr.end());
    const double median = psnr[psnr.size() / 2];
    std::cout << "[dds] " << psnr.size() << " atlases read by OpenImageIO: PSNR min " << psnr.front() << " dB, median "
              << median << " dB, max " << psnr.back() << " dB\n";
    // BC1 on the synthetic facades' pixel-sized windows: ~1 % of atlases fall
    // to 29.5-32 dB (libsquish gains only 0.1-0.4 dB there); see tiles/README.md.
    // The lowest is an alpha atlas: its translucent panes, stored straight since
    // writer revision 5 (not premultiplied, so up to 1/alpha brighter), give BC3's
    // colour endpoints more contrast (measured 27.83 dB; >= 28 dB premultiplied).
    EXPECT_GE(median, 32.0);
    EXPECT_GE(psnr.front(), 27.5);

    // Original textures: each DDS inside its block, cut out and read by OpenImageIO.
    int checked = 0;
    for (size_t t = 0; t < ca["textures"].size(); ++t) {
        const json& e = ca["textures"][t];
        ASSERT_GE(e["block"].get<int>(), 0);
        const auto block = readFile(b->dir / "tiles" / ca["texture_blocks"][e["block"].get<size_t>()]["uri"].get<std::string>());
        ASSERT_LE(e["offset"].get<size_t>() + e["bytes"].get<size_t>(), block.size());
        const fs::path one = b->dir / fmt::format("texture{}.dds", t);
        std::ofstream(one, std::ios::binary)
            .write(reinterpret_cast<const char*>(block.data() + e["offset"].get<size_t>()), e["bytes"].get<std::streamsize>());
        ++checked;
    }
    // The writer's scene -> tileset map, recomputed, ties each DDS to its original.
    // At 64 px the synthetic facades are pixel art (a window is ~2 texels), the
    // hardest case for BC1's two colours per 4x4 block: 26-28 dB; 35-44 dB for
    // the same facades at the default 512 px, as here.
    const TextureBlocks plan = planTextureBlocks(b->scene, b->tree, b->tileset["extras"]["cityatlas"]["build"]["originals"] == "all", false);
    ASSERT_EQ(plan.size(), ca["textures"].size());
    double sum = 0;
    for (size_t t = 0; t < plan.size(); ++t) {
        const TextureRef ref = b->scene.textures.ref(static_cast<size_t>(plan.scene_texture[t]));
        const double p = psnrAgainst(b->dir / fmt::format("texture{}.dds", t), ref.path, ref.channels == 4 ? 4 : 3);
        EXPECT_GE(p, 25.0) << ref.path;
        sum += p;
    }
    std::cout << "[dds] " << plan.size() << " original textures (512 px): mean PSNR "
              << sum / static_cast<double>(plan.size()) << " dB\n";
    EXPECT_GT(checked, 0);
}

// `build` hands each atlas from the renderer to the DDS encoder in memory;
// the folder must be byte for byte the one the PNG round trip gives (PNG is
// lossless and the PNG holds exactly the handed-over bytes), alpha layers
// (the town's glass) included, and no PNG is written on the way.
// Mutations run: writeTileset taking the opaque layer's record for both
// layers -> fails (tileset.json differs); the hand-off's sink encoding every
// image as the opaque layer -> fails (an alpha atlas missing).
TEST(Tileset, AtlasesHandedOverInMemoryGiveTheSameFolderAsThroughPng) {
    const auto png = buildTown("handoff_png", 30, {}, defaults(), 150);
    const auto memory = buildTown("handoff_memory", 30, {}, defaults(), 150, {}, nullptr, 64, true);
    ASSERT_FALSE(HasFailure());
    EXPECT_GT(png->stats.atlas_files, 4u);
    EXPECT_FALSE(fs::exists(memory->atlas_dir / "atlas" / "opaque" / "0.png"));
    EXPECT_TRUE(fs::exists(png->atlas_dir / "atlas" / "opaque" / "0.png"));
    size_t files = 0, alpha_atlases = 0;
    for (const auto& e : fs::recursive_directory_iterator(png->dir / "tiles")) {
        if (!e.is_regular_file()) continue;
        const fs::path rel = fs::relative(e.path(), png->dir / "tiles");
        ++files;
        alpha_atlases += rel.parent_path() == fs::path("atlas/alpha") ? 1 : 0;
        ASSERT_TRUE(fs::exists(memory->dir / "tiles" / rel)) << rel;
        EXPECT_TRUE(readFile(e.path()) == readFile(memory->dir / "tiles" / rel)) << rel << " differs";
    }
    size_t memory_files = 0;
    for (const auto& e : fs::recursive_directory_iterator(memory->dir / "tiles")) memory_files += e.is_regular_file();
    EXPECT_EQ(memory_files, files);
    EXPECT_GT(alpha_atlases, 0u) << "the town has no alpha layer to hand over";
}

// Originals that vanish between the atlas and the tiles stage (a network share
// going away): each is a counted warning, the leaves keep their atlases, and a
// block left with nothing readable is not written, so every block in the index
// is a non-empty file and the folder still passes inspect.
TEST(Tileset, UnreadableOriginalsAreCountedAndLeaveNoEmptyBlocks) {
    Diagnostics diagnostics;
    size_t removed = 0;
    const auto b = buildTown("unreadable", 40, {}, defaults(), 2000, [&](const Built& built) {
        // All but the last texture: every block but one is left with nothing readable.
        for (size_t t = 0; t + 1 < built.scene.textures.size(); ++t)
            removed += fs::remove(built.scene.textures.path(t)) ? 1 : 0;
    }, &diagnostics);
    ASSERT_FALSE(HasFailure());
    ASSERT_GT(removed, 0u);
    EXPECT_EQ(b->stats.textures_unreadable, diagnostics.count(warn::kTextureUnreadable));
    EXPECT_GT(b->stats.textures_unreadable, 0u);
    EXPECT_GT(b->stats.textures_written, 0u);
    const json& blocks = b->tileset["extras"]["cityatlas"]["texture_blocks"];
    // 40 textures of 64^2 fill about three 256^2 blocks; one texture remains readable.
    ASSERT_EQ(blocks.size(), 1u);
    for (size_t k = 0; k < blocks.size(); ++k) {
        EXPECT_EQ(blocks[k]["uri"], fmt::format("textures/{}.bin", k));
        EXPECT_GE(blocks[k]["bytes"].get<uint64_t>(), 1u);
        EXPECT_EQ(fs::file_size(b->dir / "tiles" / blocks[k]["uri"].get<std::string>()), blocks[k]["bytes"].get<uint64_t>());
    }
    EXPECT_FALSE(fs::exists(b->dir / "tiles" / "textures" / fmt::format("{}.bin", blocks.size())));
    const InspectResult r = inspectTileFolder(b->dir / "tiles", 2);
    EXPECT_TRUE(r.defects.empty()) << (r.defects.empty() ? "" : r.defects.front());
}

// Leaves whose atlas holds every texture at its own resolution get no
// original blocks: their atlas has to be as good as the originals would have
// been. Checked texel for texel against the source PNGs, with the originals
// written anyway (--originals all; the tree and atlases do not change): over
// every texel the leaves' triangles show, the atlas DDS is within 0.5 dB of
// the original DDS, both measured against the PNG.
// The client blends straight alpha (GL_SRC_ALPHA, ONE_MINUS_SRC_ALPHA), so the
// originals' BC3 blocks must hold the file's straight colours. OpenImageIO
// premultiplies the synthetic glass PNGs on read; stored that way, a pane of
// alpha 0.3 was drawn at 0.09 of its colour at street level (measured: red 28
// against the file's 103 on translucent texels), while the atlas, straight,
// drew it at 0.3 from farther away.
TEST(Tileset, OriginalsKeepStraightAlphaAsTheClientBlendsIt) {
    TilesParams p = defaults();
    p.all_originals = true;
    const auto b = buildTown("straight_alpha", 20, {}, p, 150);
    ASSERT_FALSE(HasFailure());
    const json& ca = b->tileset["extras"]["cityatlas"];
    const TextureBlocks plan = planTextureBlocks(b->scene, b->tree, true);
    uint64_t translucent = 0;
    double diff = 0;
    for (size_t st = 0; st < b->scene.textures.size(); ++st) {
        const TextureRef ref = b->scene.textures.ref(st);
        if (ref.channels != 4 || plan.texture_index[st] < 0) continue;
        const json& e = ca["textures"][static_cast<size_t>(plan.texture_index[st])];
        if (e["block"].is_null() || e["block"].get<int>() < 0) continue;
        // The file's own bytes, read without OpenImageIO's premultiplication.
        OIIO::ImageSpec config;
        config.attribute("oiio:UnassociatedAlpha", 1);
        auto in = OIIO::ImageInput::open(ref.path, &config);
        ASSERT_TRUE(in);
        const int w = in->spec().width, h = in->spec().height;
        ASSERT_EQ(in->spec().nchannels, 4);
        std::vector<uint8_t> file(static_cast<size_t>(w) * h * 4);
        ASSERT_TRUE(in->read_image(0, 0, 0, 4, OIIO::TypeDesc::UINT8, file.data()));
        const std::vector<uint8_t> block = readFile(b->dir / "tiles" / ca["texture_blocks"][e["block"].get<size_t>()]["uri"].get<std::string>());
        const size_t at = e["offset"].get<size_t>() + 128;
        ASSERT_EQ(e["width"].get<int>(), w);
        const Image8 stored = decodeBc(
            std::vector<uint8_t>(block.begin() + static_cast<long>(at), block.begin() + static_cast<long>(at + bcBlockBytes(w, h, 4))), w, h, 4);
        for (size_t i = 0; i < static_cast<size_t>(w) * h; ++i) {
            const uint8_t a = file[i * 4 + 3];
            if (a < 10 || a > 120) continue;  // the translucent panes
            ++translucent;
            for (size_t c = 0; c < 3; ++c) diff += std::abs(double(stored.pixels[i * 4 + c]) - file[i * 4 + c]);
        }
    }
    ASSERT_GT(translucent, 200u) << "the town has no translucent glass to check";
    // BC3's colour endpoints give a few levels of error; premultiplied colours are ~75 levels off.
    EXPECT_LT(diff / (3.0 * static_cast<double>(translucent)), 8.0);
}

TEST(Tileset, ExactLeavesShowTheirTexturesAsWellAsTheOriginals) {
    TilesParams p = defaults();
    p.all_originals = true;
    const auto b = buildTown("exact", 20, {}, p, 150);  // 64 px facades at 150 m: capped, most leaves exact
    ASSERT_FALSE(HasFailure());
    const json& ca = b->tileset["extras"]["cityatlas"];
    const int A = ca["build"]["atlas_size_px"];
    std::map<int32_t, Image8> png, original;  // by scene texture
    const TextureBlocks plan = planTextureBlocks(b->scene, b->tree, true);
    auto texel = [](const Image8& img, int x, int y) { return &img.pixels[(static_cast<size_t>(y) * img.width + x) * img.channels]; };
    double se_atlas = 0, se_original = 0;
    uint64_t samples = 0, exact_leaves = 0;
    forEachTile(b->tileset["root"], [&](const json& tile) {
        const json& n = tile["extras"]["cityatlas"];
        const auto id = n["id"].get<int32_t>();
        const atlas::AtlasNode& node = b->tree.nodes[static_cast<size_t>(id)];
        if (tile.contains("children") || !node.originals.empty()) return;
        ++exact_leaves;
        for (int li = 0; li < atlas::kLayerCount; ++li) {
            const atlas::NodeLayer& nl = node.layers[static_cast<size_t>(li)];
            const std::string lname(atlas::layerName(static_cast<atlas::Layer>(li)));
            if (!n["layers"].contains(lname) || n["layers"][lname]["atlas"].is_null()) continue;
            const json& a = n["layers"][lname]["atlas"];
            const int channels = li == 0 ? 3 : 4;
            const std::vector<uint8_t> dds = readFile(b->dir / "tiles" / a["uri"].get<std::string>());
            const int w = a["width_px"], h = a["height_px"];
            const Image8 atlas_img =
                decodeBc(std::vector<uint8_t>(dds.begin() + 128, dds.begin() + 128 + static_cast<long>(bcBlockBytes(w, h, channels))), w, h, channels);
            const double scale = std::ldexp(static_cast<double>(A), node.level);
            for (uint32_t i = nl.range.first; i < nl.range.first + nl.range.count; ++i) {
                const atlas::TreeTriangle& t = b->tree.triangles[i];
                if (t.tri.texture < 0) continue;
                const TextureRef ref = b->scene.textures.ref(static_cast<size_t>(t.tri.texture));
                if (!png.count(t.tri.texture)) {
                    std::string why;
                    ASSERT_TRUE(readImage8(ref.path, channels, &png[t.tri.texture], &why)) << why;
                }
                if (!original.count(t.tri.texture)) {
                    // The tileset texture of this scene texture: the one its leaf geometry names (planTextureBlocks' order).
                    const json& e = ca["textures"][static_cast<size_t>(plan.texture_index[static_cast<size_t>(t.tri.texture)])];
                    const std::vector<uint8_t> block = readFile(b->dir / "tiles" / ca["texture_blocks"][e["block"].get<size_t>()]["uri"].get<std::string>());
                    const size_t at = e["offset"].get<size_t>() + 128;
                    const int tw = e["width"], th = e["height"];
                    original[t.tri.texture] = decodeBc(
                        std::vector<uint8_t>(block.begin() + static_cast<long>(at), block.begin() + static_cast<long>(at + bcBlockBytes(tw, th, channels))),
                        tw, th, channels);
                }
                const Image8& src = png[t.tri.texture];
                const Image8& orig = original[t.tri.texture];
                // A grid of barycentric points, off the round fractions where
                // texel boundaries lie; each maps to one texel of the texture
                // and one of the atlas (both floored in v-up texels).
                for (int k1 = 0; k1 < 12; ++k1)
                    for (int k2 = 0; k1 + k2 < 11; ++k2) {
                        const double c1 = (k1 + 0.3719) / 12.0, c2 = (k2 + 0.2903) / 12.0, c0 = 1 - c1 - c2;
                        const Vec2d uv{c0 * t.tri.uv[0].x + c1 * t.tri.uv[1].x + c2 * t.tri.uv[2].x,
                                       c0 * t.tri.uv[0].y + c1 * t.tri.uv[1].y + c2 * t.tri.uv[2].y};
                        const Vec2d root{c0 * t.atlas_uv[0].x + c1 * t.atlas_uv[1].x + c2 * t.atlas_uv[2].x,
                                         c0 * t.atlas_uv[0].y + c1 * t.atlas_uv[1].y + c2 * t.atlas_uv[2].y};
                        const double ax = root.x * scale - static_cast<double>(nl.offset[0]);
                        const double ay = root.y * scale - static_cast<double>(nl.offset[1]);
                        const int px = static_cast<int>(std::floor(ax)), py = h - 1 - static_cast<int>(std::floor(ay));
                        auto wrap = [](long v, int n) { return static_cast<int>(((v % n) + n) % n); };
                        const int tx = wrap(static_cast<long>(std::floor(uv.x * src.width)), src.width);
                        const int ty = src.height - 1 - wrap(static_cast<long>(std::floor(uv.y * src.height)), src.height);
                        if (px < 0 || py < 0 || px >= w || py >= h) continue;
                        const uint8_t *s0 = texel(src, tx, ty), *s1 = texel(atlas_img, px, py), *s2 = texel(orig, tx, ty);
                        for (int c = 0; c < 3; ++c) {
                            se_atlas += (s1[c] - s0[c]) * double(s1[c] - s0[c]);
                            se_original += (s2[c] - s0[c]) * double(s2[c] - s0[c]);
                        }
                        ++samples;
                    }
            }
        }
    });
    ASSERT_GT(exact_leaves, 0u);
    ASSERT_GT(samples, 1000u);
    auto psnr = [&](double se) { return 10 * std::log10(255.0 * 255.0 / (se / (3.0 * static_cast<double>(samples)) + 1e-12)); };
    const double atlas_db = psnr(se_atlas), original_db = psnr(se_original);
    std::cout << "[exact] " << exact_leaves << " leaves without originals, " << samples << " texels: atlas DDS "
              << atlas_db << " dB, original DDS " << original_db << " dB against the PNGs\n";
    EXPECT_GE(atlas_db, original_db - 0.5);
}

TEST(Tileset, SchemaAcceptsTheWrittenTileset) {
    // The schema is compiled in; inspect validates with it (tests/tiles/test_inspect.cpp
    // covers the defects). Here: the writer's own output has the required keys.
    const auto b = buildTown("schema", 15, {}, defaults());
    ASSERT_FALSE(HasFailure());
    const json& t = b->tileset;
    EXPECT_EQ(t["asset"]["version"], "1.1");
    EXPECT_EQ(t["asset"]["tilesetVersion"], "0123456789abcdef");
    EXPECT_EQ(t["root"]["refine"], "REPLACE");
    const json& build = t["extras"]["cityatlas"]["build"];
    // geometricError * focal = min_distance: the 3D Tiles SSE test at tau agrees with minDistance.
    forEachTile(t["root"], [&](const json& tile) {
        EXPECT_NEAR(tile["geometricError"].get<double>() * build["focal_px"].get<double>(),
                    tile["extras"]["cityatlas"]["min_distance_m"].get<double>(),
                    1e-9 * tile["extras"]["cityatlas"]["min_distance_m"].get<double>());
    });
}

}  // namespace
}  // namespace cityatlas::tiles
