// SPDX-License-Identifier: GPL-3.0-or-later
// The CityGML reader against synthetic towns (exact truth) and small
// hand-written documents (one feature each).
#include "ingest/citygml/citygml_reader.h"

#include <gtest/gtest.h>

#include "read_citygml.h"
#include "test_support.h"

#include <cmath>
#include <fstream>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"
#include "truth_check.h"

namespace cityatlas {
namespace {
namespace fs = std::filesystem;

fs::path scratch(const std::string& name) { return test::scratchPath("cityatlas_test_reader", name); }

using test::ingest;

fs::path writeTown(const std::string& name, int lod, Vec3d origin, int epsg = 25832, uint32_t buildings = 40) {
    synth::TownSettings s;
    s.buildings = buildings;
    s.lod = lod;
    s.seed = 11;
    s.texture_size_px = 16;
    s.crs_epsg = epsg;
    s.origin_source = origin;
    const fs::path dir = scratch(name);
    const Status st = synth::writeTown(synth::generateTown(s), dir, true, nullptr);
    EXPECT_TRUE(st.ok()) << st.error;
    return dir;
}

void expectMatchesTruth(const fs::path& dir) {
    const auto truth = nlohmann::json::parse(std::ifstream(dir / "truth.json"));
    const auto r = ingest(dir / "town.gml");
    ASSERT_TRUE(r->status.ok()) << r->status.error;
    expectStatsMatchTruth(computeStats(r->scene), truth);
    // Building ids, and every textured triangle's texture exists on disk.
    std::set<std::string> ids, truth_ids;
    for (const Feature& f : r->scene.features) ids.insert(f.gml_id);
    for (const auto& b : truth["building_list"]) truth_ids.insert(b["gml_id"].get<std::string>());
    EXPECT_EQ(ids, truth_ids);
    size_t textured = 0;
    for (const Triangle& t : r->scene.triangles) {
        if (t.texture < 0) continue;
        ++textured;
        ASSERT_LT(static_cast<size_t>(t.texture), r->scene.textures.size());
        ASSERT_TRUE(fs::is_regular_file(r->scene.textures.path(t.texture))) << r->scene.textures.path(t.texture);
    }
    EXPECT_GT(textured, 0u);
    EXPECT_EQ(r->state.diagnostics.total(), 0u) << "a valid synthetic town must ingest without warnings";
}

TEST(CityGmlReader, Lod2TownReproducesTruth) { expectMatchesTruth(writeTown("lod2", 2, {690000, 5336000, 500})); }
TEST(CityGmlReader, Lod1TownReproducesTruth) { expectMatchesTruth(writeTown("lod1", 1, {690000, 5336000, 500})); }
TEST(CityGmlReader, ExtremeTownReproducesTruth) {
    expectMatchesTruth(writeTown("extreme", 2, {833000, 9900000, 0}, 32733));
}

// The same town near the origin and at northing 9.9e6 m: local triangles
// equal within 1 mm (the frame's origin absorbs the offset exactly).
TEST(CityGmlReader, ExtremeCoordinatesKeepMillimetrePrecision) {
    const auto near = ingest(writeTown("near", 2, {1000, 1000, 0}, 32733) / "town.gml");
    const auto far = ingest(writeTown("far", 2, {833000, 9900000, 0}, 32733) / "town.gml");
    ASSERT_TRUE(near->status.ok() && far->status.ok());
    ASSERT_EQ(near->scene.triangles.size(), far->scene.triangles.size());
    double worst = 0;
    for (size_t i = 0; i < near->scene.triangles.size(); ++i)
        for (int k = 0; k < 3; ++k)
            worst = std::max(worst, length(near->scene.triangles[i].position_local[k] -
                                           far->scene.triangles[i].position_local[k]));
    EXPECT_LT(worst, 1e-3);
    // The frame's origin is the envelope centre in whole metres: near 9.9e6.
    EXPECT_NEAR(far->scene.georef.origin_source.y, 9900000.0, 100);
    EXPECT_EQ(far->scene.georef.origin_source.y, std::round(far->scene.georef.origin_source.y));
}

// --- small documents -------------------------------------------------------------

constexpr const char* kHeader2 = R"(<?xml version="1.0" encoding="UTF-8"?>
<core:CityModel xmlns:core="http://www.opengis.net/citygml/2.0" xmlns:bldg="http://www.opengis.net/citygml/building/2.0"
 xmlns:app="http://www.opengis.net/citygml/appearance/2.0" xmlns:gml="http://www.opengis.net/gml"
 xmlns:xlink="http://www.w3.org/1999/xlink">
<gml:boundedBy><gml:Envelope srsName="urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783" srsDimension="3">
<gml:lowerCorner>100 200 0</gml:lowerCorner><gml:upperCorner>110 210 10</gml:upperCorner></gml:Envelope></gml:boundedBy>
)";

fs::path writeDoc(const std::string& name, const std::string& body, const char* header = kHeader2,
                  const char* footer = "</core:CityModel>\n") {
    const fs::path p = scratch(name + ".gml");
    std::ofstream(p) << header << body << footer;
    return p;
}

// A 10 x 10 square at height z, counter-clockwise seen from above.
std::string square(const std::string& id, double z, bool reverse = false) {
    std::string pts = reverse ? "100 200 Z 100 210 Z 110 210 Z 110 200 Z 100 200 Z"
                              : "100 200 Z 110 200 Z 110 210 Z 100 210 Z 100 200 Z";
    for (size_t at; (at = pts.find('Z')) != std::string::npos;) pts.replace(at, 1, std::to_string(z));
    return "<gml:Polygon gml:id=\"" + id + "\"><gml:exterior><gml:LinearRing gml:id=\"" + id +
           "_r\"><gml:posList>" + pts + "</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon>";
}

TEST(CityGmlReader, OrientableSurfaceMinusFlipsTheFace) {
    const auto r = ingest(writeDoc("orientable", R"(<core:cityObjectMember><bldg:Building gml:id="b1"><bldg:lod2MultiSurface><gml:MultiSurface>
<gml:surfaceMember><gml:OrientableSurface orientation="-"><gml:baseSurface>)" + square("p1", 5) +
                                                      R"(</gml:baseSurface></gml:OrientableSurface></gml:surfaceMember>
</gml:MultiSurface></bldg:lod2MultiSurface></bldg:Building></core:cityObjectMember>)"));
    ASSERT_TRUE(r->status.ok()) << r->status.error;
    ASSERT_EQ(r->scene.triangles.size(), 2u);
    for (const Triangle& t : r->scene.triangles) {
        const auto& p = t.position_local;
        EXPECT_LT(cross(p[1] - p[0], p[2] - p[0]).z, 0) << "orientation=\"-\" must face down";
        EXPECT_EQ(t.semantic, SurfaceSemantic::Ground) << "a bare downward polygon is inferred as ground";
    }
    // Compound CRS: horizontal EPSG:25832, origin at the envelope centre.
    EXPECT_EQ(r->scene.georef.source_crs, "EPSG:25832+5783");
    EXPECT_EQ(r->scene.georef.origin_source, (Vec3d{105, 205, 5}));
}

TEST(CityGmlReader, ForwardXlinkToAnotherCityObjectIsResolved) {
    // Building b1's solid references a polygon that only appears later, in b2.
    const auto r = ingest(writeDoc("xlink", R"(<core:cityObjectMember><bldg:Building gml:id="b1"><bldg:lod2Solid><gml:Solid><gml:exterior><gml:CompositeSurface>
<gml:surfaceMember xlink:href="#shared"/></gml:CompositeSurface></gml:exterior></gml:Solid></bldg:lod2Solid></bldg:Building></core:cityObjectMember>
<core:cityObjectMember><bldg:Building gml:id="b2"><bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember>)" +
                                                square("shared", 3) +
                                                R"(</gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface></bldg:Building></core:cityObjectMember>)"));
    ASSERT_TRUE(r->status.ok()) << r->status.error;
    EXPECT_EQ(r->state.counts.xlinks_cross_object, 1u);
    std::map<uint32_t, int> per_feature;
    for (const Triangle& t : r->scene.triangles) per_feature[t.feature]++;
    EXPECT_EQ(per_feature[0], 2) << "b1 gets the referenced square";
    EXPECT_EQ(per_feature[1], 2);
    EXPECT_EQ(r->state.diagnostics.count(warn::kXlinkUnresolved), 0u);
}

