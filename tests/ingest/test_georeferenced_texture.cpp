// SPDX-License-Identifier: GPL-3.0-or-later
// GeoreferencedTexture: the synthetic town's orthophoto on every roof, placed
// by a world file or by referencePoint + orientation, checked texel by texel
// against the orthophoto's own ground truth (each roof pixel's colour encodes
// its building); and the official SIG3D appearance example.
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <fstream>

#include <nlohmann/json.hpp>

#include "ingest/citygml/citygml_reader.h"
#include "ingest/scene_sink.h"
#include "ingest/synth/orthophoto.h"
#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"
#include "read_citygml.h"
#include "test_support.h"

namespace cityatlas {
namespace {
namespace fs = std::filesystem;

using Read = test::Ingested;

std::unique_ptr<Read> read(const fs::path& file, const std::string& theme = "") {
    CityGmlOptions options;
    options.theme = theme;
    return test::ingest(file, options);
}

fs::path writeTown(const std::string& name, synth::OrthophotoMode mode, int lod = 2) {
    synth::TownSettings s;
    s.buildings = 40;
    s.lod = lod;
    s.seed = 5;
    s.texture_size_px = 16;
    s.orthophoto = mode;
    const fs::path dir = test::scratchPath("cityatlas_test_georef_texture", name);
    const Status st = synth::writeTown(synth::generateTown(s), dir, true, nullptr);
    EXPECT_TRUE(st.ok()) << st.error;
    return dir;
}

struct Image {
    int width = 0, height = 0;
    std::vector<uint8_t> rgb;
    uint32_t at(int col, int row) const {
        const uint8_t* p = &rgb[(static_cast<size_t>(row) * width + col) * 3];
        return (uint32_t{p[0]} << 16) | (uint32_t{p[1]} << 8) | p[2];
    }
};

Image readImage(const fs::path& path) {
    Image img;
    auto in = OIIO::ImageInput::open(path.string());
    if (!in) return img;
    img.width = in->spec().width, img.height = in->spec().height;
    img.rgb.resize(static_cast<size_t>(img.width) * img.height * 3);
    in->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, img.rgb.data());
    return img;
}

// The pixel grid as the test reads it from the town's files: the world file's
// six numbers (A D B E C F: sizes and the centre of the upper left pixel).
struct Grid {
    double a = 0, e = 0, c = 0, f = 0;
    int width = 0, height = 0;
};

Grid gridFromWorldFile(const fs::path& pgw, const Image& img) {
    std::ifstream in(pgw);
    double a, d, b, e, c, f;
    in >> a >> d >> b >> e >> c >> f;
    EXPECT_EQ(d, 0.0);
    EXPECT_EQ(b, 0.0);
    return {a, e, c, f, img.width, img.height};
}

// Every roof triangle: textured by the orthophoto with uv = the grid's
// mapping of its ground position (to 1e-12); and every pixel whose centre lies
// in the triangle's ground plan has its building's colour.
void expectRoofsOnTheirOrthophotoPixels(const Read& r, const Grid& g, const Image& img) {
    const Vec3d o = r.scene.georef.origin_source;
    size_t roofs = 0, pixels = 0, wrong = 0;
    double roof_area = 0;
    for (const Triangle& t : r.scene.triangles) {
        if (t.semantic != SurfaceSemantic::Roof) continue;
        ++roofs;
        ASSERT_GE(t.texture, 0) << "roof triangle without the orthophoto";
        EXPECT_EQ(fs::path(r.scene.textures.path(t.texture)).filename(), "orthophoto.png");
        for (int k = 0; k < 3; ++k) {
            const double x = t.position_local[k].x + o.x, y = t.position_local[k].y + o.y;
            const double col = (x - g.c) / g.a, row = (y - g.f) / g.e;  // pixel-centre units
            EXPECT_NEAR(t.uv[k].x, (col + 0.5) / g.width, 1e-12);
            EXPECT_NEAR(t.uv[k].y, 1.0 - (row + 0.5) / g.height, 1e-12);
        }
        const Feature& f = r.scene.features[t.feature];
        const uint32_t number = static_cast<uint32_t>(std::stoul(f.gml_id.substr(f.gml_id.find('_') + 1)));
        // Pixels whose centre is inside the triangle (ground plan, local frame).
        const auto& p = t.position_local;
        const double area2 = (p[1].x - p[0].x) * (p[2].y - p[0].y) - (p[2].x - p[0].x) * (p[1].y - p[0].y);
        roof_area += std::abs(area2) / 2;
        if (std::abs(area2) < 1e-9) continue;
        auto inside = [&](double x, double y) {
            for (int k = 0; k < 3; ++k) {
                const Vec3d& a = p[k];
                const Vec3d& b = p[(k + 1) % 3];
                const double s = ((b.x - a.x) * (y - a.y) - (x - a.x) * (b.y - a.y)) * (area2 > 0 ? 1 : -1);
                if (s <= 0) return false;  // strictly inside: edge pixels belong to either side
            }
            return true;
        };
        double lo_x = 1e300, hi_x = -1e300, lo_y = 1e300, hi_y = -1e300;
        for (const Vec3d& q : p) lo_x = std::min(lo_x, q.x), hi_x = std::max(hi_x, q.x), lo_y = std::min(lo_y, q.y), hi_y = std::max(hi_y, q.y);
        const int c0 = static_cast<int>(std::floor((lo_x + o.x - g.c) / g.a)), c1 = static_cast<int>(std::ceil((hi_x + o.x - g.c) / g.a));
        const int r0 = static_cast<int>(std::floor((hi_y + o.y - g.f) / g.e)), r1 = static_cast<int>(std::ceil((lo_y + o.y - g.f) / g.e));
        for (int row = std::max(0, r0); row <= std::min(g.height - 1, r1); ++row)
            for (int col = std::max(0, c0); col <= std::min(g.width - 1, c1); ++col) {
                const double x = g.c + col * g.a - o.x, y = g.f + row * g.e - o.y;
                if (!inside(x, y)) continue;
                ++pixels;
                wrong += synth::orthophotoNumber(img.at(col, row)) != number;
            }
    }
    EXPECT_GT(roofs, 100u);
    EXPECT_EQ(wrong, 0u) << "of " << pixels << " roof pixels";
    // The pixels checked cover the roofs' ground plan (about area / pixel^2).
    EXPECT_NEAR(static_cast<double>(pixels), roof_area / (g.a * g.a), 0.05 * roof_area / (g.a * g.a));
}

TEST(GeoreferencedTexture, OrthophotoByWorldFileLandsOnEveryRoof) {
    const fs::path dir = writeTown("world_file", synth::OrthophotoMode::WorldFile);
    const Image img = readImage(dir / "textures/orthophoto.png");
    ASSERT_GT(img.width, 0);
    const Grid g = gridFromWorldFile(dir / "textures/orthophoto.pgw", img);
    const auto r = read(dir / "town.gml");
    ASSERT_TRUE(r->status.ok()) << r->status.error;
    EXPECT_EQ(r->state.diagnostics.total(), 0u);
    expectRoofsOnTheirOrthophotoPixels(*r, g, img);
}

TEST(GeoreferencedTexture, OrthophotoByReferencePointLandsOnEveryRoofAndWinsOverAWorldFile) {
    const fs::path dir = writeTown("reference_point", synth::OrthophotoMode::ReferencePoint);
    ASSERT_FALSE(fs::exists(dir / "textures/orthophoto.pgw"));
    const Image img = readImage(dir / "textures/orthophoto.png");
    const auto truth = nlohmann::json::parse(std::ifstream(dir / "truth.json"))["textures"]["orthophoto"];
    const double p = truth["pixel_m"];
    const Grid g{p, -p, truth["west_m"].get<double>() + p / 2, truth["north_m"].get<double>() - p / 2, img.width, img.height};
    // A world file 100 m off: referencePoint + orientation take precedence (CityGML 2.0, 9.5).
    std::ofstream(dir / "textures/orthophoto.pgw") << p << "\n0\n0\n" << -p << "\n" << g.c + 100 << "\n" << g.f << "\n";
    const auto r = read(dir / "town.gml");
    ASSERT_TRUE(r->status.ok()) << r->status.error;
    EXPECT_EQ(r->state.diagnostics.total(), 0u);
    expectRoofsOnTheirOrthophotoPixels(*r, g, img);
}

TEST(GeoreferencedTexture, Lod1RoofsGetTheOrthophotoToo) {
    const fs::path dir = writeTown("lod1", synth::OrthophotoMode::WorldFile, 1);
    const Image img = readImage(dir / "textures/orthophoto.png");
    const Grid g = gridFromWorldFile(dir / "textures/orthophoto.pgw", img);
    const auto r = read(dir / "town.gml");
    ASSERT_TRUE(r->status.ok()) << r->status.error;
    expectRoofsOnTheirOrthophotoPixels(*r, g, img);
}

TEST(GeoreferencedTexture, OtherWorldFileNamesAreFound) {
    const fs::path dir = writeTown("names", synth::OrthophotoMode::WorldFile);
    const Image img = readImage(dir / "textures/orthophoto.png");
    const Grid g = gridFromWorldFile(dir / "textures/orthophoto.pgw", img);
    for (const char* name : {"orthophoto.pngw", "orthophoto.wld", "orthophoto.PGW"}) {
        SCOPED_TRACE(name);
        fs::path current;
        for (const auto& e : fs::directory_iterator(dir / "textures"))
            if (e.path().stem() == "orthophoto" && e.path().extension() != ".png") current = e.path();
        fs::rename(current, dir / "textures" / name);
        const auto r = read(dir / "town.gml");
        ASSERT_TRUE(r->status.ok()) << r->status.error;
        EXPECT_EQ(r->state.diagnostics.total(), 0u);
        expectRoofsOnTheirOrthophotoPixels(*r, g, img);
    }
}

TEST(GeoreferencedTexture, WithoutAnyGeoreferenceRoofsAreColouredAndWarnedOnce) {
    const fs::path dir = writeTown("none", synth::OrthophotoMode::WorldFile);
    fs::remove(dir / "textures/orthophoto.pgw");
    const auto r = read(dir / "town.gml");
    ASSERT_TRUE(r->status.ok()) << r->status.error;
    EXPECT_EQ(r->state.diagnostics.count("georeference_missing"), 1u);
    for (const Triangle& t : r->scene.triangles)
        if (t.semantic == SurfaceSemantic::Roof) {
            EXPECT_LT(t.texture, 0);
            EXPECT_GE(t.material, 0);
        }
}

// The official OGC/SIG3D appearance example (FZK-Haus): the roofs and the
// terrain carry a GeoreferencedTexture by referencePoint + orientation; the
// Winter theme reuses the Summer side texture and a TexCoordList by xlink.
TEST(GeoreferencedTexture, Sig3dAppearanceExample) {
    const fs::path file = test::sharedDir() / "data/citygml2_textured_sig3d_appearance_example/Appearance-EPSG25832.gml";
    if (!fs::exists(file)) GTEST_SKIP() << "the shared data folder is absent: " << file;
    for (const char* theme : {"Summer", "Winter"}) {
        SCOPED_TRACE(theme);
        const auto r = read(file, theme);
        ASSERT_TRUE(r->status.ok()) << r->status.error;
        size_t textured = 0, roofs = 0;
        const Vec3d o = r->scene.georef.origin_source;
        for (const Triangle& t : r->scene.triangles) {
            textured += t.texture >= 0;
            if (t.semantic != SurfaceSemantic::Roof) continue;
            ++roofs;
            ASSERT_GE(t.texture, 0);
            const TextureRef tex = r->scene.textures.ref(t.texture);
            EXPECT_EQ(fs::path(tex.path).filename(), std::string("ground_") + (theme[0] == 'S' ? "summer" : "winter") + ".png");
            // referencePoint 458870 5438360 (upper left pixel centre), orientation 0.05 0 0 -0.05; 401 x 301 px.
            ASSERT_EQ(tex.width_px, 401);
            ASSERT_EQ(tex.height_px, 301);
            for (int k = 0; k < 3; ++k) {
                const double x = t.position_local[k].x + o.x, y = t.position_local[k].y + o.y;
                EXPECT_NEAR(t.uv[k].x, ((x - 458870) / 0.05 + 0.5) / 401, 1e-9);
                EXPECT_NEAR(t.uv[k].y, 1 - ((5438360 - y) / 0.05 + 0.5) / 301, 1e-9);
                EXPECT_GE(t.uv[k].x, 0);  // the house lies inside the image
                EXPECT_LE(t.uv[k].x, 1);
            }
        }
        EXPECT_EQ(roofs, 4u);
        EXPECT_EQ(textured, 16u) << "walls (side texture, front/back) and roofs; the ground slab has none";
    }
}

}  // namespace
}  // namespace cityatlas
