// SPDX-License-Identifier: GPL-3.0-or-later
// The BlockMap shader (render/gl/blockmap_pass.h) against its C++ twin
// (render/core/blockmap_ray.h), which test_blockmap_ray holds to brute
// force: on a synthetic LOD2 town's BlockMap seen from several cameras, every
// pixel's centre ray cast on the CPU gives the same hit or miss, the same
// cell and face (the pass's cell-id hook), the same depth and, from colour
// planes where every cell's roof and every column has a colour of its own,
// the same colour (../shared/SEED-FEATURES.md §1.3 item 7). Pixels whose
// ray passes within a hundredth of a pixel of a prism edge may differ (the
// shader walks in float); they are counted and bounded.
#include <gtest/gtest.h>

#include <epoxy/gl.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "atlas/blockmap.h"
#include "ingest/synth/town.h"
#include "render/core/blockmap_ray.h"
#include "render/core/picking.h"
#include "render/gl/blockmap_pass.h"
#include "render/gl/gl_context.h"
#include "render/gl/gl_renderer.h"
#include "tests/render/gl/headless_gl_test.h"

namespace cityatlas::render {
namespace {

struct Expected {
    bool hit = false;
    uint32_t id = OffscreenTarget::kNoFeature;
    double depth = 1;
};

Expected expectAt(const format::BlockMap& bm, const Camera& camera, double px, double py) {
    const Vec3d dir = pixelRay(camera, px, py);
    const BlockMapHit h = castBlockMapRay(bm, camera.position, dir);
    Expected e;
    if (!h.hit) return e;
    e.hit = true;
    e.id = static_cast<uint32_t>(bm.index(h.x, h.y)) * 8u + static_cast<uint32_t>(h.face);
    // Window depth of the hit with the camera's projection, in double.
    const Vec3d forward = (1.0 / length(camera.direction)) * camera.direction;
    const double z_eye = h.t * dot(dir, forward);  // distance along the view axis
    const double n = camera.near_m, f = camera.far_m;
    const double ndc = ((f + n) / (f - n)) - (2 * f * n / (f - n)) / z_eye;
    e.depth = 0.5 * ndc + 0.5;
    return e;
}

// sRGB bytes per cell (roof) and per column (every row the same), all different.
std::array<uint8_t, 3> colourOf(uint32_t k, uint32_t salt) {
    const uint32_t h = (k + 1) * 2654435761u ^ salt;
    return {static_cast<uint8_t>(40 + (h & 0xAF)), static_cast<uint8_t>(40 + ((h >> 8) & 0xAF)), static_cast<uint8_t>(40 + ((h >> 16) & 0xAF))};
}

using BlockMapGl = HeadlessGlTest;

// A 60-building synthetic LOD2 town's BlockMap at 2.5 m cells, every roof
// cell and every column in a colour of its own, uploaded; a 128 x 128
// target with an id buffer; cameras around the town that it fills.
struct TownBlockMap {
    static constexpr int kSize = 128;
    format::BlockMap bm;
    std::unique_ptr<BlockMapPass> pass;
    GpuBlockMap gpu;
    std::unique_ptr<OffscreenTarget> target;