TEST(CityGmlReader, AGeometryIdInTwoCityObjectsIsWarnedInEach) {
    // Two buildings with a polygon of the same gml:id, a third apart: the
    // index pass's sorted walk over the ids finds the pair.
    std::string body;
    for (const auto& [b, p] : {std::pair{"b1", "dup"}, std::pair{"b2", "dup"}, std::pair{"b3", "own"}})
        body += std::string(R"(<core:cityObjectMember><bldg:Building gml:id=")") + b +
                R"("><bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember>)" + square(p, 2) +
                R"(</gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface></bldg:Building></core:cityObjectMember>)";
    const auto r = ingest(writeDoc("duplicate_across", body));
    ASSERT_TRUE(r->status.ok()) << r->status.error;
    EXPECT_EQ(r->state.diagnostics.count(warn::kDuplicateGmlId), 2u) << "once in each of the two buildings";
    EXPECT_EQ(r->scene.triangles.size(), 6u) << "each building keeps its own polygon";
    EXPECT_EQ(r->state.counts.xlinks_cross_object, 0u);
}

TEST(CityGmlReader, UnresolvedXlinkIsACountedWarning) {
    const auto r = ingest(writeDoc("dangling", R"(<core:cityObjectMember><bldg:Building gml:id="b1"><bldg:lod2MultiSurface><gml:MultiSurface>
<gml:surfaceMember xlink:href="#nowhere"/><gml:surfaceMember>)" + square("p", 1) +
                                                  R"(</gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface></bldg:Building></core:cityObjectMember>)"));
    ASSERT_TRUE(r->status.ok());
    EXPECT_EQ(r->state.diagnostics.count(warn::kXlinkUnresolved), 1u);
    EXPECT_EQ(r->scene.triangles.size(), 2u);
}

