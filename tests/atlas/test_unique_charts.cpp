// SPDX-License-Identifier: GPL-3.0-or-later
// --unique-charts (issue 19, SEED-FEATURES M2): no two world-distinct
// triangles share atlas texels. The oracle rasterizes every leaf triangle in
// its atlas at texel centres, written here from the atlas coordinates alone,
// and maps each texel back to the world point it stands for; a texel claimed
// by two triangles at points more than a millimetre apart is a collision.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <vector>

#include "atlas/atlas_tree.h"
#include "atlas/charts.h"
#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"
#include "tests/atlas/scenes.h"
#include "tests/ingest/test_support.h"

namespace cityatlas::atlas {
namespace {

struct Collisions {
    uint64_t texels = 0;      // texels claimed by at least one textured triangle
    uint64_t collisions = 0;  // texels claimed by two triangles at world-distinct points
};

double cross2(const Vec2d& o, const Vec2d& a, const Vec2d& b) {
    return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

// Every leaf layer's triangles rasterized at texel centres (closed triangles:
// a centre on an edge belongs to both sides, which map it to one point).
Collisions countCollisions(const AtlasTree& tree) {
    Collisions out;
    const int a = tree.params.atlas_size_px;
    for (const AtlasNode& node : tree.nodes) {
        if (!node.leaf()) continue;
        for (const NodeLayer& layer : node.layers) {
            if (!layer.present()) continue;
            std::unordered_map<int64_t, Vec3d> claimed;  // texel -> the world point of its first claim
            for (uint32_t i = layer.range.first; i < layer.range.first + layer.range.count; ++i) {
                const TreeTriangle& t = tree.triangles[i];
                if (t.tri.texture < 0) continue;
                std::array<Vec2d, 3> p;
                for (int k = 0; k < 3; ++k) p[k] = layer.texelFromRoot(t.atlas_uv[k], node.level, a);
                const double area = cross2(p[0], p[1], p[2]);
                if (area == 0) continue;  // one colour or a line: covers no texel's interior
                const int x0 = static_cast<int>(std::floor(std::min({p[0].x, p[1].x, p[2].x})));
                const int x1 = static_cast<int>(std::ceil(std::max({p[0].x, p[1].x, p[2].x})));
                const int y0 = static_cast<int>(std::floor(std::min({p[0].y, p[1].y, p[2].y})));
                const int y1 = static_cast<int>(std::ceil(std::max({p[0].y, p[1].y, p[2].y})));
                for (int y = y0; y < y1; ++y)
                    for (int x = x0; x < x1; ++x) {
                        const Vec2d c{x + 0.5, y + 0.5};
                        const double w0 = cross2(p[1], p[2], c) / area, w1 = cross2(p[2], p[0], c) / area,
                                     w2 = cross2(p[0], p[1], c) / area;
                        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
                        const auto& q = t.tri.position_local;
                        const Vec3d world = w0 * q[0] + w1 * q[1] + w2 * q[2];
                        const int64_t key = int64_t{y} * (int64_t{1} << 32) + x;
                        const auto [it, fresh] = claimed.emplace(key, world);
                        if (fresh) {
                            ++out.texels;
                        } else if (length(it->second - world) > 1e-3) {
                            ++out.collisions;
                            it->second = world;  // count each further distinct claim once more
                        }
                    }
            }
        }
    }
    return out;
}

Triangle wallTriangle(Vec3d a, Vec3d b, Vec3d c, Vec2d ta, Vec2d tb, Vec2d tc, int32_t texture, uint32_t feature) {
    Triangle t;
    t.position_local = {a, b, c};
    t.uv = {ta, tb, tc};
    t.texture = texture;
    t.feature = feature;
    t.semantic = SurfaceSemantic::Wall;
    return t;
}

// What real CityGML does: many walls in different places, each mapping the
// same photo 0..1 (one texture shared by a street of buildings), plus walls
// that wrap one texture around a corner with continuous u (one surface).
Scene reusedPhotoScene() {
    Scene scene;
    TextureRef photo;
    photo.path = "/nonexistent/photo.png";
    photo.width_px = 256, photo.height_px = 128, photo.channels = 3;
    scene.textures.push_back(photo);
    for (uint32_t b = 0; b < 12; ++b) {
        const double x = 30.0 * b, w = 10.0, h = 6.0;
        for (int side = 0; side < 2; ++side) {  // front and back, both 0..1
            const double y = side * 8.0;
            const Vec3d p00{x, y, 0}, p10{x + w, y, 0}, p11{x + w, y, h}, p01{x, y, h};
            scene.triangles.push_back(wallTriangle(p00, p10, p11, {0, 0}, {1, 0}, {1, 1}, 0, b));
            scene.triangles.push_back(wallTriangle(p00, p11, p01, {0, 0}, {1, 1}, {0, 1}, 0, b));
        }
        // Around the corner: the side wall continues u from 1 to 1.8.
        const Vec3d q0{x + w, 0, 0}, q1{x + w, 8, 0}, q2{x + w, 8, h}, q3{x + w, 0, h};
        scene.triangles.push_back(wallTriangle(q0, q1, q2, {1, 0}, {1.8, 0}, {1.8, 1}, 0, b));
        scene.triangles.push_back(wallTriangle(q0, q2, q3, {1, 0}, {1.8, 1}, {1, 1}, 0, b));
    }
    Feature f;
    scene.features.assign(12, f);
    return scene;
}

AtlasParams structureOnly(bool unique) {
    AtlasParams p;
    p.render_images = false;
    p.d_min_m = 40;
    p.unique_charts = unique;
    return p;
}

AtlasTree buildTree(const Scene& scene, const AtlasParams& params) {
    AtlasTree tree;
    Diagnostics diagnostics;
    const Status s = buildAtlasTree(scene, params, {}, diagnostics, {}, &tree);
    EXPECT_TRUE(s.ok()) << s.error;
    return tree;
}

SurfaceTriangle surfaceTriangle(Vec3d a, Vec3d b, Vec3d c, Vec2d ta, Vec2d tb, Vec2d tc) {
    return {{a, b, c}, {ta, tb, tc}};
}

TEST(SurfaceComponents, JoinsAlongSharedEdgesWithoutFolding) {
    const Vec3d p00{0, 0, 0}, p10{1, 0, 0}, p11{1, 1, 0}, p01{0, 1, 0};
    std::vector<SurfaceTriangle> t = {
        surfaceTriangle(p00, p10, p11, {0, 0}, {1, 0}, {1, 1}),  // 0: a quad's two halves: one surface
        surfaceTriangle(p00, p11, p01, {0, 0}, {1, 1}, {0, 1}),  // 1
        // 2: the same uv elsewhere in the world: its own surface.
        surfaceTriangle({5, 0, 0}, {6, 0, 0}, {6, 1, 0}, {0, 0}, {1, 0}, {1, 1}),
        // 3: shares 0's edge p00-p10 with the same uv, but lies on 0's side of it in uv (a fold).
        surfaceTriangle(p00, p10, {0.5, -1, 0}, {0, 0}, {1, 0}, {0.5, 0.5}),
        // 4: zero uv area (one colour): joins nothing, though it shares 1's edge.
        surfaceTriangle(p11, p01, {0.5, 2, 0}, {0.5, 0.5}, {0.5, 0.5}, {0.5, 0.5}),
        // 5: shares the edge p10-p11 in position but not in uv: a seam, not a joint.
        surfaceTriangle(p10, {2, 0, 0}, p11, {0, 0}, {1, 0}, {0, 1}),
    };
    EXPECT_EQ(surfaceComponents(t), (std::vector<uint32_t>{0, 0, 2, 3, 4, 5}));
    // 6: a third triangle on 0 and 1's diagonal (non-manifold), on 0's side in
    // uv and so opposite 1: joining along such an edge could fold 6 over 0,
    // so nothing joins along it (0 and 1 part: a region more, never a collision).
    t.push_back(surfaceTriangle(p00, p11, {1, -1, 0}, {0, 0}, {1, 1}, {0.8, 0.1}));
    EXPECT_EQ(surfaceComponents(t), (std::vector<uint32_t>{0, 1, 2, 3, 4, 5, 6}));
}

// A surface written twice (a solid's member and a multi-surface, as PLATEAU
// files do): the copies are one place, and their edges still join the quad.
TEST(SurfaceComponents, CopiesOfATriangleAreOnePlace) {
    const Vec3d p00{0, 0, 0}, p10{1, 0, 0}, p11{1, 1, 0}, p01{0, 1, 0};
    const std::vector<SurfaceTriangle> t = {
        surfaceTriangle(p00, p10, p11, {0, 0}, {1, 0}, {1, 1}),
        surfaceTriangle(p00, p11, p01, {0, 0}, {1, 1}, {0, 1}),
        surfaceTriangle(p00, p10, p11, {0, 0}, {1, 0}, {1, 1}),  // copies of both halves
        surfaceTriangle(p11, p01, p00, {1, 1}, {0, 1}, {0, 0}),  // (another corner order)
    };
    EXPECT_EQ(surfaceComponents(t), (std::vector<uint32_t>{0, 0, 0, 0}));
}

TEST(UniqueCharts, SameUvOnTwoSurfacesGetsTwoRegions) {
    // 125 texels per unit of uv at d_min: the 8-texel borders span 0.064.
    std::vector<ChartMember> m = {{{0, 0}, {1, 1}, 5000, 5000, 0}, {{0, 0}, {1, 1}, 5000, 5000, 0}};
    ChartSettings cs;
    cs.d_min_m = 40;
    EXPECT_EQ(planTextureRegions(m, cs).regions.size(), 1u);  // shared: the papers' and our default
    m[1].surface = 7;
    cs.unique = true;
    const TextureRegions r = planTextureRegions(m, cs);
    ASSERT_EQ(r.regions.size(), 2u);
    EXPECT_NE(r.region_of[0], r.region_of[1]);
    // Disjoint boxes of two surfaces may still share a region (no texel lies in both)...
    m[1].uv_min = {1.01, 0}, m[1].uv_max = {2, 1};
    EXPECT_EQ(planTextureRegions(m, cs).regions.size(), 1u);
    // ...touching ones may not.
    m[1].uv_min = {1, 0};
    EXPECT_EQ(planTextureRegions(m, cs).regions.size(), 2u);
}

// M2 on real data's pattern. The test's own negative: without the option the
// same scene collides (so the oracle sees shared texels).
TEST(UniqueCharts, NoTexelBelongsToTwoPlacesOnReusedPhotos) {
    const Scene scene = reusedPhotoScene();
    const Collisions shared = countCollisions(buildTree(scene, structureOnly(false)));
    const Collisions unique = countCollisions(buildTree(scene, structureOnly(true)));
    std::cout << "reused photo: shared " << shared.collisions << " collisions of " << shared.texels
              << " texels; unique " << unique.collisions << " of " << unique.texels << "\n";
    EXPECT_GT(shared.collisions, 1000u);
    EXPECT_EQ(unique.collisions, 0u);
    // Every wall now has texels of its own: more texels than shared.
    EXPECT_GT(unique.texels, shared.texels);
}

// M2 on a synthetic town (LOD2: wrapped facades, roofs).
TEST(UniqueCharts, NoTexelBelongsToTwoPlacesOnTheSynthTown) {
    synth::TownSettings settings;
    settings.buildings = 60;
    settings.seed = 3;
    settings.lod = 2;
    const Scene scene = synth::townToScene(synth::generateTown(settings), "/nonexistent/town");
    const AtlasTree unique = buildTree(scene, structureOnly(true));
    const Collisions c = countCollisions(unique);
    std::cout << "synth town: " << c.collisions << " collisions of " << c.texels << " texels\n";
    EXPECT_GT(c.texels, 100000u);
    EXPECT_EQ(c.collisions, 0u);
}

// M2 on real data, the textured files of the team's shared folder: PLATEAU's
// one atlas image for a whole building (its texture grows 0.14 -> 0.16 MB
// of atlas with the option), the Berlin VCS export (one image a polygon)
// and the SIG3D example (texture-coordinate generation, uv outside 0..1).
TEST(UniqueCharts, NoTexelBelongsToTwoPlacesOnRealData) {
    namespace fs = std::filesystem;
    const fs::path data = test::sharedDir() / "data";
    const std::vector<fs::path> files = {
        data / "citygml2_textured_plateau_tokyo_meiji_gallery/53394517_bldg_6697_2_op_CityGML2.gml",
        data / "citygml2_textured_berlin_vcs_export/export.gml",
        data / "citygml2_textured_sig3d_appearance_example/Appearance-EPSG25832.gml"};
    for (const fs::path& file : files) {
        if (!fs::is_regular_file(file))
            GTEST_SKIP() << file << " is absent (the team's shared data, ../shared beside the clone): no real data to test with";
        Scene scene;
        const Status s = test::readCityGmlScene(file, &scene);
        ASSERT_TRUE(s.ok()) << s.error;
        AtlasParams p = structureOnly(true);
        p.d_min_m.reset();  // the default: chosen from the data
        const Collisions unique = countCollisions(buildTree(scene, p));
        p.unique_charts = false;
        const Collisions shared = countCollisions(buildTree(scene, p));
        std::cout << file.filename().string() << ": shared " << shared.collisions << " collisions of " << shared.texels
                  << " texels; unique " << unique.collisions << " of " << unique.texels << "\n";
        EXPECT_GT(unique.texels, 1000u);
        EXPECT_EQ(unique.collisions, 0u) << file;
    }
}

}  // namespace
}  // namespace cityatlas::atlas
