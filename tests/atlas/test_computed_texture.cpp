// SPDX-License-Identifier: GPL-3.0-or-later
// Computed textures over the atlas coordinates (atlas/computed_texture.h;
// issue 19): the texel -> surface map against the photo atlas's own region
// mapping, its border fill, and the sky-view factor read from leaf computed
// images against the town's exact truths T1 and T3, independent of threads
// (T8 for the values).
#include "atlas/computed_texture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "atlas/raycast.h"
#include "atlas/sky_view.h"
#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"
#include "tests/atlas/scenes.h"

namespace cityatlas::atlas {
namespace {

struct TownTree {
    synth::Town town;
    Scene scene;
    AtlasTree tree;
    size_t tallest = 0;
};

// A town whose tallest building has a flat textured roof (T1 needs one), its atlas
// tree with unique charts (structure only: no texture is read).
TownTree flatTallestTown() {
    // Flat and paved: an untextured roof has no atlas texels, so no computed ones.
    auto found = test::townWithTallest(30, 64, [](const synth::Town& town, size_t tallest) {
        const synth::SynthBuilding& b = town.buildings[tallest];
        return b.roof == synth::RoofType::Flat && b.roof_texture >= 0;
    });
    if (!found) {
        ADD_FAILURE() << "no seed in 1..39 gives a flat paved tallest building";
        return {};
    }
    TownTree c;
    c.town = std::move(found->first);
    c.tallest = found->second;
    c.scene = synth::townToScene(c.town, "/nonexistent");
    AtlasParams p;
    p.render_images = false;
    p.unique_charts = true;
    p.d_min_m = 150;
    Diagnostics diagnostics;
    const Status st = buildAtlasTree(c.scene, p, {}, diagnostics, {}, &c.tree);
    EXPECT_TRUE(st.ok()) << st.error;
    return c;
}

const TownTree& town() {
    static const TownTree t = flatTallestTown();
    return t;
}

std::vector<int32_t> leaves(const AtlasTree& tree) {
    std::vector<int32_t> out;
    for (size_t k = 0; k < tree.nodes.size(); ++k)
        if (tree.nodes[k].leaf() && tree.nodes[k].layers[0].present()) out.push_back(static_cast<int32_t>(k));
    return out;
}

// Barycentric coordinates of a point on a triangle's plane, from positions.
std::array<double, 3> barycentric3(const std::array<Vec3d, 3>& p, const Vec3d& q) {
    const Vec3d n = cross(p[1] - p[0], p[2] - p[0]);
    const double nn = dot(n, n);
    const double w0 = dot(cross(p[2] - p[1], q - p[1]), n) / nn, w1 = dot(cross(p[0] - p[2], q - p[2]), n) / nn;
    return {w0, w1, 1 - w0 - w1};
}

// Every covered texel's surface point shows, in its triangle's ORIGINAL
// texture, the texel the photo atlas shows there: the region's own mapping
// (PackedRegion::toTexture, what fills the atlas image) at the texel centre
// equals the triangle's uv interpolated at the point's barycentric
// coordinates, computed from positions. Border texels lie in their region,
// and every texel of a region with a covered texel stands for a point.
TEST(ComputedTexture, TexelsStandForThePointsThePhotoAtlasShows) {
    const TownTree& c = town();
    uint64_t covered = 0, border = 0;
    double worst = 0;
    for (int32_t n : leaves(c.tree)) {
        const NodeLayer& nl = c.tree.nodes[static_cast<size_t>(n)].layers[0];
        const LeafTexelMap map = leafTexelMap(c.tree, n, Layer::Opaque, 1);
        ASSERT_EQ(map.width, nl.width);
        ASSERT_EQ(map.height, nl.height);
        std::vector<uint8_t> in_region(map.texel.size(), 0);
        for (const PackedRegion& r : nl.regions)
            for (int y = r.y; y < r.y + r.h; ++y)
                for (int x = r.x; x < r.x + r.w; ++x) in_region[static_cast<size_t>(y) * map.width + x] = 1;
        for (int y = 0; y < map.height; ++y)
            for (int x = 0; x < map.width; ++x) {
                const int32_t s = map.texel[static_cast<size_t>(y) * map.width + x];
                if (s < 0) continue;
                ASSERT_TRUE(in_region[static_cast<size_t>(y) * map.width + x]) << "a texel outside every region";
                const TexelSurface& ts = map.surfaces[static_cast<size_t>(s)];
                if (!ts.covered) {
                    ++border;
                    continue;
                }
                ++covered;
                const Triangle& t = c.tree.triangles[ts.triangle].tri;
                const PackedRegion* region = nullptr;
                for (const PackedRegion& r : nl.regions)
                    if (r.texture == t.texture && x >= r.x && x < r.x + r.w && y >= r.y && y < r.y + r.h) region = &r;
                ASSERT_NE(region, nullptr);
                const Vec2d from_atlas = region->toTexture({x + 0.5, y + 0.5});
                const auto w = barycentric3(t.position_local, ts.point);
                const Vec2d from_point{w[0] * t.uv[0].x + w[1] * t.uv[1].x + w[2] * t.uv[2].x,
                                       w[0] * t.uv[0].y + w[1] * t.uv[1].y + w[2] * t.uv[2].y};
                const TextureRef tex = c.scene.textures.ref(static_cast<size_t>(t.texture));
                worst = std::max({worst, std::abs(from_atlas.x - from_point.x) * tex.width_px,
                                  std::abs(from_atlas.y - from_point.y) * tex.height_px});
            }
        // Border fill: a region with a covered texel has no empty texel.
        for (const PackedRegion& r : nl.regions) {
            int have = 0, empty = 0;
            for (int y = r.y; y < r.y + r.h; ++y)
                for (int x = r.x; x < r.x + r.w; ++x) {
                    const int32_t s = map.texel[static_cast<size_t>(y) * map.width + x];
                    have += s >= 0 && map.surfaces[static_cast<size_t>(s)].covered;
                    empty += s < 0;
                }
            if (have > 0) {
                EXPECT_EQ(empty, 0) << "a region's border is not filled";
            }
        }
    }
    std::printf("  %llu covered texels, %llu border texels; texture texels off: %.2e\n",
                static_cast<unsigned long long>(covered), static_cast<unsigned long long>(border), worst);
    EXPECT_GT(covered, 100000u);
    EXPECT_GT(border, 1000u);
    EXPECT_LT(worst, 1e-6);
}

// T1 and T3 read from the computed images (scale 4, 32 directions: a power
// of two splits a wall's hemisphere exactly, so T3 holds for any such N):
// covered texels of the flat roof at the town's top are exactly 1; covered
// wall texels are at most 1/2. And the images do not depend on threads.
TEST(ComputedTexture, SkyViewImagesMeetT1AndT3AndIgnoreThreads) {
    const TownTree& c = town();
    std::vector<std::array<Vec3d, 3>> tris;
    for (const Triangle& t : c.scene.triangles) tris.push_back(t.position_local);
    const auto caster = RayCaster::build(tris);
    const auto dirs = hemisphereDirections(32);
    auto svf = [&](const TexelSurface& s) { return skyViewFactor(*caster, s.point, s.normal, dirs); };
    const synth::SynthBuilding& tallest = c.town.buildings[c.tallest];
    const double top = tallest.base_height_m + tallest.ridge_height_m;
    int t1 = 0, t3 = 0;
    for (int32_t n : leaves(c.tree)) {
        const LeafTexelMap map = leafTexelMap(c.tree, n, Layer::Opaque, 4);
        const ScalarImage one = evaluateComputed(map, svf, 1, -1.0f);
        const ScalarImage two = evaluateComputed(map, svf, 2, -1.0f);
        ASSERT_EQ(one.value, two.value) << "leaf " << n << " depends on the thread count";
        const format::Image8 q = quantizeUnit(one);  // rows top-down
        auto stored = [&](size_t k) {
            const size_t x = k % static_cast<size_t>(map.width), y = k / static_cast<size_t>(map.width);
            return q.pixels[(static_cast<size_t>(map.height) - 1 - y) * static_cast<size_t>(map.width) + x];
        };
        for (size_t k = 0; k < map.texel.size(); ++k) {
            if (map.texel[k] < 0) {
                EXPECT_EQ(one.value[k], -1.0f);
                continue;
            }
            const TexelSurface& s = map.surfaces[static_cast<size_t>(map.texel[k])];
            if (!s.covered) continue;
            const Triangle& t = c.tree.triangles[s.triangle].tri;
            if (t.feature == c.tallest && t.semantic == SurfaceSemantic::Roof && s.normal.z > 0.999 &&
                t.position_local[0].z == top) {
                EXPECT_EQ(one.value[k], 1.0f) << "T1";
                EXPECT_EQ(stored(k), 255) << "T1 stored";
                ++t1;
            }
            if (t.semantic == SurfaceSemantic::Wall) {
                EXPECT_LE(one.value[k], 0.5f) << "T3";
                EXPECT_LE(stored(k), 128) << "T3 stored (0.5 rounds to 128)";
                ++t3;
            }
        }
    }
    std::printf("  T1 on %d roof texels, T3 on %d wall texels\n", t1, t3);
    EXPECT_GT(t1, 10);
    EXPECT_GT(t3, 1000);
}

// Inner nodes: each texel is the mean of the child texels (with a value)
// whose centres fall in it, the children located through the root atlas
// coordinates (offset and level, as a draw samples them; not the placement
// list the code uses); texels no child texel falls in hold no value. Over
// every level of the tree, at scales 1, 2 and 4.
TEST(ComputedTexture, InnerNodesAreTheirChildrensMeans) {
    const TownTree& c = town();
    const AtlasTree& tree = c.tree;
    const int a = tree.params.atlas_size_px;
    auto field = [](const TexelSurface& s) { return std::fmod(std::abs(s.point.z), 10.0) / 10.0; };
    for (int scale : {1, 2, 4}) {
        std::vector<ScalarImage> image(tree.nodes.size());
        uint64_t checked = 0;
        for (size_t id = tree.nodes.size(); id-- > 0;) {  // preorder reversed: children first
            const auto n = static_cast<int32_t>(id);
            if (tree.nodes[id].leaf()) {
                image[id] = evaluateComputed(leafTexelMap(tree, n, Layer::Opaque, scale), field, 0, kNoValue);
                continue;
            }
            image[id] = innerComputed(tree, n, Layer::Opaque, scale, [&](int32_t ch) { return &image[static_cast<size_t>(ch)]; });
            const NodeLayer& nl = tree.nodes[id].layers[0];
            if (nl.width == 0) continue;
            std::vector<double> sum(image[id].value.size(), 0);
            std::vector<int> count(image[id].value.size(), 0);
            for (int32_t ch : tree.nodes[id].children) {
                if (ch < 0) continue;
                const NodeLayer& cl = tree.nodes[static_cast<size_t>(ch)].layers[0];
                const ScalarImage& ci = image[static_cast<size_t>(ch)];
                const double child_scale = std::ldexp(static_cast<double>(a), tree.nodes[static_cast<size_t>(ch)].level);
                for (int y = 0; y < ci.height; ++y)
                    for (int x = 0; x < ci.width; ++x) {
                        const float v = ci.value[static_cast<size_t>(y) * ci.width + x];
                        if (std::isnan(v)) continue;
                        const Vec2d root{((x + 0.5) * scale + static_cast<double>(cl.offset[0])) / child_scale,
                                         ((y + 0.5) * scale + static_cast<double>(cl.offset[1])) / child_scale};
                        const Vec2d t = nl.texelFromRoot(root, tree.nodes[id].level, a);
                        const int px = static_cast<int>(std::floor(t.x / scale)), py = static_cast<int>(std::floor(t.y / scale));
                        ASSERT_TRUE(px >= 0 && px < image[id].width && py >= 0 && py < image[id].height);
                        sum[static_cast<size_t>(py) * image[id].width + px] += v;
                        ++count[static_cast<size_t>(py) * image[id].width + px];
                    }
            }
            for (size_t k = 0; k < sum.size(); ++k) {
                const float got = image[id].value[k];
                if (count[k] == 0) {
                    ASSERT_TRUE(std::isnan(got)) << "node " << id << " texel " << k << " has a value no child gives";
                } else {
                    ASSERT_NEAR(got, sum[k] / count[k], 1e-6) << "node " << id << " texel " << k;
                    ++checked;
                }
            }
        }
        std::printf("  scale %d: %llu inner texels checked\n", scale, static_cast<unsigned long long>(checked));
        EXPECT_GT(checked, 1000u);
    }
}

}  // namespace
}  // namespace cityatlas::atlas