TEST(CityGmlReader, BuildingPartsAreFeaturesWithTheirParent) {
    const auto r = ingest(writeDoc("parts", R"(<core:cityObjectMember><bldg:Building gml:id="b"><bldg:consistsOfBuildingPart><bldg:BuildingPart gml:id="part">
<bldg:lod1Solid><gml:Solid><gml:exterior><gml:CompositeSurface><gml:surfaceMember>)" + square("q", 2) +
                                               R"(</gml:surfaceMember></gml:CompositeSurface></gml:exterior></gml:Solid></bldg:lod1Solid>
</bldg:BuildingPart></bldg:consistsOfBuildingPart></bldg:Building></core:cityObjectMember>)"));
    ASSERT_TRUE(r->status.ok());
    ASSERT_EQ(r->scene.features.size(), 2u);
    EXPECT_EQ(r->scene.features[1].gml_id, "part");
    EXPECT_EQ(r->scene.features[1].parent, 0);
    EXPECT_EQ(r->state.counts.features_without_geometry, 0u) << "geometry in a part counts for the building";
    for (const Triangle& t : r->scene.triangles) EXPECT_EQ(t.feature, 1u);
}

TEST(CityGmlReader, BestLodPrefersLod2AndLodOptionSelects) {
    const std::string body = R"(<core:cityObjectMember><bldg:Building gml:id="b"><bldg:lod1MultiSurface><gml:MultiSurface><gml:surfaceMember>)" +
                             square("l1", 4) + R"(</gml:surfaceMember></gml:MultiSurface></bldg:lod1MultiSurface>
<bldg:boundedBy><bldg:RoofSurface gml:id="rs"><bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember>)" +
                             square("l2", 8) + R"(</gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface></bldg:RoofSurface></bldg:boundedBy>
</bldg:Building></core:cityObjectMember>)";
    const fs::path doc = writeDoc("lods", body);
    const auto best = ingest(doc);
    ASSERT_EQ(best->scene.triangles.size(), 2u);
    EXPECT_NEAR(best->scene.triangles[0].position_local[0].z, 8 - 5, 1e-12);
    EXPECT_EQ(best->scene.triangles[0].semantic, SurfaceSemantic::Roof);
    CityGmlOptions lod1;
    lod1.lod = 1;
    const auto one = ingest(doc, lod1);
    ASSERT_EQ(one->scene.triangles.size(), 2u);
    EXPECT_NEAR(one->scene.triangles[0].position_local[0].z, 4 - 5, 1e-12);
}