    void make() {
        synth::TownSettings s;
        s.buildings = 60;
        s.seed = 4;
        s.texture_size_px = 16;
        const Scene scene = synth::townToScene(synth::generateTown(s), "/nonexistent");
        atlas::BlockMapParams params;
        params.cell_m = 2.5;
        ASSERT_TRUE(atlas::buildBlockMap(scene.triangles, params, &bm).ok());
        std::vector<uint8_t> roof(bm.cells.size() * 3), walls(static_cast<size_t>(bm.wall_width) * bm.wall_height * 3, 0);
        for (size_t c = 0; c < bm.cells.size(); ++c) {
            const auto rgb = colourOf(static_cast<uint32_t>(c), 0x5A5A);
            std::copy(rgb.begin(), rgb.end(), roof.begin() + static_cast<long>(c * 3));
        }
        for (size_t i = 0; i < bm.columns.size(); ++i) {
            const format::BlockMapColumn& col = bm.columns[i];
            const auto rgb = colourOf(static_cast<uint32_t>(i), 0xC3C3);
            for (int r = 0; r < col.rows; ++r)
                std::copy(rgb.begin(), rgb.end(),
                          walls.begin() + static_cast<long>(((col.y + r) * static_cast<size_t>(bm.wall_width) + col.x) * 3));
        }
        Status status;
        pass = BlockMapPass::create(&status);
        ASSERT_NE(pass, nullptr) << status.error;
        gpu = pass->upload(bm, roof, walls, &status);
        ASSERT_TRUE(gpu.valid()) << status.error;
        target = OffscreenTarget::create(kSize, kSize, &status, true);
        ASSERT_NE(target, nullptr) << status.error;
    }
    ~TownBlockMap() {
        if (pass) pass->release(&gpu);
    }
    Vec3d centre() const {
        return {bm.origin.x + 0.5 * bm.nx * bm.cell_m, bm.origin.y + 0.5 * bm.ny * bm.cell_m, 0.5 * (bm.origin.z + bm.z_hi)};
    }
    double reach() const { return std::hypot(bm.nx * bm.cell_m, bm.ny * bm.cell_m); }
    // Looking at the centre from azimuth and elevation (degrees).
    Camera camera(double azimuth_deg, double elevation_deg) const {
        const double az = azimuth_deg * M_PI / 180, el = elevation_deg * M_PI / 180;
        Camera cam;
        cam.position = centre() + 0.55 * reach() * Vec3d{std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
        cam.direction = (1.0 / length(centre() - cam.position)) * (centre() - cam.position);
        cam.width_px = cam.height_px = kSize;
        cam.vertical_fov_deg = 60;
        cam.near_m = 1;
        cam.far_m = 4 * reach();
        return cam;
    }
    void clear() {
        target->bind();
        glClearColor(0, 0, 0, 0);
        glClearDepth(1);
        glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
        const GLuint none = OffscreenTarget::kNoFeature;
        glClearBufferuiv(GL_COLOR, 1, &none);
    }
    // The id buffer of the BlockMap drawn alone, with a fade (GlRenderer::setFade's mode and progress).
    std::vector<uint32_t> ids(const Camera& cam, int fade, float fade_t) {
        clear();
        pass->draw(gpu, cam, nullptr, fade, fade_t);
        std::vector<uint32_t> out;
        EXPECT_TRUE(target->readIds(&out));
        return out;
    }
};

TEST_F(BlockMapGl, ShaderEqualsTheCppTraversalOnEveryPixel) {
    TownBlockMap town;
    ASSERT_NO_FATAL_FAILURE(town.make());
    const format::BlockMap& bm = town.bm;
    BlockMapPass* pass = town.pass.get();
    GpuBlockMap& gpu = town.gpu;
    OffscreenTarget* target = town.target.get();
    const int size = TownBlockMap::kSize;
    size_t pixels = 0, hits = 0, boundary = 0, wrong = 0, colour_checked = 0, colour_wrong = 0;
    double worst_depth = 0;
    // Oblique views from four sides and a steep one; the town fills most of the frame.
    const double views[5][2] = {{20, 35}, {110, 25}, {200, 50}, {290, 15}, {45, 80}};
    for (const auto& v : views) {
        const Camera cam = town.camera(v[0], v[1]);
        town.clear();
        pass->setCellIds(true);
        pass->draw(gpu, cam);
        std::vector<uint32_t> ids;
        std::vector<float> depth;
        ASSERT_TRUE(target->readIds(&ids));
        target->readDepth(&depth);
        // Colours in a second frame with feature ids (the normal mode).
        glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
        pass->setCellIds(false);
        pass->draw(gpu, cam);
        std::vector<uint8_t> rgba;
        target->readPixels(&rgba);
        for (int py = 0; py < size; ++py)
            for (int px = 0; px < size; ++px, ++pixels) {
                const size_t i = static_cast<size_t>(py) * size + static_cast<size_t>(px);
                const Expected e = expectAt(bm, cam, px + 0.5, py + 0.5);
                hits += e.hit;
                if (ids[i] != e.id) {
                    // Near an edge the float walk may take the neighbour: a ray a hundredth of a pixel away agrees.
                    bool near = false;
                    for (const auto& j : {std::pair{0.01, 0.0}, {-0.01, 0.0}, {0.0, 0.01}, {0.0, -0.01}})
                        near |= expectAt(bm, cam, px + 0.5 + j.first, py + 0.5 + j.second).id == ids[i];
                    if (!near && wrong < 5)
                        ADD_FAILURE() << "view " << v[0] << "/" << v[1] << " pixel " << px << "," << py << ": shader id " << ids[i]
                                      << ", C++ " << e.id;
                    (near ? boundary : wrong)++;
                    continue;
                }
                if (!e.hit) continue;
                worst_depth = std::max(worst_depth, std::abs(depth[i] - e.depth));
                // The colour of the face hit: the cell's roof, or its side's column.
                const uint32_t cell = e.id / 8, face = e.id % 8;
                std::array<uint8_t, 3> want{25, 25, 25};
                if (face == kBlockMapRoof) want = colourOf(cell, 0x5A5A);
                else if (face < 4) {
                    const uint32_t col = bm.columnOf(static_cast<int>(cell % static_cast<uint32_t>(bm.nx)),
                                                     static_cast<int>(cell / static_cast<uint32_t>(bm.nx)), static_cast<int>(face));
                    ASSERT_NE(col, format::kBlockMapNone);
                    want = colourOf(col, 0xC3C3);
                } else continue;
                ++colour_checked;
                bool same = true;
                for (int k = 0; k < 3; ++k) same &= std::abs(rgba[i * 4 + static_cast<size_t>(k)] - want[static_cast<size_t>(k)]) <= 1;
                colour_wrong += !same;
            }
    }
    EXPECT_EQ(wrong, 0u) << "of " << pixels << " pixels";
    EXPECT_LE(boundary, pixels / 100) << "pixels on a prism edge";
    EXPECT_GT(hits, pixels / 8) << "the town fills a good part of the frames";
    EXPECT_LE(worst_depth, 2e-6) << "window depth against the double-precision hit";
    EXPECT_EQ(colour_wrong, 0u) << "of " << colour_checked;
    RecordProperty("boundary_pixels", static_cast<int>(boundary));
    std::printf("pixels %zu, hits %zu, on edges %zu, worst depth %.2g, colours checked %zu\n", pixels, hits, boundary, worst_depth,
                colour_checked);
}

// The cross-fade (render/gl/screen_door.h): fading in at progress t keeps
// exactly the pixels whose 4 x 4 ordered-dither threshold (k + 0.5) / 16 is
// below t, fading out exactly the others, so the two cover the BlockMap's
// pixels once between them; t = 1 fading in is the whole BlockMap, t = 0
// fading out too. The thresholds are written out here, not taken from the
// shader.
TEST_F(BlockMapGl, CrossFadeKeepsTheScreenDoorsPixels) {
    TownBlockMap town;
    ASSERT_NO_FATAL_FAILURE(town.make());
    const int n = TownBlockMap::kSize;
    const int bayer[4][4] = {{0, 8, 2, 10}, {12, 4, 14, 6}, {3, 11, 1, 9}, {15, 7, 13, 5}};  // [y & 3][x & 3], GL rows
    const uint32_t none = OffscreenTarget::kNoFeature;
    const Camera cam = town.camera(20, 35);
    const std::vector<uint32_t> whole = town.ids(cam, 0, 0);
    ASSERT_EQ(town.ids(cam, 1, 1.0F), whole) << "fully faded in";
    ASSERT_EQ(town.ids(cam, 2, 0.0F), whole) << "just starting to fade out";
    size_t drawn = 0;
    for (const float t : {0.3F, 0.5F, 0.8F}) {
        const std::vector<uint32_t> in = town.ids(cam, 1, t), out = town.ids(cam, 2, t);
        size_t kept_in = 0, wrong = 0;
        drawn = 0;
        for (int py = 0; py < n; ++py)
            for (int px = 0; px < n; ++px) {
                const size_t i = static_cast<size_t>(py) * n + static_cast<size_t>(px);
                const int gl_y = n - 1 - py;  // readIds' rows are top-down
                const bool in_part = (bayer[gl_y & 3][px & 3] + 0.5) / 16.0 < t;
                drawn += whole[i] != none;
                kept_in += in[i] != none;
                wrong += in[i] != (in_part ? whole[i] : none);
                wrong += out[i] != (in_part ? none : whole[i]);
            }
        EXPECT_EQ(wrong, 0u) << "t = " << t;
        EXPECT_NEAR(static_cast<double>(kept_in) / static_cast<double>(drawn), t, 0.05) << "t = " << t;
    }
    EXPECT_GT(drawn, static_cast<size_t>(n * n / 8));
}

TEST_F(BlockMapGl, RefusesPlanesOfTheWrongSize) {
    Status status;
    auto pass = BlockMapPass::create(&status);
    ASSERT_NE(pass, nullptr) << status.error;
    format::BlockMap bm;
    bm.nx = 2, bm.ny = 2, bm.cell_m = 1, bm.z_hi = 1;
    bm.cells.resize(4);
    bm.dist.resize(3);
    EXPECT_FALSE(pass->upload(bm, {}, {}, &status).valid());
    EXPECT_FALSE(status.ok());
    bm.dist.resize(4);
    status = Status::Ok();
    const std::vector<uint8_t> roof(5);
    EXPECT_FALSE(pass->upload(bm, roof, {}, &status).valid());
    status = Status::Ok();
    GpuBlockMap g = pass->upload(bm, {}, {}, &status);
    EXPECT_TRUE(g.valid()) << status.error;
    pass->release(&g);
}

}  // namespace
}  // namespace cityatlas::render