TEST(CityGmlReader, TexCoordGenAndThemesAndMaterialFallback) {
    // Two themes; the first has only a material, the second a texture: the
    // default is the first TEXTURED theme. The texture file is missing in
    // theme "night", so that theme falls back to a colour.
    const fs::path dir = scratch("texgen");
    fs::create_directories(dir);
    const std::string png = (dir / "t.png").string();
    {
        // A real 2x2 PNG via the synthetic texture writer's library (OIIO).
        std::ofstream(dir / "make.txt") << "";
    }
    std::string body = R"(<core:cityObjectMember><bldg:Building gml:id="b"><bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember>)" +
                       square("p", 0) + R"(</gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface></bldg:Building></core:cityObjectMember>
<app:appearanceMember><app:Appearance><app:theme>plain</app:theme><app:surfaceDataMember><app:X3DMaterial>
<app:diffuseColor>1 0 0</app:diffuseColor><app:target>#p</app:target></app:X3DMaterial></app:surfaceDataMember></app:Appearance></app:appearanceMember>
<app:appearanceMember><app:Appearance><app:theme>day</app:theme><app:surfaceDataMember><app:ParameterizedTexture>
<app:imageURI>IMAGE</app:imageURI><app:wrapMode>wrap</app:wrapMode><app:target uri="#p"><app:TexCoordGen>
<app:worldToTexture>0.1 0 0 -10 0 0.1 0 -20 0 0 0 1</app:worldToTexture></app:TexCoordGen></app:target>
</app:ParameterizedTexture></app:surfaceDataMember></app:Appearance></app:appearanceMember>)";
    auto docFor = [&](const std::string& image) {
        std::string b = body;
        b.replace(b.find("IMAGE"), 5, image);
        const fs::path p = dir / (image + ".gml");
        std::ofstream(p) << kHeader2 << b << "</core:CityModel>\n";
        return p;
    };
    // Any readable image will do: write one with the synth texture writer.
    synth::TownSettings s;
    s.buildings = 1;
    s.texture_size_px = 16;
    ASSERT_TRUE(synth::writeTown(synth::generateTown(s), dir / "town", true, nullptr).ok());
    fs::copy_file(dir / "town" / "textures" / "paving.png", png);

    const auto r = ingest(docFor("t.png"));
    ASSERT_TRUE(r->status.ok()) << r->status.error;
    EXPECT_EQ(r->state.counts.theme_used, "day");
    EXPECT_EQ(r->state.counts.themes, (std::vector<std::string>{"plain", "day"}));
    ASSERT_EQ(r->scene.triangles.size(), 2u);
    for (const Triangle& t : r->scene.triangles) {
        ASSERT_EQ(t.texture, 0);
        for (int k = 0; k < 3; ++k) {
            // u = 0.1 x - 10, v = 0.1 y - 20 on the file's coordinates (x = 105 + local x, ...).
            EXPECT_NEAR(t.uv[k].x, 0.1 * (105 + t.position_local[k].x) - 10, 1e-9);
            EXPECT_NEAR(t.uv[k].y, 0.1 * (205 + t.position_local[k].y) - 20, 1e-9);
        }
    }
    CityGmlOptions plain;
    plain.theme = "plain";
    const auto red = ingest(docFor("t.png"), plain);
    ASSERT_EQ(red->scene.materials.size(), 1u);
    EXPECT_EQ(red->scene.materials[0].diffuse[0], 1.0f);
    EXPECT_EQ(red->scene.triangles[0].texture, -1);

    const auto missing = ingest(docFor("gone.png"));
    ASSERT_TRUE(missing->status.ok());
    EXPECT_EQ(missing->state.diagnostics.count(warn::kTextureMissing), 1u);
    EXPECT_EQ(missing->scene.triangles[0].texture, -1);
    EXPECT_GE(missing->scene.triangles[0].material, 0) << "a failed texture falls back to a colour";

    CityGmlOptions bad;
    bad.theme = "nope";
    EXPECT_FALSE(ingest(docFor("t.png"), bad)->status.ok());
}

// A scratch folder holding two readable textures, t.png and u.png (a
// synthetic town's paving), for appearances to point at.
fs::path twoTextureFolder(const std::string& name) {
    const fs::path dir = scratch(name);
    fs::create_directories(dir);
    synth::TownSettings ts;
    ts.buildings = 1;
    ts.texture_size_px = 16;
    EXPECT_TRUE(synth::writeTown(synth::generateTown(ts), dir / "town", true, nullptr).ok());
    for (const char* texture : {"t.png", "u.png"})
        fs::copy_file(dir / "town" / "textures" / "paving.png", dir / texture, fs::copy_options::overwrite_existing);
    return dir;
}

// Surface members p1 .. pn: squares at heights 5, 10, ... (rings p<i>_r).
std::string squareSurfaces(int n) {
    std::string surfaces;
    // (fmt rather than operator+: GCC 12 warns falsely, bug 105329.)
    for (int i = 1; i <= n; ++i) surfaces += fmt::format("<gml:surfaceMember>{}</gml:surfaceMember>", square(fmt::format("p{}", i), 5.0 * i));
    return surfaces;
}

TEST(CityGmlReader, GlobalAppearanceStreamedGivesWhatTheSameAppearanceGivesInsideTheBuilding) {
    // The index pass hands a global appearanceMember to the store a piece at
    // a time (its theme, each surface data's header, each target alone);
    // an appearance inside a city object still goes whole. The same
    // appearances either way must give the same scene: textures, materials
    // and uvs per triangle, per theme, and the same theme list.
    const fs::path dir = twoTextureFolder("global_streamed");
    const std::string surfaces = squareSurfaces(5);
    const std::string uv = "0 0 1 0 1 1 0 1 0 0";
    // Day: a texture (with an id, reused by night) with two targets, one
    // TexCoordList with an id; a material; a texture whose target comes
    // before its imageURI (it must wait for it) and a TexCoordGen target.
    // Night: the day texture by reference. "bare": no surface data at all.
    const std::string appearances =
        R"(<app:Appearance><app:theme>bare</app:theme></app:Appearance>)"
        R"(<app:Appearance><app:theme>day</app:theme>)"
        R"(<app:surfaceDataMember><app:ParameterizedTexture gml:id="pt"><app:imageURI>t.png</app:imageURI><app:wrapMode>wrap</app:wrapMode>)"
        R"(<app:target uri="#p1"><app:TexCoordList><app:textureCoordinates ring="#p1_r">)" + uv +
        R"(</app:textureCoordinates></app:TexCoordList></app:target>)"
        R"(<app:target uri="#p2"><app:TexCoordList gml:id="tcl2"><app:textureCoordinates ring="#p2_r">0 0 2 0 2 2 0 2 0 0</app:textureCoordinates></app:TexCoordList></app:target>)"
        R"(</app:ParameterizedTexture></app:surfaceDataMember>)"
        R"(<app:surfaceDataMember><app:X3DMaterial><app:diffuseColor>0 1 0</app:diffuseColor><app:target>#p3</app:target></app:X3DMaterial></app:surfaceDataMember>)"
        R"(<app:surfaceDataMember><app:ParameterizedTexture><app:target uri="#p4"><app:TexCoordList><app:textureCoordinates ring="#p4_r">)" + uv +
        R"(</app:textureCoordinates></app:TexCoordList></app:target><app:imageURI>u.png</app:imageURI>)"
        R"(<app:target uri="#p5"><app:TexCoordGen><app:worldToTexture>0.1 0 0 -10 0 0.1 0 -20 0 0 0 1</app:worldToTexture></app:TexCoordGen></app:target>)"
        R"(</app:ParameterizedTexture></app:surfaceDataMember></app:Appearance>)"
        R"(<app:Appearance><app:theme>night</app:theme><app:surfaceDataMember xlink:href="#pt"/></app:Appearance>)";
    std::string global_appearances, local_appearances;
    for (size_t at = 0, end; (end = appearances.find("</app:Appearance>", at)) != std::string::npos; at = end + 17) {
        const std::string one = appearances.substr(at, end + 17 - at);
        global_appearances += "<app:appearanceMember>" + one + "</app:appearanceMember>\n";
        local_appearances += "<app:appearance>" + one + "</app:appearance>";
    }
    auto write = [&](const std::string& name, const std::string& inside, const std::string& after) {
        const fs::path p = dir / (name + ".gml");
        std::ofstream(p) << kHeader2 << R"(<core:cityObjectMember><bldg:Building gml:id="b">)" << inside
                         << "<bldg:lod2MultiSurface><gml:MultiSurface>" << surfaces
                         << "</gml:MultiSurface></bldg:lod2MultiSurface></bldg:Building></core:cityObjectMember>\n"
                         << after << "</core:CityModel>\n";
        return p;
    };
    const fs::path global = write("global", "", global_appearances);
    const fs::path local = write("local", local_appearances, "");
    for (const char* theme : {"", "day", "night", "bare"}) {
        CityGmlOptions o;
        o.theme = theme;
        const auto g = ingest(global, o), l = ingest(local, o);
        ASSERT_TRUE(g->status.ok()) << g->status.error;
        ASSERT_TRUE(l->status.ok()) << l->status.error;
        EXPECT_EQ(g->state.counts.themes, (std::vector<std::string>{"bare", "day", "night"}));
        EXPECT_EQ(g->state.counts.themes, l->state.counts.themes);
        EXPECT_EQ(g->state.counts.theme_used, l->state.counts.theme_used) << theme;
        EXPECT_EQ(g->state.diagnostics.total(), l->state.diagnostics.total()) << theme;
        ASSERT_EQ(g->scene.triangles.size(), 10u);
        ASSERT_EQ(g->scene.triangles.size(), l->scene.triangles.size());
        ASSERT_EQ(g->scene.textures.size(), l->scene.textures.size()) << theme;
        for (size_t t = 0; t < g->scene.textures.size(); ++t) EXPECT_EQ(g->scene.textures.path(t), l->scene.textures.path(t));
        ASSERT_EQ(g->scene.materials.size(), l->scene.materials.size()) << theme;
        for (size_t m = 0; m < g->scene.materials.size(); ++m) EXPECT_EQ(g->scene.materials[m], l->scene.materials[m]);
        for (size_t i = 0; i < g->scene.triangles.size(); ++i) {
            const Triangle &a = g->scene.triangles[i], &b = l->scene.triangles[i];
            EXPECT_EQ(a.texture, b.texture) << theme << " triangle " << i;
            EXPECT_EQ(a.material, b.material) << theme << " triangle " << i;
            for (int k = 0; k < 3; ++k) EXPECT_EQ(a.uv[k], b.uv[k]) << theme << " triangle " << i;
        }
        if (std::string(theme) == "day" || std::string(theme).empty()) {
            // Every surface got what its appearance gave it: p1, p2 t.png, p3 green, p4, p5 u.png.
            const std::vector<int32_t> texture = {0, 0, 0, 0, -1, -1, 1, 1, 1, 1};
            for (size_t i = 0; i < 10; ++i) EXPECT_EQ(g->scene.triangles[i].texture, texture[i]) << "triangle " << i;
            EXPECT_EQ(g->scene.materials[static_cast<size_t>(g->scene.triangles[4].material)].diffuse[1], 1.0f);
        }
        if (std::string(theme) == "night") {
            // The day texture by reference: p1 and p2, with their own coordinates (p2's reach 2).
            const std::vector<int32_t> texture = {0, 0, 0, 0, -1, -1, -1, -1, -1, -1};
            for (size_t i = 0; i < 10; ++i) EXPECT_EQ(g->scene.triangles[i].texture, texture[i]) << "night triangle " << i;
            double p2_max = 0;
            for (size_t i = 2; i < 4; ++i)
                for (const Vec2d& t : g->scene.triangles[i].uv) p2_max = std::max({p2_max, t.x, t.y});
            EXPECT_EQ(p2_max, 2.0);
        }
    }
    // A header element after the targets it should have applied to (against
    // the schema's order) is a counted warning; whole, the DOM would apply it to all.
    const fs::path late = write("late", "",
                                R"(<app:appearanceMember><app:Appearance><app:surfaceDataMember><app:ParameterizedTexture>)"
                                R"(<app:imageURI>t.png</app:imageURI><app:target uri="#p1"><app:TexCoordList><app:textureCoordinates ring="#p1_r">)" +
                                    uv + R"(</app:textureCoordinates></app:TexCoordList></app:target><app:wrapMode>clamp</app:wrapMode>)"
                                R"(</app:ParameterizedTexture></app:surfaceDataMember></app:Appearance></app:appearanceMember>)");
    const auto w = ingest(late);
    ASSERT_TRUE(w->status.ok()) << w->status.error;
    EXPECT_EQ(w->state.diagnostics.count(warn::kAppearanceUnsupported), 1u);
    EXPECT_EQ(w->scene.triangles[0].texture, 0) << "the target before it keeps its texture";
}

TEST(CityGmlReader, SurfaceDataByReferenceGivesItsOwnDataWhereItsThemeHadAnothers) {
    // Day: texture "a" on p1 (coordinates up to 1), then texture "pt" on p1
    // again (up to 2: day keeps a's) and on p2, material "m" on p3. Night
    // refers to pt and m: p1 gets pt's own texture and coordinates, not
    // what day kept. (The store keeps a surface data by id as pointers to
    // its theme's entries, and copies only what differs from them.)
    const fs::path dir = twoTextureFolder("by_reference");
    const std::string surfaces = squareSurfaces(3);
    auto target = [](const char* p, const char* uv) {
        return fmt::format(R"(<app:target uri="#{0}"><app:TexCoordList><app:textureCoordinates ring="#{0}_r">{1})"
                           R"(</app:textureCoordinates></app:TexCoordList></app:target>)", p, uv);
    };
    const std::string appearances =
        std::string(R"(<app:appearanceMember><app:Appearance><app:theme>day</app:theme>)"
                    R"(<app:surfaceDataMember><app:ParameterizedTexture gml:id="a"><app:imageURI>t.png</app:imageURI>)") +
        target("p1", "0 0 1 0 1 1 0 1 0 0") +
        R"(</app:ParameterizedTexture></app:surfaceDataMember>)"
        R"(<app:surfaceDataMember><app:ParameterizedTexture gml:id="pt"><app:imageURI>u.png</app:imageURI>)" +
        target("p1", "0 0 2 0 2 2 0 2 0 0") + target("p2", "0 0 1 0 1 1 0 1 0 0") +
        R"(</app:ParameterizedTexture></app:surfaceDataMember>)"
        R"(<app:surfaceDataMember><app:X3DMaterial gml:id="m"><app:diffuseColor>0 1 0</app:diffuseColor><app:target>#p3</app:target></app:X3DMaterial></app:surfaceDataMember>)"
        R"(</app:Appearance></app:appearanceMember>)"
        R"(<app:appearanceMember><app:Appearance><app:theme>night</app:theme><app:surfaceDataMember xlink:href="#pt"/>)"
        R"(<app:surfaceDataMember xlink:href="#m"/></app:Appearance></app:appearanceMember>)";
    const fs::path file = dir / "by_reference.gml";
    std::ofstream(file) << kHeader2 << R"(<core:cityObjectMember><bldg:Building gml:id="b"><bldg:lod2MultiSurface><gml:MultiSurface>)"
                        << surfaces << "</gml:MultiSurface></bldg:lod2MultiSurface></bldg:Building></core:cityObjectMember>\n"
                        << appearances << "</core:CityModel>\n";
    auto maxUv = [](const auto& r, size_t first) {
        double m = 0;
        for (size_t i = first; i < first + 2; ++i)
            for (const Vec2d& t : r.scene.triangles[i].uv) m = std::max({m, t.x, t.y});
        return m;
    };
    CityGmlOptions day, night;
    day.theme = "day";
    night.theme = "night";
    const auto d = ingest(file, day), n = ingest(file, night);
    ASSERT_TRUE(d->status.ok()) << d->status.error;
    ASSERT_TRUE(n->status.ok()) << n->status.error;
    ASSERT_EQ(d->scene.triangles.size(), 6u);
    ASSERT_EQ(n->scene.triangles.size(), 6u);
    EXPECT_EQ(fs::path(d->scene.textures.path(static_cast<size_t>(d->scene.triangles[0].texture))).filename(), "t.png");
    EXPECT_EQ(maxUv(*d, 0), 1.0) << "day keeps the first texture given to p1";
    EXPECT_EQ(fs::path(n->scene.textures.path(static_cast<size_t>(n->scene.triangles[0].texture))).filename(), "u.png");
    EXPECT_EQ(maxUv(*n, 0), 2.0) << "night: pt's own coordinates for p1";
    EXPECT_EQ(fs::path(n->scene.textures.path(static_cast<size_t>(n->scene.triangles[2].texture))).filename(), "u.png");
    ASSERT_GE(n->scene.triangles[4].material, 0);
    EXPECT_EQ(n->scene.materials[static_cast<size_t>(n->scene.triangles[4].material)].diffuse[1], 1.0f) << "m by reference";
}

TEST(CityGmlReader, CityGml1NamespaceAndPosElementsAnd2dCoordinates) {
    constexpr const char* header1 = R"(<?xml version="1.0"?>
<CityModel xmlns="http://www.opengis.net/citygml/1.0" xmlns:bldg="http://www.opengis.net/citygml/building/1.0"
 xmlns:gml="http://www.opengis.net/gml">
)";
    const auto r = ingest(writeDoc("v1", R"(<cityObjectMember><bldg:Building gml:id="b"><bldg:lod1MultiSurface><gml:MultiSurface srsName="EPSG:25833"><gml:surfaceMember>
<gml:Polygon><gml:exterior><gml:LinearRing><gml:pos srsDimension="2">0 0</gml:pos><gml:pos srsDimension="2">4 0</gml:pos>
<gml:pos srsDimension="2">4 4</gml:pos><gml:pos srsDimension="2">0 0</gml:pos></gml:LinearRing></gml:exterior></gml:Polygon>
</gml:surfaceMember></gml:MultiSurface></bldg:lod1MultiSurface></bldg:Building></cityObjectMember>)",
                                   header1, "</CityModel>\n"));
    ASSERT_TRUE(r->status.ok()) << r->status.error;
    ASSERT_EQ(r->state.files.size(), 1u);
    EXPECT_EQ(r->state.files.at(0).citygml_version, "1.0");
    EXPECT_EQ(r->scene.georef.source_crs, "EPSG:25833");
    EXPECT_EQ(r->scene.triangles.size(), 1u);
    EXPECT_EQ(r->state.diagnostics.count(warn::kCoordinates2d), 1u);
}

// An undeclared namespace prefix is an error libxml2 reads past; so must we:
// a counted warning, and every building after it read (the xmlTextReader
// walk stopped there, exit 0, 1 building of 3).
TEST(CityGmlReader, UndeclaredPrefixIsAWarningAndTheRestIsRead) {
    std::string body;
    for (int i = 0; i < 3; ++i)
        body += "<core:cityObjectMember><bldg:Building gml:id=\"b" + std::to_string(i) + "\">" +
                (i == 0 ? "<uro:buildingID>x</uro:buildingID>" : "") +
                "<bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember>" + square("p" + std::to_string(i), i) +
                "</gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface></bldg:Building></core:cityObjectMember>\n";
    const auto r = ingest(writeDoc("undeclared_prefix", body));
    ASSERT_TRUE(r->status.ok()) << r->status.error;
    EXPECT_EQ(r->scene.features.size(), 3u);
    EXPECT_EQ(r->state.diagnostics.count("xml_namespace_error"), 1u);
}

TEST(CityGmlReader, FatalErrorsNameTheFile) {
    const fs::path nocrs = writeDoc("nocrs", "", R"(<?xml version="1.0"?>
<core:CityModel xmlns:core="http://www.opengis.net/citygml/2.0">
)");
    const auto missing_crs = ingest(nocrs);
    EXPECT_FALSE(missing_crs->status.ok());
    EXPECT_NE(missing_crs->status.error.find("crs_missing"), std::string::npos) << missing_crs->status.error;
    EXPECT_NE(missing_crs->status.error.find("nocrs.gml"), std::string::npos);
    CityGmlOptions with_crs;
    with_crs.fallback_crs = "EPSG:25832";
    EXPECT_TRUE(ingest(nocrs, with_crs)->status.ok());

    const fs::path trunc = scratch("trunc.gml");
    std::ofstream(trunc) << kHeader2 << "<core:cityObjectMember><bldg:Building gml:id=\"b\"><bldg:lod2MultiSurface>";
    const auto t = ingest(trunc);
    EXPECT_FALSE(t->status.ok());
    EXPECT_EQ(t->status.error.rfind("xml_malformed", 0), 0u) << t->status.error;
    EXPECT_TRUE(t->scene.triangles.empty()) << "nothing is emitted from a file that is not well-formed";

    // A root that is never closed is a truncated file too.
    const fs::path open_root = writeDoc("open_root", "", R"(<?xml version="1.0"?>
<core:CityModel xmlns:core="http://www.opengis.net/citygml/2.0">
)", "");
    const auto o = ingest(open_root, with_crs);
    EXPECT_EQ(o->status.error.rfind("xml_malformed", 0), 0u) << o->status.error;
}

}  // namespace
}  // namespace cityatlas
