// SPDX-License-Identifier: GPL-3.0-or-later
// Tests of render/gl on Mesa llvmpipe through EGL surfaceless (no display, no
// GPU). Pictures are read back from an OffscreenTarget and compared with
// independent ground truth: tiles::decodeBc (squish) for texels, the sRGB
// transfer function for linear colours and blends, and the same scene drawn
// near the origin for camera-relative precision.
//
// Tolerances, in 8-bit sRGB codes per channel:
// * 1 for a texel seen at 1:1 (texel centres on pixel centres): Mesa's S3TC
//   decoder and squish may round the 1/3-2/3 interpolants differently by one,
//   and the sRGB -> linear -> sRGB round trip with bilinear weights of
//   (1 - e, e) can move a value by one.
// * 2 for blends: the framebuffer stores sRGB bytes, so a blend reads the
//   destination back through 8-bit quantization, plus the texel's own 1.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <epoxy/gl.h>

#include "render/gl/gl_context.h"
#include "render/core/picking.h"
#include "render/gl/gl_renderer.h"
#include "render/loader/block_decoder.h"
#include "tiles/texture_codec.h"
#include "tiles/texture_tiles.h"
#include "tests/render/gl/headless_gl_test.h"

namespace cityatlas::render {
namespace {

// ---------------------------------------------------------------- colour maths (independent of GL)

double srgbToLinear(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }
double linearToSrgb(double l) { return l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1.0 / 2.4) - 0.055; }
double byteToLinear(uint8_t b) { return srgbToLinear(b / 255.0); }
int linearToByte(double l) { return static_cast<int>(std::lround(std::clamp(linearToSrgb(l), 0.0, 1.0) * 255.0)); }

struct Rgba {
    int r = 0, g = 0, b = 0, a = 0;
};

Rgba pixelAt(const std::vector<uint8_t>& rgba, int width, int x, int y) {
    const size_t i = (static_cast<size_t>(y) * width + x) * 4;
    return {rgba[i], rgba[i + 1], rgba[i + 2], rgba[i + 3]};
}

int maxRgbDiff(const Rgba& a, const Rgba& b) {
    return std::max({std::abs(a.r - b.r), std::abs(a.g - b.g), std::abs(a.b - b.b)});
}

std::string str(const Rgba& c) {
    char text[64];
    std::snprintf(text, sizeof text, "(%d, %d, %d, %d)", c.r, c.g, c.b, c.a);
    return text;
}

// ---------------------------------------------------------------- fixtures

// A structured test picture: gradients, a checkerboard and (RGBA) an alpha ramp,
// so a flip, a shift or a wrong channel shows.
tiles::Image8 pattern(int w, int h, int channels) {
    tiles::Image8 img{w, h, channels, std::vector<uint8_t>(static_cast<size_t>(w) * h * channels)};
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            uint8_t* p = img.pixels.data() + (static_cast<size_t>(y) * w + x) * channels;
            p[0] = static_cast<uint8_t>(x * 255 / std::max(1, w - 1));
            p[1] = static_cast<uint8_t>(y * 255 / std::max(1, h - 1));
            p[2] = ((x / 8 + y / 8) % 2) != 0 ? 220 : 30;
            if (channels == 4) p[3] = static_cast<uint8_t>(40 + (x + 2 * y) * 180 / (3 * std::max(1, w - 1)));
        }
    }
    return img;
}

tiles::Image8 solid(int w, int h, int channels, std::array<uint8_t, 4> c) {
    tiles::Image8 img{w, h, channels, {}};
    for (int i = 0; i < w * h; ++i) img.pixels.insert(img.pixels.end(), c.begin(), c.begin() + channels);
    return img;
}

// What the loader hands over: the DDS without its 128-byte header.
CompressedTexture compress(const tiles::Image8& image, bool mips) {
    const std::vector<tiles::Image8> chain = mips ? tiles::mipChain(image) : std::vector<tiles::Image8>{image};
    const std::vector<uint8_t> dds = tiles::encodeDds(chain, tiles::BcQuality::Fast);
    CompressedTexture t;
    const Status st = decodeDds(dds.data(), dds.size(), 0, &t);
    EXPECT_TRUE(st.ok()) << st.error;
    return t;
}

// Level 0 decoded by squish: what the GPU must show at 1:1.
tiles::Image8 decodeLevel0(const CompressedTexture& t) {
    const auto first = t.data.begin() + static_cast<std::ptrdiff_t>(t.levels[0].offset);
    return tiles::decodeBc(std::vector<uint8_t>(first, first + static_cast<std::ptrdiff_t>(t.levels[0].bytes)),
                           t.width, t.height, t.channels);
}

Rgba texel(const tiles::Image8& img, int x, int y) {
    const uint8_t* p = img.pixels.data() + (static_cast<size_t>(y) * img.width + x) * img.channels;
    return {p[0], p[1], p[2], img.channels == 4 ? p[3] : 255};
}

// llvmpipe's anisotropic filter is an elliptical weighted average that blurs
// even at 1:1 (measured: 2995 of 4096 pixels of the BC1 pattern off by up to
// 105 codes at 16x, none at 1x), so the exactness tests turn it off; the
// filtering test below checks it is on by default.
RendererOptions exactFiltering() {
    RendererOptions o;
    o.max_anisotropy = 1;
    return o;
}

struct QuadUv {
    float u0 = 0, v0 = 0, u1 = 1, v1 = 1;
};

// A quad in the node's x-z plane (y = 0), facing -y: x0..x1 left to right,
// z0..z1 bottom to top as a camera looking along +y with z up sees it; v = 0
// at the bottom (the project convention).
void addQuad(MeshData* m, float x0, float x1, float z0, float z1, QuadUv atlas, QuadUv original, int32_t material,
             float y = 0) {
    const auto base = static_cast<uint32_t>(m->positions.size() / 3);
    const float xs[4] = {x0, x1, x1, x0}, zs[4] = {z0, z0, z1, z1};
    const float ua[4] = {atlas.u0, atlas.u1, atlas.u1, atlas.u0}, va[4] = {atlas.v0, atlas.v0, atlas.v1, atlas.v1};
    const float uo[4] = {original.u0, original.u1, original.u1, original.u0};
    const float vo[4] = {original.v0, original.v0, original.v1, original.v1};
    for (int i = 0; i < 4; ++i) {
        m->positions.insert(m->positions.end(), {xs[i], y, zs[i]});
        m->uv_atlas.insert(m->uv_atlas.end(), {ua[i], va[i]});
        m->uv_original.insert(m->uv_original.end(), {uo[i], vo[i]});
        m->material_id.push_back(material);
        m->texture_id.push_back(-1);
        m->feature_id.push_back(0);
    }
    m->indices.insert(m->indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
}

// Looking along +y from `position`, z up: with fov 90 and a square viewport a
// quad 1 m ahead spanning [-1, 1]^2 covers the viewport exactly, texel centres
// on pixel centres when the texture has the viewport's size.
Camera frontCamera(int size_px, const Vec3d& position = {0, 0, 0}, double fov_deg = 90) {
    Camera c;
    c.position = position;
    c.direction = {0, 1, 0};
    c.up = {0, 0, 1};
    c.vertical_fov_deg = fov_deg;
    c.width_px = c.height_px = size_px;
    c.near_m = 0.1;
    c.far_m = 100;
    return c;
}

class GlTest : public HeadlessGlTest {
protected:
    std::unique_ptr<GlRenderer> renderer(const std::vector<MaterialInfo>& materials = {},
                                         RendererOptions options = {}) {
        Status status;
        auto r = GlRenderer::create(materials, options, &status);
        EXPECT_TRUE(status.ok()) << status.error;
        return r;
    }
    std::unique_ptr<OffscreenTarget> target(int w, int h, bool with_ids = false) {
        Status status;
        auto t = OffscreenTarget::create(w, h, &status, with_ids);
        EXPECT_TRUE(status.ok()) << status.error;
        if (t) t->bind();
        return t;
    }
};

// Renders `texture` on the viewport-filling quad (one layer) and reads back.
std::vector<uint8_t> renderFullQuad(GlRenderer& r, OffscreenTarget& target, const GpuTexture& texture, int layer,
                                    std::array<float, 4> clear, FrameStats* stats = nullptr) {
    MeshData m;
    addQuad(&m, -1, 1, -1, 1, {}, {}, -1);
    Status status;
    GpuMesh mesh = r.upload(m, &status);
    EXPECT_TRUE(status.ok()) << status.error;
    target.bind();
    r.beginFrame(frontCamera(target.width()), clear);
    r.drawAtlas(mesh, &texture, Vec3d{0, 1, 0}, layer);
    const FrameStats s = r.endFrame();
    if (stats != nullptr) *stats = s;
    std::vector<uint8_t> pixels;
    target.readPixels(&pixels);
    r.release(&mesh);
    return pixels;
}

// ---------------------------------------------------------------- context

TEST_F(GlTest, HeadlessContextIsCore33WithS3tcAndNeedsNoDisplay) {
    EXPECT_EQ(std::getenv("DISPLAY"), nullptr);
    const GlInfo info = queryGlInfo();
    EXPECT_GE(info.major * 10 + info.minor, 33) << info.version;
    EXPECT_TRUE(info.core_profile) << info.version;
    EXPECT_TRUE(info.s3tc);
    EXPECT_TRUE(info.srgb_s3tc);
    EXPECT_FALSE(info.renderer.empty());
    EXPECT_GE(info.max_anisotropy, 1.0F);
    EXPECT_TRUE(context_->platform() == "surfaceless" || context_->platform() == "device") << context_->platform();
    std::printf("GL: %s | %s | %s | EGL %s | aniso %.0f\n", info.vendor.c_str(), info.renderer.c_str(),
                info.version.c_str(), context_->platform().c_str(), static_cast<double>(info.max_anisotropy));
}

TEST_F(GlTest, WindowWithoutDisplayFailsWithOneClearLine) {
    Status status;
    auto window = Window::create(64, 64, "test", &status);
    EXPECT_EQ(window, nullptr);
    EXPECT_NE(status.error.find("no display"), std::string::npos) << status.error;
    EXPECT_NE(status.error.find("xvfb-run"), std::string::npos) << status.error;
}

TEST_F(GlTest, OffscreenTargetRefusesBadSizes) {
    Status status;
    EXPECT_EQ(OffscreenTarget::create(0, 16, &status), nullptr);
    EXPECT_FALSE(status.ok());
    EXPECT_EQ(OffscreenTarget::create(16, 1 << 30, &status), nullptr);
    EXPECT_FALSE(status.ok());
}

// ---------------------------------------------------------------- textures

TEST_F(GlTest, Bc1TextureAtOneToOneShowsItsDecodedTexelsUpright) {
    constexpr int kSize = 64;
    auto r = renderer({}, exactFiltering());
    auto t = target(kSize, kSize);
    const CompressedTexture tex = compress(pattern(kSize, kSize, 3), /*mips=*/true);
    ASSERT_EQ(tex.levels.size(), 7U);
    Status status;
    GpuTexture gpu = r->upload(tex, /*wrap=*/false, &status);
    ASSERT_TRUE(status.ok()) << status.error;
    ASSERT_TRUE(gpu.valid());
    EXPECT_FALSE(gpu.decoded_on_cpu);
    EXPECT_FALSE(r->decodesOnCpu());
    uint64_t bc_bytes = 0;
    for (const auto& level : tex.levels) bc_bytes += level.bytes;
    EXPECT_EQ(gpu.gpu_bytes, bc_bytes);  // stays compressed: 2736 bytes, not 64*64*4

    FrameStats stats;
    const std::vector<uint8_t> pixels = renderFullQuad(*r, *t, gpu, 0, {0, 0, 0, 1}, &stats);
    const tiles::Image8 expected = decodeLevel0(tex);
    int worst = 0, worst_flipped = 0;
    for (int y = 0; y < kSize; ++y) {
        for (int x = 0; x < kSize; ++x) {
            const Rgba got = pixelAt(pixels, kSize, x, y);
            worst = std::max(worst, maxRgbDiff(got, texel(expected, x, y)));
            worst_flipped = std::max(worst_flipped, maxRgbDiff(got, texel(expected, x, kSize - 1 - y)));
            EXPECT_EQ(got.a, 255);
        }
    }
    EXPECT_LE(worst, 1);
    std::printf("BC1 1:1: largest difference %d codes (flipped: %d)\n", worst, worst_flipped);
    EXPECT_GT(worst_flipped, 100);  // the comparison sees orientation
    EXPECT_EQ(stats.draw_calls, 1U);
    EXPECT_EQ(stats.texture_binds, 1U);
    EXPECT_EQ(stats.triangles, 2U);
    EXPECT_EQ(stats.nodes, 1U);
    r->release(&gpu);
    EXPECT_FALSE(gpu.valid());
}

TEST_F(GlTest, Bc3TextureInTheAlphaLayerBlendsOverTheClearColourInLinearLight) {
    constexpr int kSize = 32;
    auto r = renderer({}, exactFiltering());
    auto t = target(kSize, kSize);
    const CompressedTexture tex = compress(pattern(kSize, kSize, 4), /*mips=*/false);
    Status status;
    GpuTexture gpu = r->upload(tex, false, &status);
    ASSERT_TRUE(status.ok()) << status.error;
    EXPECT_EQ(gpu.gpu_bytes, static_cast<uint64_t>(kSize * kSize));  // BC3: one byte per texel
    const std::array<float, 4> clear{0.2F, 0.4F, 0.05F, 1};
    const std::vector<uint8_t> pixels = renderFullQuad(*r, *t, gpu, 1, clear);
    const tiles::Image8 src = decodeLevel0(tex);
    int worst = 0, alpha_min = 255, alpha_max = 0;
    for (int y = 0; y < kSize; ++y) {
        for (int x = 0; x < kSize; ++x) {
            const Rgba s = texel(src, x, y);
            const double a = s.a / 255.0;
            alpha_min = std::min(alpha_min, s.a);
            alpha_max = std::max(alpha_max, s.a);
            const Rgba want{linearToByte(a * byteToLinear(static_cast<uint8_t>(s.r)) + (1 - a) * clear[0]),
                            linearToByte(a * byteToLinear(static_cast<uint8_t>(s.g)) + (1 - a) * clear[1]),
                            linearToByte(a * byteToLinear(static_cast<uint8_t>(s.b)) + (1 - a) * clear[2]), 255};
            const Rgba got = pixelAt(pixels, kSize, x, y);
            worst = std::max(worst, maxRgbDiff(got, want));
            // Alpha is coverage, "over": a + (1 - a) * 1.
            EXPECT_EQ(got.a, 255);
        }
    }
    EXPECT_LT(alpha_min, 80);   // the blend is really exercised
    EXPECT_GT(alpha_max, 180);
    EXPECT_LE(worst, 2);
    std::printf("BC3 blend: largest difference %d codes, alpha %d..%d\n", worst, alpha_min, alpha_max);
    r->release(&gpu);
}

TEST_F(GlTest, TexturesGetTrilinearAnisotropicFilteringAndTheirWrapMode) {
    auto r = renderer();
    const GlInfo info = queryGlInfo();
    const CompressedTexture tex = compress(pattern(16, 16, 3), true);
    for (bool wrap : {true, false}) {
        GpuTexture g = r->upload(tex, wrap);
        ASSERT_TRUE(g.valid());
        EXPECT_EQ(g.levels, 5);
        glBindTexture(GL_TEXTURE_2D, g.id);
        GLint min_filter = 0, mag_filter = 0, max_level = 0, wrap_s = 0, wrap_t = 0, compressed = 0, format = 0;
        glGetTexParameteriv(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, &min_filter);
        glGetTexParameteriv(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, &mag_filter);
        glGetTexParameteriv(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, &max_level);
        glGetTexParameteriv(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, &wrap_s);
        glGetTexParameteriv(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, &wrap_t);
        glGetTexLevelParameteriv(GL_TEXTURE_2D, 4, GL_TEXTURE_COMPRESSED, &compressed);
        glGetTexLevelParameteriv(GL_TEXTURE_2D, 0, GL_TEXTURE_INTERNAL_FORMAT, &format);
        EXPECT_EQ(min_filter, GL_LINEAR_MIPMAP_LINEAR);
        EXPECT_EQ(mag_filter, GL_LINEAR);
        EXPECT_EQ(max_level, 4);
        EXPECT_EQ(wrap_s, wrap ? GL_REPEAT : GL_CLAMP_TO_EDGE);
        EXPECT_EQ(wrap_t, wrap ? GL_REPEAT : GL_CLAMP_TO_EDGE);
        EXPECT_EQ(compressed, GL_TRUE);  // every level went up as blocks
        EXPECT_EQ(format, GL_COMPRESSED_SRGB_S3TC_DXT1_EXT);
        if (info.anisotropic) {
            GLfloat aniso = 0;
            glGetTexParameterfv(GL_TEXTURE_2D, GL_TEXTURE_MAX_ANISOTROPY, &aniso);
            EXPECT_EQ(aniso, std::min(16.0F, info.max_anisotropy));
        }
        glBindTexture(GL_TEXTURE_2D, 0);
        r->release(&g);
    }
}

TEST_F(GlTest, CpuDecodeFallbackShowsTheSamePixelsAsS3tcUpload) {
    constexpr int kSize = 64;
    auto gpu_renderer = renderer();
    RendererOptions cpu_options;
    cpu_options.force_cpu_decode = true;
    auto cpu_renderer = renderer({}, cpu_options);
    ASSERT_TRUE(cpu_renderer->decodesOnCpu());
    auto t = target(kSize, kSize);
    for (int channels : {3, 4}) {
        const CompressedTexture tex = compress(pattern(kSize, kSize, channels), true);
        GpuTexture on_gpu = gpu_renderer->upload(tex, true);
        GpuTexture on_cpu = cpu_renderer->upload(tex, true);
        ASSERT_TRUE(on_gpu.valid() && on_cpu.valid());
        EXPECT_TRUE(on_cpu.decoded_on_cpu);
        uint64_t texels = 0;
        for (const auto& level : tex.levels) texels += static_cast<uint64_t>(level.width) * level.height;
        EXPECT_EQ(on_cpu.gpu_bytes, 4 * texels);
        const int layer = channels == 4 ? 1 : 0;
        const auto a = renderFullQuad(*gpu_renderer, *t, on_gpu, layer, {0.3F, 0.1F, 0.6F, 1});
        const auto b = renderFullQuad(*cpu_renderer, *t, on_cpu, layer, {0.3F, 0.1F, 0.6F, 1});
        int worst = 0;
        for (int y = 0; y < kSize; ++y)
            for (int x = 0; x < kSize; ++x)
                worst = std::max(worst, maxRgbDiff(pixelAt(a, kSize, x, y), pixelAt(b, kSize, x, y)));
        EXPECT_LE(worst, 2) << channels << " channels";
        std::printf("CPU decode vs S3TC, %d channels: largest difference %d codes\n", channels, worst);
        gpu_renderer->release(&on_gpu);
        cpu_renderer->release(&on_cpu);
    }
}

TEST_F(GlTest, UploadsRefuseMalformedDataWithOneLine) {
    auto r = renderer();
    CompressedTexture tex = compress(pattern(16, 16, 3), true);
    CompressedTexture short_level = tex;
    short_level.levels[1].bytes -= 8;
    Status status;
    EXPECT_FALSE(r->upload(short_level, false, &status).valid());
    EXPECT_NE(status.error.find("level 1"), std::string::npos) << status.error;
    CompressedTexture outside = tex;
    outside.data.resize(outside.data.size() - 1);
    EXPECT_FALSE(r->upload(outside, false, &status).valid());
    EXPECT_FALSE(status.ok());
    CompressedTexture bad_channels = tex;
    bad_channels.channels = 2;
    EXPECT_FALSE(r->upload(bad_channels, false, &status).valid());
    EXPECT_FALSE(status.ok());

    MeshData m;
    addQuad(&m, -1, 1, -1, 1, {}, {}, -1);
    MeshData bad_index = m;
    bad_index.indices[4] = 99;
    EXPECT_FALSE(r->upload(bad_index, &status).valid());
    EXPECT_NE(status.error.find("index 4 is 99"), std::string::npos) << status.error;
    MeshData bad_range = m;
    bad_range.texture_ranges = {{3, 3, 6, {}}};
    EXPECT_FALSE(r->upload(bad_range, &status).valid());
    EXPECT_FALSE(status.ok());
    MeshData bad_uv = m;
    bad_uv.uv_atlas.pop_back();
    EXPECT_FALSE(r->upload(bad_uv, &status).valid());
    EXPECT_FALSE(status.ok());

    MeshData bad_ids = m;
    bad_ids.feature_id.push_back(0);
    EXPECT_FALSE(r->upload(bad_ids, &status).valid());
    EXPECT_NE(status.error.find("5 feature ids for 4 vertices"), std::string::npos) << status.error;

    ASSERT_EQ(m.feature_id.size(), 4U);
    GpuMesh ok = r->upload(m, &status);
    EXPECT_TRUE(status.ok() && ok.valid());
    // 4 vertices x (xyz + 2 uv sets + material id + feature id) + 6 16-bit indices.
    EXPECT_EQ(ok.gpu_bytes, 4U * (12 + 8 + 8 + 4 + 4) + 6U * 2);
    r->release(&ok);
}

// ---------------------------------------------------------------- leaves: original textures

TEST_F(GlTest, DrawOriginalsBindsEachTextureOnceAndFallsBackToTheAtlas) {
    constexpr int kSize = 32;
    auto r = renderer();
    auto t = target(kSize, kSize);
    const std::array<uint8_t, 4> red{220, 30, 40, 255}, blue{30, 60, 230, 255}, green{40, 200, 60, 255};
    const CompressedTexture tex5 = compress(solid(8, 8, 3, red), true);
    const CompressedTexture tex7 = compress(solid(8, 8, 3, blue), true);
    const CompressedTexture atlas = compress(solid(8, 8, 3, green), true);
    GpuTexture g5 = r->upload(tex5, true), g7 = r->upload(tex7, true), ga = r->upload(atlas, false);
    const Rgba want5 = texel(decodeLevel0(tex5), 0, 0), want7 = texel(decodeLevel0(tex7), 0, 0),
               want_atlas = texel(decodeLevel0(atlas), 0, 0);
    ASSERT_GT(maxRgbDiff(want5, want7), 100);

    // Left half texture 5, right half texture 7, each repeated twice (wrap);
    // atlas coordinates split the atlas between them.
    MeshData m;
    addQuad(&m, -1, 0, -1, 1, {0, 0, 0.5F, 1}, {0, 0, 2, 2}, -1);
    addQuad(&m, 0, 1, -1, 1, {0.5F, 0, 1, 1}, {0, 0, 2, 2}, -1);
    m.texture_id = {5, 5, 5, 5, 7, 7, 7, 7};
    m.texture_ranges = {{5, 0, 6, {}}, {7, 6, 6, {}}};
    Status status;
    GpuMesh mesh = r->upload(m, &status);
    ASSERT_TRUE(status.ok()) << status.error;

    auto frame = [&](const std::function<const GpuTexture*(int32_t)>& original, FrameStats* stats) {
        r->beginFrame(frontCamera(kSize), {0, 0, 0, 1});
        r->drawOriginals(mesh, original, &ga, {0, 1, 0}, 0);
        *stats = r->endFrame();
        std::vector<uint8_t> pixels;
        t->readPixels(&pixels);
        return pixels;
    };
    auto halves = [&](const std::vector<uint8_t>& px, const Rgba& left, const Rgba& right) {
        int worst = 0;
        for (int y = 0; y < kSize; ++y) {
            for (int x = 0; x < kSize; ++x)
                worst = std::max(worst, maxRgbDiff(pixelAt(px, kSize, x, y), x < kSize / 2 ? left : right));
        }
        return worst;
    };

    FrameStats stats;
    auto both = frame([&](int32_t id) -> const GpuTexture* { return id == 5 ? &g5 : id == 7 ? &g7 : nullptr; },
                      &stats);
    EXPECT_LE(halves(both, want5, want7), 1);
    EXPECT_EQ(stats.draw_calls, 2U);
    EXPECT_EQ(stats.texture_binds, 2U);
    EXPECT_EQ(stats.triangles, 4U);
    EXPECT_EQ(stats.nodes, 1U);

    auto missing7 = frame([&](int32_t id) -> const GpuTexture* { return id == 5 ? &g5 : nullptr; }, &stats);
    EXPECT_LE(halves(missing7, want5, want_atlas), 1);
    EXPECT_EQ(stats.draw_calls, 2U);
    EXPECT_EQ(stats.texture_binds, 2U);

    // Both missing: both ranges use the atlas, bound once.
    auto none = frame([](int32_t) -> const GpuTexture* { return nullptr; }, &stats);
    EXPECT_LE(halves(none, want_atlas, want_atlas), 1);
    EXPECT_EQ(stats.draw_calls, 2U);
    EXPECT_EQ(stats.texture_binds, 1U);

    // Two leaves with the same texture in a row: the second bind is skipped.
    r->beginFrame(frontCamera(kSize), {0, 0, 0, 1});
    auto only5 = [&](int32_t) -> const GpuTexture* { return &g5; };
    r->drawOriginals(mesh, only5, &ga, {0, 1, 0}, 0);
    r->drawOriginals(mesh, only5, &ga, {0, 1.5, 0}, 0);
    stats = r->endFrame();
    EXPECT_EQ(stats.draw_calls, 4U);
    EXPECT_EQ(stats.texture_binds, 1U);
    EXPECT_EQ(stats.nodes, 2U);

    r->release(&mesh);
    for (GpuTexture* g : {&g5, &g7, &ga}) r->release(g);
}

// ---------------------------------------------------------------- dummy, materials

TEST_F(GlTest, DrawDummyPaintsEveryPixelOfTheMeshWithOneBindPerFrame) {
    constexpr int kSize = 32;
    auto r = renderer({MaterialInfo{{0.1F, 0.9F, 0.1F}, 0}});
    auto t = target(kSize, kSize);
    // Left: a textured quad; right: a material-coloured one. The dummy ignores both.
    MeshData m;
    addQuad(&m, -1, 0, -0.5F, 0.5F, {}, {}, -1);
    addQuad(&m, 0, 0.5F, -0.5F, 0.5F, {}, {}, 0);
    GpuMesh mesh = r->upload(m);
    const std::array<float, 4> clear{0, 0, 0, 1};
    for (int frame = 0; frame < 2; ++frame) {
        r->beginFrame(frontCamera(kSize), clear);
        r->drawDummy(mesh, {0, 1, 0}, 0);
        r->drawDummy(mesh, {0, 3, 0}, 0);  // behind, hidden
        const FrameStats stats = r->endFrame();
        EXPECT_EQ(stats.texture_binds, 1U);
        EXPECT_EQ(stats.draw_calls, 2U);
        EXPECT_EQ(stats.nodes, 2U);
    }
    std::vector<uint8_t> px;
    t->readPixels(&px);
    const Rgba dummy{GlRenderer::kDummyColour[0], GlRenderer::kDummyColour[1], GlRenderer::kDummyColour[2], 255};
    int covered = 0;
    for (int y = 0; y < kSize; ++y) {
        for (int x = 0; x < kSize; ++x) {
            // Mesh: x in [-1, 0.5] -> columns 0..23, z in [-0.5, 0.5] -> rows 8..23.
            const bool inside = x < 24 && y >= 8 && y < 24;
            const Rgba got = pixelAt(px, kSize, x, y);
            if (inside) {
                ++covered;
                EXPECT_LE(maxRgbDiff(got, dummy), 1) << x << "," << y << " " << str(got);
            } else {
                EXPECT_EQ(maxRgbDiff(got, {0, 0, 0, 255}), 0) << x << "," << y << " " << str(got);
            }
        }
    }
    EXPECT_EQ(covered, 24 * 16);
    r->release(&mesh);
}

TEST_F(GlTest, UntexturedVerticesShowTheirMaterialOrNeutralGrey) {
    constexpr int kSize = 32;
    const std::vector<MaterialInfo> materials{{{0.9F, 0.1F, 0.1F}, 0}, {{0.05F, 0.5F, 0.8F}, 0}};
    auto r = renderer(materials);
    auto t = target(kSize, kSize);
    // Material 1 on the left; no material on the right; an atlas is given but
    // material-coloured vertices must ignore it, and the right half (textured
    // vertices) shows it.
    const CompressedTexture atlas = compress(solid(8, 8, 3, {250, 250, 0, 255}), true);
    GpuTexture ga = r->upload(atlas, false);
    MeshData m;
    addQuad(&m, -1, 0, -1, 1, {}, {}, 1);
    addQuad(&m, 0, 1, -1, 1, {}, {}, -1);
    GpuMesh mesh = r->upload(m);
    const Rgba want_material{linearToByte(0.05), linearToByte(0.5), linearToByte(0.8), 255};
    const Rgba want_atlas = texel(decodeLevel0(atlas), 0, 0);
    const Rgba grey{linearToByte(GlRenderer::kNeutralGrey), linearToByte(GlRenderer::kNeutralGrey),
                    linearToByte(GlRenderer::kNeutralGrey), 255};

    for (const GpuTexture* tex : {static_cast<const GpuTexture*>(&ga), static_cast<const GpuTexture*>(nullptr)}) {
        r->beginFrame(frontCamera(kSize), {0, 0, 0, 1});
        r->drawAtlas(mesh, tex, {0, 1, 0}, 0);
        const FrameStats stats = r->endFrame();
        EXPECT_EQ(stats.texture_binds, tex != nullptr ? 1U : 0U);
        std::vector<uint8_t> px;
        t->readPixels(&px);
        for (int y = 0; y < kSize; ++y) {
            EXPECT_LE(maxRgbDiff(pixelAt(px, kSize, 5, y), want_material), 1) << str(pixelAt(px, kSize, 5, y));
            const Rgba right = pixelAt(px, kSize, 25, y);
            EXPECT_LE(maxRgbDiff(right, tex != nullptr ? want_atlas : grey), 1) << str(right);
        }
    }
    // A material id beyond the table is bad data: grey, no crash.
    MeshData bad;
    addQuad(&bad, -1, 1, -1, 1, {}, {}, 7);
    GpuMesh bad_mesh = r->upload(bad);
    r->beginFrame(frontCamera(kSize), {0, 0, 0, 1});
    r->drawAtlas(bad_mesh, nullptr, {0, 1, 0}, 0);
    r->endFrame();
    std::vector<uint8_t> px;
    t->readPixels(&px);
    EXPECT_LE(maxRgbDiff(pixelAt(px, kSize, 16, 16), grey), 1);
    r->release(&mesh);
    r->release(&bad_mesh);
    r->release(&ga);
}

// ---------------------------------------------------------------- precision

TEST_F(GlTest, QuadAtEcefMagnitudesRendersLikeTheSameQuadAtTheOrigin) {
    constexpr int kSize = 128;
    auto r = renderer();
    auto t = target(kSize, kSize);
    const CompressedTexture tex = compress(pattern(64, 64, 3), true);
    GpuTexture gpu = r->upload(tex, false);
    // A 1 m quad, textured, seen from 10 m away, obliquely and off-grid.
    MeshData m;
    addQuad(&m, -0.5F, 0.5F, -0.5F, 0.5F, {}, {}, -1);
    GpuMesh mesh = r->upload(m);
    const Vec3d eye_offset{-6.1, -7.9, 0.37};  // camera relative to the quad's centre, |.| ~ 10 m
    auto camera = [&](const Vec3d& quad_centre) {
        Camera c = frontCamera(kSize, quad_centre + eye_offset, 8);
        c.direction = normalized(-1.0 * eye_offset);
        c.near_m = 1;
        c.far_m = 50;
        return c;
    };
    auto render = [&](const GpuMesh& g, const Vec3d& node_centre, const Camera& c) {
        r->beginFrame(c, {0, 0, 0, 1});
        r->drawAtlas(g, &gpu, node_centre, 0);
        r->endFrame();
        std::vector<uint8_t> px;
        t->readPixels(&px);
        return px;
    };
    const Vec3d ecef{4.0e6, 1.0e6, 4.9e6};
    const auto at_origin = render(mesh, {0, 0, 0}, camera({0, 0, 0}));
    const auto at_ecef = render(mesh, ecef, camera(ecef));

    int covered = 0;
    for (size_t i = 0; i < at_origin.size(); i += 4) covered += at_origin[i] + at_origin[i + 1] + at_origin[i + 2] > 0;
    EXPECT_GT(covered, kSize * kSize / 4);  // the quad is big on screen
    // Only the quad's edges may differ by a pixel: (node - camera) is the same
    // double to ~1e-9 m in both cases.
    int differing = 0;
    for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x)
            differing += maxRgbDiff(pixelAt(at_origin, kSize, x, y), pixelAt(at_ecef, kSize, x, y)) > 1;
    EXPECT_LE(differing, 4 * kSize) << "of " << covered << " covered pixels";

    // The control: the same quad with absolute float32 positions (what a
    // renderer without camera-relative offsets does) is visibly wrong, so the
    // comparison above can fail.
    MeshData absolute = m;
    for (size_t i = 0; i < absolute.positions.size(); i += 3) {
        absolute.positions[i] = static_cast<float>(ecef.x + m.positions[i]);
        absolute.positions[i + 1] = static_cast<float>(ecef.y + m.positions[i + 1]);
        absolute.positions[i + 2] = static_cast<float>(ecef.z + m.positions[i + 2]);
    }
    GpuMesh absolute_mesh = r->upload(absolute);
    const auto naive = render(absolute_mesh, {0, 0, 0}, camera(ecef));
    int naive_differing = 0;
    for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x)
            naive_differing += maxRgbDiff(pixelAt(at_origin, kSize, x, y), pixelAt(naive, kSize, x, y)) > 1;
    EXPECT_GT(naive_differing, covered / 10);
    std::printf("precision: %d covered, %d differ camera-relative, %d differ with float32 world positions\n",
                covered, differing, naive_differing);
    r->release(&mesh);
    r->release(&absolute_mesh);
    r->release(&gpu);
}

// ---------------------------------------------------------------- layers

TEST_F(GlTest, AlphaLayerDrawsAfterOpaqueAndFarToNearWhateverTheCallOrder) {
    constexpr int kSize = 16;
    const std::vector<MaterialInfo> materials{
        {{0.8F, 0.05F, 0.05F}, 0},     // 0: opaque red
        {{0.05F, 0.05F, 0.9F}, 0.5F},  // 1: half-transparent blue
        {{0.05F, 0.9F, 0.05F}, 0.75F}  // 2: quarter-opaque green
    };
    auto r = renderer(materials);
    auto t = target(kSize, kSize);
    auto quadWith = [&](int32_t material) {
        MeshData m;
        addQuad(&m, -1, 1, -1, 1, {}, {}, material);
        return r->upload(m);
    };
    GpuMesh red = quadWith(0), blue = quadWith(1), green = quadWith(2);
    auto centre = [&]() {
        std::vector<uint8_t> px;
        t->readPixels(&px);
        return pixelAt(px, kSize, kSize / 2, kSize / 2);
    };
    auto over = [](const std::array<float, 3>& src, double a, const std::array<double, 3>& dst) {
        return std::array<double, 3>{a * src[0] + (1 - a) * dst[0], a * src[1] + (1 - a) * dst[1],
                                     a * src[2] + (1 - a) * dst[2]};
    };
    auto toRgba = [](const std::array<double, 3>& l) {
        return Rgba{linearToByte(l[0]), linearToByte(l[1]), linearToByte(l[2]), 255};
    };
    const std::array<double, 3> red_lin{0.8, 0.05, 0.05};

    // Blue (alpha, in front at 1 m) is called before red (opaque, behind at 2 m).
    r->beginFrame(frontCamera(kSize), {0, 0, 0, 1});
    r->drawAtlas(blue, nullptr, {0, 1, 0}, 1);
    r->drawAtlas(red, nullptr, {0, 2, 0}, 0);
    r->endFrame();
    const Rgba want_blue_over_red = toRgba(over(materials[1].diffuse, 0.5, red_lin));
    EXPECT_LE(maxRgbDiff(centre(), want_blue_over_red), 2) << str(centre()) << " vs " << str(want_blue_over_red);

    // An alpha quad behind the opaque one is hidden (depth test stays on).
    r->beginFrame(frontCamera(kSize), {0, 0, 0, 1});
    r->drawAtlas(blue, nullptr, {0, 3, 0}, 1);
    r->drawAtlas(red, nullptr, {0, 2, 0}, 0);
    r->endFrame();
    EXPECT_LE(maxRgbDiff(centre(), toRgba(red_lin)), 1) << str(centre());

    // Two alpha quads called near first: drawn far first, so the near one is on top.
    r->beginFrame(frontCamera(kSize), {0, 0, 0, 1});
    r->drawAtlas(green, nullptr, {0, 1, 0}, 1);  // near
    r->drawAtlas(blue, nullptr, {0, 1.5, 0}, 1);  // far
    r->drawAtlas(red, nullptr, {0, 2, 0}, 0);
    r->endFrame();
    const Rgba want = toRgba(over(materials[2].diffuse, 0.25, over(materials[1].diffuse, 0.5, red_lin)));
    const Rgba wrong_order = toRgba(over(materials[1].diffuse, 0.5, over(materials[2].diffuse, 0.25, red_lin)));
    ASSERT_GT(maxRgbDiff(want, wrong_order), 10);
    EXPECT_LE(maxRgbDiff(centre(), want), 2) << str(centre()) << " vs " << str(want);

    for (GpuMesh* g : {&red, &blue, &green}) r->release(g);
}

// The id buffer (OffscreenTarget with_ids): each pixel holds the feature id of
// the nearest surface drawn there, opaque or alpha, and kNoFeature elsewhere;
// a mesh without ids draws kNoFeature; the colour is what it is without ids.
TEST_F(GlTest, IdBufferHoldsTheNearestFeatureOpaqueOrAlphaAndNoneElsewhere) {
    constexpr int kSize = 16;
    const std::vector<MaterialInfo> materials{{{0.8F, 0.05F, 0.05F}, 0}, {{0.05F, 0.05F, 0.9F}, 0.5F}};
    auto r = renderer(materials);
    Status status;
    auto t = OffscreenTarget::create(kSize, kSize, &status, /*with_ids=*/true);
    ASSERT_TRUE(status.ok()) << status.error;
    ASSERT_TRUE(t->hasIds());
    auto quad = [&](float x0, float x1, int32_t material, uint32_t feature, bool with_ids = true) {
        MeshData m;
        addQuad(&m, x0, x1, -1, 1, {}, {}, material);
        if (with_ids) std::fill(m.feature_id.begin(), m.feature_id.end(), feature);
        else m.feature_id.clear();
        return r->upload(m);
    };
    // Left half: opaque feature 7 at 2 m behind alpha feature 3000000000 at 1 m.
    // Right half: nothing, then (second frame) a quad without ids.
    GpuMesh back = quad(-1, 0, 0, 7), front = quad(-1, 0, 1, 3000000000u), bare = quad(0, 1, 0, 0, false);
    t->bind();
    r->beginFrame(frontCamera(kSize), {0, 0, 0, 1});
    r->drawAtlas(front, nullptr, {0, 1, 0}, 1);
    r->drawAtlas(back, nullptr, {0, 2, 0}, 0);
    r->endFrame();
    std::vector<uint32_t> ids;
    ASSERT_TRUE(t->readIds(&ids));
    ASSERT_EQ(ids.size(), static_cast<size_t>(kSize * kSize));
    // Fov 90: the front quad (x in [-1, 0], 1 m) covers pixel columns 0-7,
    // the back one (2 m) columns 4-7 and rows 4-11, behind it.
    EXPECT_EQ(ids[4 * kSize + 2], 3000000000u);
    EXPECT_EQ(ids[4 * kSize + 13], OffscreenTarget::kNoFeature);
    EXPECT_EQ(t->idAt(6, 8), 3000000000u) << "the alpha surface in front of the opaque one";
    EXPECT_EQ(t->idAt(2, 4), 3000000000u);
    EXPECT_EQ(t->idAt(13, 4), OffscreenTarget::kNoFeature);
    EXPECT_EQ(t->idAt(-1, 4), OffscreenTarget::kNoFeature);
    // Without the alpha quad the opaque one shows; the quad without ids reads as none.
    r->beginFrame(frontCamera(kSize), {0, 0, 0, 1});
    r->drawAtlas(back, nullptr, {0, 2, 0}, 0);
    r->drawAtlas(bare, nullptr, {0, 1, 0}, 0);
    r->endFrame();
    EXPECT_EQ(t->idAt(6, 8), 7u);
    EXPECT_EQ(t->idAt(2, 4), OffscreenTarget::kNoFeature) << "cleared again";
    EXPECT_EQ(t->idAt(13, 4), OffscreenTarget::kNoFeature);
    std::vector<uint8_t> px;
    t->readPixels(&px);
    EXPECT_GT(pixelAt(px, kSize, 13, 4).r, 100) << "the quad without ids is drawn (red) all the same";
    // A target without an id buffer has nothing to read.
    auto plain = OffscreenTarget::create(kSize, kSize, &status);
    EXPECT_FALSE(plain->readIds(&ids));
    EXPECT_EQ(plain->idAt(2, 4), OffscreenTarget::kNoFeature);
    for (GpuMesh* g : {&back, &front, &bare}) r->release(g);
}

// ---------------------------------------------------------------- split originals (tiles/texture_tiles.h, H6)

// H6: a 4096^2 texture on a flat roof, seen straight down so one texel of the
// sampled mip level covers one pixel, with pixel centres on texel corners (so
// every sample blends four texels and a seam cannot hide). Drawn whole and as
// tiles (the roof cut at the core lines by clipToTiles, each tile its own
// BC1 texture with mips, sampled clamped): with enough overlap the pictures
// are equal within 1 LSB on every pixel; without it the pixels on the core
// lines are off by >= 20 LSB (papers/004 Fig. 2a). Texel colours follow the
// parity of (x / 2^level, y / 2^level), four far-apart colours, so the
// sampled level alternates texel by texel.
TEST_F(GlTest, SplitOriginalsAreSeamFreeWithOverlapAndNotWithout) {
    constexpr int kTexture = 4096, kCore = 512, kView = 96;
    auto r = renderer({}, exactFiltering());
    auto t = target(kView, kView);
    for (const int level : {0, 2}) {
        const int scale = 1 << level;
        tiles::Image8 image{kTexture, kTexture, 3, std::vector<uint8_t>(size_t{kTexture} * kTexture * 3)};
        const std::array<std::array<uint8_t, 3>, 4> colours{{{230, 40, 30}, {20, 200, 60}, {40, 50, 220}, {240, 230, 200}}};
        for (int y = 0; y < kTexture; ++y)
            for (int x = 0; x < kTexture; ++x) {
                const auto& c = colours[static_cast<size_t>((x / scale) % 2 + 2 * ((y / scale) % 2))];
                std::copy(c.begin(), c.end(), image.pixels.begin() + (static_cast<std::ptrdiff_t>(y) * kTexture + x) * 3);
            }
        // The roof: 1 m per level-0 texel, x = s, y = -t (rows down), around
        // the corner of cores 0, 1, 8 and 9 at (512, 512), uv v = 0 at the bottom.
        const double half = kView * scale / 2.0 + 4 * scale;
        std::array<tiles::ClipVertex, 4> corners;
        const std::array<std::array<double, 2>, 4> st{{{kCore - half, kCore + half}, {kCore + half, kCore + half},
                                                      {kCore + half, kCore - half}, {kCore - half, kCore - half}}};
        for (size_t i = 0; i < 4; ++i)
            corners[i] = {{st[i][0], -st[i][1], 0}, {st[i][0] / kTexture, 1 - st[i][1] / kTexture}, {}};
        // Straight down, one sampled texel (scale metres) per pixel, pixel centres on texel corners.
        Camera cam;
        cam.vertical_fov_deg = 60;
        cam.width_px = cam.height_px = kView;
        cam.position = {kCore + 0.5 * scale, -(kCore + 0.5 * scale), scale * (kView / 2.0) / std::tan(M_PI / 6)};
        cam.direction = {0, 0, -1};
        cam.up = {0, 1, 0};
        cam.near_m = 1;
        cam.far_m = 1e5;
        auto draw = [&](const MeshData& m, const std::vector<const GpuTexture*>& textures) {
            GpuMesh mesh = r->upload(m);
            t->bind();
            r->beginFrame(cam, {0, 0, 0, 1});
            r->drawOriginals(mesh, [&](int32_t k) { return textures[static_cast<size_t>(k)]; }, nullptr, {0, 0, 0}, 0);
            r->endFrame();
            r->release(&mesh);
            std::vector<uint8_t> px;
            t->readPixels(&px);
            return px;
        };
        auto vertex = [](MeshData* m, const tiles::ClipVertex& v, int32_t texture) {
            m->positions.insert(m->positions.end(), {static_cast<float>(v.position.x), static_cast<float>(v.position.y), 0.0F});
            m->uv_original.insert(m->uv_original.end(), {static_cast<float>(v.uv.x), static_cast<float>(v.uv.y)});
            m->uv_atlas.insert(m->uv_atlas.end(), {0.0F, 0.0F});
            m->texture_id.push_back(texture);
            m->material_id.push_back(-1);
            m->feature_id.push_back(0);
        };
        // Whole.
        MeshData whole;
        for (const tiles::ClipVertex& v : corners) vertex(&whole, v, 0);
        whole.indices = {0, 1, 2, 0, 2, 3};
        whole.texture_ranges = {{0, 0, 6, {}}};
        GpuTexture whole_texture = r->upload(compress(image, true), false);
        const std::vector<uint8_t> reference = draw(whole, {&whole_texture});
        // Tiled, at overlaps 0, 4 * 2^(level - 1) (too little for this level) and 4 * 2^level.
        std::vector<int> overlaps{0, tiles::tileOverlap(level)};
        if (level > 0) overlaps.insert(overlaps.begin() + 1, tiles::tileOverlap(level - 1));
        for (const int overlap : overlaps) {
            const tiles::TileGrid grid = tiles::tileGridFor(kTexture, kTexture, WrapMode::Clamp, kCore, overlap);
            std::vector<tiles::TilePiece> pieces;
            for (const auto& tri : {std::array<tiles::ClipVertex, 3>{corners[0], corners[1], corners[2]},
                                    std::array<tiles::ClipVertex, 3>{corners[0], corners[2], corners[3]}})
                ASSERT_TRUE(tiles::clipToTiles(grid, tri, &pieces));
            std::sort(pieces.begin(), pieces.end(), [](const auto& a, const auto& b) { return a.tile < b.tile; });
            MeshData tiled;
            std::vector<GpuTexture> uploaded;
            std::vector<const GpuTexture*> textures(static_cast<size_t>(grid.count()), nullptr);
            for (const tiles::TilePiece& p : pieces) {
                if (tiled.texture_ranges.empty() || tiled.texture_ranges.back().texture != p.tile)
                    tiled.texture_ranges.push_back({p.tile, static_cast<uint32_t>(tiled.indices.size()), 0, {}});
                for (const tiles::ClipVertex& v : p.corners) {
                    tiled.indices.push_back(static_cast<uint32_t>(tiled.positions.size() / 3));
                    vertex(&tiled, v, p.tile);
                }
                tiled.texture_ranges.back().index_count += 3;
            }
            uploaded.reserve(tiled.texture_ranges.size());
            for (const MeshData::TextureRange& range : tiled.texture_ranges) {
                const tiles::Image8 tile = tiles::cropTile(image, grid.rectOf(range.texture), grid.wraps);
                uploaded.push_back(r->upload(compress(tile, true), false));
                textures[static_cast<size_t>(range.texture)] = &uploaded.back();
            }
            ASSERT_EQ(tiled.texture_ranges.size(), 4U) << "the view spans the corner of four cores";
            const std::vector<uint8_t> got = draw(tiled, textures);
            // Pixels whose centre lies on a core line (x or y = 512 m): the seam.
            int worst = 0, worst_seam = 0, seam = 0, seam_off = 0;
            for (int y = 0; y < kView; ++y)
                for (int x = 0; x < kView; ++x) {
                    const Rgba a = pixelAt(got, kView, x, y), b = pixelAt(reference, kView, x, y);
                    const int d = maxRgbDiff(a, b);
                    worst = std::max(worst, d);
                    const double wx = cam.position.x + (x + 0.5 - kView / 2.0) * scale;
                    const double wy = -cam.position.y + (y + 0.5 - kView / 2.0) * scale;  // t: rows down
                    if (std::abs(wx - kCore) < 0.25 || std::abs(wy - kCore) < 0.25) {
                        ++seam;
                        worst_seam = std::max(worst_seam, d);
                        seam_off += d >= 20;
                    }
                }
            SCOPED_TRACE(::testing::Message() << "level " << level << ", overlap " << overlap);
            EXPECT_GE(seam, 2 * kView - 1) << "a row and a column of seam pixels";
            if (overlap >= tiles::tileOverlap(level)) {
                EXPECT_LE(worst, 1);
            } else if (overlap == 0) {
                EXPECT_EQ(seam_off, seam) << "every seam pixel is off by >= 20 LSB (worst " << worst_seam << ")";
            } else {
                EXPECT_GT(worst, 1) << "too little overlap for this level shows";
            }
            for (GpuTexture& g : uploaded) r->release(&g);
        }
        r->release(&whole_texture);
    }
}

// ---------------------------------------------------------------- lenses (render/core/lenses.h, papers/003)

// A vertical quad through `centre`, spanning `along` (horizontal, unit) by
// [z0, z1], one feature and one material.
MeshData wall(const Vec3d& centre, const Vec3d& along, double half, double z0, double z1, uint32_t feature,
              int32_t material) {
    MeshData m;
    const Vec3d a = centre - half * along, b = centre + half * along;
    for (const Vec3d& p : {Vec3d{a.x, a.y, z0}, Vec3d{b.x, b.y, z0}, Vec3d{b.x, b.y, z1}, Vec3d{a.x, a.y, z1}}) {
        m.positions.insert(m.positions.end(), {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)});
        m.material_id.push_back(material);
        m.feature_id.push_back(feature);
    }
    m.indices = {0, 1, 2, 0, 2, 3};
    return m;
}

// L3: a wall on a 3-4-5 rotation seen along an axis has |cos| exactly 0.8 or
// 0.6 at the image centre, so x-ray composites over the background with
// opacity 1 - |cos|^e, within 1 LSB; picking (the id buffer) sees through it.
TEST_F(GlTest, XRayWallOnA345RotationHasTheFormulasOpacity) {
    constexpr int kSize = 64;
    const std::vector<MaterialInfo> materials{{{0.8F, 0.1F, 0.05F}, 0}};
    auto r = renderer(materials);
    auto t = target(kSize, kSize, true);
    ASSERT_NE(t, nullptr);
    const std::array<float, 4> clear{0.2F, 0.3F, 0.4F, 1.0F};
    for (const auto& [along, cosine] : std::vector<std::pair<Vec3d, double>>{{{0.8, 0.6, 0}, 0.8}, {{0.6, 0.8, 0}, 0.6}}) {
        for (const float e : {0.5F, 1.0F}) {
            GpuMesh m = r->upload(wall({0, 10, 0}, along, 20, -20, 20, 5, 0));
            LensStyle lens;
            lens.style.assign(8, LensStyle::kNormal);
            lens.style[5] = LensStyle::kXRay;
            lens.xray_falloff = e;
            r->setLens(lens);
            t->bind();
            r->beginFrame(frontCamera(kSize, {0, 0, 0}, 5), clear);
            r->drawAtlas(m, nullptr, {0, 0, 0}, 0);
            r->endFrame();
            std::vector<uint8_t> px;
            t->readPixels(&px);
            const double a = 1.0 - std::pow(cosine, e);
            const std::array<double, 3> c{0.8, 0.1, 0.05};
            const Rgba want{linearToByte(a * c[0] + (1 - a) * clear[0]), linearToByte(a * c[1] + (1 - a) * clear[1]),
                            linearToByte(a * c[2] + (1 - a) * clear[2]), 255};
            const Rgba got = pixelAt(px, kSize, kSize / 2, kSize / 2);
            EXPECT_LE(maxRgbDiff(got, want), 1) << "cos " << cosine << " e " << e << ": " << str(got) << " vs " << str(want);
            EXPECT_EQ(t->idAt(kSize / 2, kSize / 2), OffscreenTarget::kNoFeature) << "the x-ray face hides nothing from picking";
            r->release(&m);
        }
    }
    r->setLens({});
}

// L5 and the per-feature styles: a sphere lens on a wall facing the camera
// styles exactly the pixels whose point on the wall (the pixel ray's hit) lies
// outside the sphere with the context formula, and leaves those inside as
// they are; discarded features leave no pixel and no id; a flattened wall
// keeps only its lowest sliver.
TEST_F(GlTest, SphereLensStylesExactlyThePixelsOutsideItAndDiscardAndFlattenWork) {
    constexpr int kSize = 64;
    const std::vector<MaterialInfo> materials{{{0.7F, 0.35F, 0.1F}, 0}};
    auto r = renderer(materials);
    auto t = target(kSize, kSize, true);
    ASSERT_NE(t, nullptr);
    const Camera cam = frontCamera(kSize, {0, 0, 0}, 60);
    GpuMesh m = r->upload(wall({0, 10, 0}, {1, 0, 0}, 20, -20, 20, 2, 0));
    LensStyle lens;
    lens.lens = 1;
    lens.lens_centre = {1.0, 10.0, -0.5};
    lens.lens_radius_m = 3.0;
    r->setLens(lens);
    t->bind();
    r->beginFrame(cam, {0, 0, 0, 1});
    r->drawAtlas(m, nullptr, {0, 0, 0}, 0);
    r->endFrame();
    std::vector<uint8_t> px;
    t->readPixels(&px);
    const std::array<double, 3> c{0.7, 0.35, 0.1};
    const double grey = 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    auto context = [&](int k) { return (grey + (c[static_cast<size_t>(k)] - grey) * lens.context_saturation) * lens.context_brightness; };
    const Rgba inside{linearToByte(c[0]), linearToByte(c[1]), linearToByte(c[2]), 255};
    const Rgba outside{linearToByte(context(0)), linearToByte(context(1)), linearToByte(context(2)), 255};
    const double pixel_m = 2 * 10 * std::tan(M_PI / 6) / kSize;  // a pixel's size on the wall
    int checked = 0, in = 0, worst = 0;
    for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x) {
            const Vec3d ray = pixelRay(cam, x + 0.5, y + 0.5);
            const Vec3d hit = (10.0 / ray.y) * ray;
            const double d = length(hit - lens.lens_centre);
            if (std::abs(d - lens.lens_radius_m) < 1.5 * pixel_m) continue;  // the silhouette, within a pixel
            const bool is_in = d < lens.lens_radius_m;
            worst = std::max(worst, maxRgbDiff(pixelAt(px, kSize, x, y), is_in ? inside : outside));
            ++checked;
            in += is_in;
        }
    EXPECT_LE(worst, 1) << "inside " << str(inside) << ", outside " << str(outside);
    EXPECT_GT(in, 100);
    EXPECT_GT(checked - in, 1000);

    // Discard: nothing drawn, no id. Flatten: a wall from 0 to 20 m at k 0.02 keeps 0 to 0.4 m.
    LensStyle styles;
    styles.style = {0, 0, LensStyle::kDiscard};
    r->setLens(styles);
    r->beginFrame(cam, {0, 0, 0, 1});
    r->drawAtlas(m, nullptr, {0, 0, 0}, 0);
    r->endFrame();
    std::vector<uint32_t> ids;
    t->readIds(&ids);
    EXPECT_TRUE(std::all_of(ids.begin(), ids.end(), [](uint32_t i) { return i == OffscreenTarget::kNoFeature; }));
    GpuMesh tall = r->upload(wall({0, 10, 0}, {1, 0, 0}, 20, 0, 20, 2, 0));
    styles.style = {0, 0, LensStyle::kFlatten};
    styles.base_z = {0, 0, 0.0F};  // local frame
    styles.flatten = 0.02F;
    r->setLens(styles);
    r->beginFrame(cam, {0, 0, 0, 1});
    r->drawAtlas(tall, nullptr, {0, 0, 0}, 0);
    r->endFrame();
    // Rows above the horizon see z > 0.4 m on the wall (10 m away): none is drawn.
    int drawn_above = 0, drawn_sliver = 0;
    for (int y = 0; y < kSize; ++y) {
        const Vec3d ray = pixelRay(cam, kSize / 2 + 0.5, y + 0.5);
        const double z = 10.0 * ray.z / ray.y;
        const bool drawn = t->idAt(kSize / 2, y) == 2;
        if (z > 0.4 + pixel_m) drawn_above += drawn;
        if (z > pixel_m && z < 0.4 - pixel_m) drawn_sliver += !drawn;
    }
    EXPECT_EQ(drawn_above, 0);
    EXPECT_EQ(drawn_sliver, 0);
    r->setLens({});
    r->release(&m);
    r->release(&tall);
}


// L4 (papers/003 eq. 3.20, flatten factor 0): an L-shaped prism on a 3-4-5
// rotation, base 2 m, 15 m tall, seen obliquely from above, is drawn flat:
// every pixel with its id lies within 1 px of its footprint polygon projected
// (an independent pinhole projection, not pixelRay), every pixel more than
// 1 px inside that polygon has its id, and the depth there is the base
// plane's, within a few steps of the 24-bit depth buffer.
TEST_F(GlTest, FlattenDrawsTheFootprintAtTheBasePlanesDepth) {
    constexpr int kSize = 256;
    const std::vector<MaterialInfo> materials{{{0.6F, 0.6F, 0.6F}, 0}};
    auto r = renderer(materials);
    auto t = target(kSize, kSize, true);
    ASSERT_NE(t, nullptr);
    constexpr double kBase = 2, kTop = 17;
    const Vec3d origin{-4, 18, 0}, u{0.8, 0.6, 0}, v{-0.6, 0.8, 0};
    std::vector<Vec3d> footprint;  // counter-clockwise
    for (const auto& [a, b] : std::vector<std::pair<double, double>>{{0, 0}, {12, 0}, {12, 5}, {5, 5}, {5, 10}, {0, 10}})
        footprint.push_back(origin + a * u + b * v);
    MeshData m;
    auto vertex = [&](const Vec3d& p, double z) {
        m.positions.insert(m.positions.end(), {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(z)});
        m.material_id.push_back(0);
        m.feature_id.push_back(2);
        return static_cast<uint32_t>(m.positions.size() / 3 - 1);
    };
    for (size_t i = 0; i < footprint.size(); ++i) {  // the walls
        const Vec3d& a = footprint[i];
        const Vec3d& b = footprint[(i + 1) % footprint.size()];
        const uint32_t k = vertex(a, kBase);
        vertex(b, kBase), vertex(b, kTop), vertex(a, kTop);
        m.indices.insert(m.indices.end(), {k, k + 1, k + 2, k, k + 2, k + 3});
    }
    std::vector<uint32_t> roof;  // the L as two rectangles: 0-1-2-3 and 0-3-4-5
    for (const Vec3d& p : footprint) roof.push_back(vertex(p, kTop));
    m.indices.insert(m.indices.end(), {roof[0], roof[1], roof[2], roof[0], roof[2], roof[3],
                                       roof[0], roof[3], roof[4], roof[0], roof[4], roof[5]});
    GpuMesh mesh = r->upload(m);
    Camera cam;
    cam.position = {-2, 5, 25};
    cam.direction = normalized(Vec3d{-0.2, 20.6, -23});  // at the footprint's centre (-2.2, 25.6, 2)
    cam.up = {0, 0, 1};
    cam.vertical_fov_deg = 60;
    cam.width_px = cam.height_px = kSize;
    cam.near_m = 1;
    cam.far_m = 500;
    // The pinhole projection, from the camera's own axes.
    const Vec3d fwd = cam.direction, right = normalized(cross(fwd, cam.up)), up = cross(right, fwd);
    const double focal = kSize / 2.0 / std::tan(cam.vertical_fov_deg * M_PI / 360);
    auto project = [&](const Vec3d& p) {
        const Vec3d e = p - cam.position;
        return std::array<double, 2>{kSize / 2.0 + focal * dot(e, right) / dot(e, fwd),
                                     kSize / 2.0 - focal * dot(e, up) / dot(e, fwd)};
    };
    std::vector<std::array<double, 2>> poly;
    for (const Vec3d& p : footprint) poly.push_back(project(p + Vec3d{0, 0, kBase}));
    // Signed distance in pixels to the projected polygon: negative inside.
    auto signedDistance = [&](double x, double y) {
        double best = 1e300;
        bool inside = false;
        for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
            const auto& a = poly[j];
            const auto& b = poly[i];
            if ((a[1] > y) != (b[1] > y) && x < a[0] + (y - a[1]) * (b[0] - a[0]) / (b[1] - a[1])) inside = !inside;
            const double dx = b[0] - a[0], dy = b[1] - a[1];
            const double s = std::clamp(((x - a[0]) * dx + (y - a[1]) * dy) / (dx * dx + dy * dy), 0.0, 1.0);
            best = std::min(best, std::hypot(x - a[0] - s * dx, y - a[1] - s * dy));
        }
        return inside ? -best : best;
    };
    // The base plane's window depth along a pixel's ray (GL's perspective depth).
    auto baseDepth = [&](double x, double y) {
        const Vec3d ray = fwd + ((x - kSize / 2.0) / focal) * right - ((y - kSize / 2.0) / focal) * up;
        const double s = (kBase - cam.position.z) / ray.z;  // ray parameter; eye depth = s (fwd component is 1)
        return cam.far_m * (s - cam.near_m) / ((cam.far_m - cam.near_m) * s);
    };
    for (const float k : {0.0F, 0.001F}) {
        LensStyle lens;
        lens.style = {0, 0, LensStyle::kFlatten};
        lens.base_z = {0, 0, static_cast<float>(kBase)};
        lens.flatten = k;
        r->setLens(lens);
        t->bind();
        r->beginFrame(cam, {0, 0, 0, 1});
        r->drawAtlas(mesh, nullptr, {0, 0, 0}, 0);
        r->endFrame();
        std::vector<uint32_t> ids;
        std::vector<float> depth;
        ASSERT_TRUE(t->readIds(&ids));
        t->readDepth(&depth);
        int drawn = 0, outside = 0, missing = 0, inner = 0;
        double worst_depth = 0;
        for (int y = 0; y < kSize; ++y)
            for (int x = 0; x < kSize; ++x) {
                const double d = signedDistance(x + 0.5, y + 0.5);
                const bool has = ids[static_cast<size_t>(y * kSize + x)] == 2;
                drawn += has;
                if (has && d > 1) ++outside;
                if (d < -1) {
                    ++inner;
                    missing += !has;
                    if (has) worst_depth = std::max(worst_depth, std::abs(depth[static_cast<size_t>(y * kSize + x)] - baseDepth(x + 0.5, y + 0.5)));
                }
            }
        const double step = 1.0 / ((1 << 24) - 1);
        SCOPED_TRACE(::testing::Message() << "flatten " << k);
        EXPECT_GT(inner, 1500) << "the footprint covers enough pixels";
        EXPECT_EQ(outside, 0) << drawn << " pixels drawn";
        EXPECT_EQ(missing, 0);
        if (k == 0) EXPECT_LE(worst_depth, 4 * step) << worst_depth / step << " depth steps";
        else EXPECT_GT(worst_depth, 4 * step) << "15 mm above the base is seen (the check can fail)";
    }
    r->setLens({});
    r->release(&mesh);
}

}  // namespace
}  // namespace cityatlas::render

namespace cityatlas::render {
namespace {

// A BC4 computed texture as the loader hands it over: 16 x 16 (a quarter of
// the 64 px photo per axis, as --computed scale=4 makes it), the top half
// code 255, the bottom-left quarter 128, the bottom-right 0 (rows top-down;
// constant 4 x 4 blocks, which BC4 holds exactly).
CompressedTexture computedQuadrants() {
    tiles::Image8 img{16, 16, 1, std::vector<uint8_t>(256)};
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x) img.pixels[static_cast<size_t>(y * 16 + x)] = y < 8 ? 255 : x < 8 ? 128 : 0;
    const std::vector<uint8_t> dds = tiles::encodeDds(tiles::mipChain(img), tiles::BcQuality::Fast);
    CompressedTexture t;
    const Status st = decodeDds(dds.data(), dds.size(), 1, &t);
    EXPECT_TRUE(st.ok()) << st.error;
    return t;
}

// M3 and M4 (issue 19; papers/000 Fig. 20), and Fig. 34's emphasis: the photo render against the same
// quad with its computed texture, at pixels one computed texel (4 px) away
// from the quadrants' edges, where bilinear filtering reads one value.
TEST_F(GlTest, ComputedTextureRampAndModulateFollowTheirFormulas) {
    constexpr int kSize = 64;
    // The CPU-decode fallback decodes BC1 only: BC4 is core GL and stays compressed.
    RendererOptions options = exactFiltering();
    options.force_cpu_decode = true;
    auto r = renderer({}, options);
    auto t = target(kSize, kSize);
    Status status;
    GpuTexture photo = r->upload(compress(pattern(kSize, kSize, 3), true), false, &status);
    ASSERT_TRUE(status.ok()) << status.error;
    const CompressedTexture bc4 = computedQuadrants();
    GpuTexture computed = r->upload(bc4, false, &status);
    ASSERT_TRUE(status.ok()) << status.error;
    EXPECT_FALSE(computed.decoded_on_cpu);
    uint64_t bc4_bytes = 0;
    for (const auto& level : bc4.levels) bc4_bytes += level.bytes;
    EXPECT_EQ(computed.gpu_bytes, bc4_bytes);

    MeshData m;
    addQuad(&m, -1, 1, -1, 1, {}, {}, -1);
    GpuMesh mesh = r->upload(m, &status);
    ASSERT_TRUE(status.ok()) << status.error;
    auto draw = [&](const ComputedStyle& style, const GpuTexture* c) {
        r->setComputed(style);
        t->bind();
        r->beginFrame(frontCamera(kSize), {0, 0, 0, 1});
        r->drawAtlas(mesh, &photo, Vec3d{0, 1, 0}, 0, c);
        r->endFrame();
        std::vector<uint8_t> pixels;
        t->readPixels(&pixels);
        return pixels;
    };
    const std::vector<uint8_t> plain = draw({}, nullptr);
    // The computed value under pixel (x, y) (rows top-down), or -1 near a quadrant's edge.
    auto value = [](int x, int y) -> int {
        const bool near_edge = std::abs(y - 32) < 4 || (y >= 32 && std::abs(x - 32) < 4);
        if (near_edge) return -1;
        return y < 32 ? 255 : x < 32 ? 128 : 0;
    };
    const auto& ramp = computedRamp();
    const std::vector<uint8_t> ramped = draw({ComputedMode::Ramp}, &computed);
    const std::vector<uint8_t> modulated = draw({ComputedMode::Modulate, 0.0F, 1.0F}, &computed);
    const std::vector<uint8_t> bright = draw({ComputedMode::Modulate, 0.3F, 1.2F}, &computed);
    const std::vector<uint8_t> emphasis = draw({ComputedMode::Emphasis, 0.3F, 1.0F}, &computed);
    const std::vector<uint8_t> photo_mode = draw({ComputedMode::Photo}, &computed);
    const std::vector<uint8_t> missing = draw({ComputedMode::Ramp}, nullptr);
    int checked = 0, ramp_255_exact = 0, worst_ramp = 0, worst_modulate = 0, worst_bright = 0, worst_emphasis = 0;
    for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x) {
            const Rgba p = pixelAt(plain, kSize, x, y);
            // Photo mode and a computed texture not resident draw the photo exactly.
            ASSERT_EQ(maxRgbDiff(pixelAt(photo_mode, kSize, x, y), p), 0) << x << "," << y;
            ASSERT_EQ(maxRgbDiff(pixelAt(missing, kSize, x, y), p), 0) << x << "," << y;
            const int v = value(x, y);
            if (v < 0) continue;
            ++checked;
            const RampColour& c = ramp[static_cast<size_t>(v)];
            const int d_ramp = maxRgbDiff(pixelAt(ramped, kSize, x, y), {c[0], c[1], c[2], 255});
            worst_ramp = std::max(worst_ramp, d_ramp);
            if (v == 255 && d_ramp == 0) ++ramp_255_exact;
            // photo x v in linear light, then sRGB.
            const double f = v / 255.0;
            const Rgba want{linearToByte(byteToLinear(static_cast<uint8_t>(p.r)) * f),
                            linearToByte(byteToLinear(static_cast<uint8_t>(p.g)) * f),
                            linearToByte(byteToLinear(static_cast<uint8_t>(p.b)) * f), 255};
            worst_modulate = std::max(worst_modulate, maxRgbDiff(pixelAt(modulated, kSize, x, y), want));
            if (v == 255) worst_bright = std::max(worst_bright, maxRgbDiff(pixelAt(bright, kSize, x, y), p));
            // Fig. 34's emphasis, by its definition: saturation by v, brightness min(1, 0.3 + 0.7 v), yellow 0.15 v.
            const double lin[3] = {byteToLinear(static_cast<uint8_t>(p.r)), byteToLinear(static_cast<uint8_t>(p.g)),
                                   byteToLinear(static_cast<uint8_t>(p.b))};
            const double grey = 0.2126 * lin[0] + 0.7152 * lin[1] + 0.0722 * lin[2];
            const double yellow[3] = {1.0, 0.8, 0.1};
            int e[3];
            for (int k = 0; k < 3; ++k) {
                const double saturated = grey + (lin[k] - grey) * f;
                const double bright_k = saturated * std::min(1.0, 0.3 + 0.7 * f);
                e[k] = linearToByte(bright_k + (yellow[k] - bright_k) * 0.15 * f);
            }
            worst_emphasis = std::max(worst_emphasis, maxRgbDiff(pixelAt(emphasis, kSize, x, y), {e[0], e[1], e[2], 255}));
        }
    std::printf("computed: %d pixels checked; ramp within %d (value 1: %d pixels exactly LUT[255]), modulate within %d, "
                "b_max >= 1 at value 1 within %d, emphasis within %d\n",
                checked, worst_ramp, ramp_255_exact, worst_modulate, worst_bright, worst_emphasis);
    EXPECT_GT(checked, 2000);
    EXPECT_EQ(ramp_255_exact, 64 * 29);  // M4: every value-1 pixel is LUT[255] exactly (rows 0..28)
    EXPECT_LE(worst_ramp, 1);
    EXPECT_LE(worst_modulate, 1);        // M3, b_min 0 and b_max 1: photo x v
    EXPECT_LE(worst_bright, 1);          // M3, b_max >= 1 where the value is 1: the photo
    EXPECT_LE(worst_emphasis, 1);        // Fig. 34 at the values 0, 128/255 and 1
    r->release(&mesh);
    r->release(&photo);
    r->release(&computed);
}

// ---------------------------------------------------------------- edge enhancement (render/gl/edge_pass.h)

// A frame of four surfaces: a far wall (feature 7) filling the view, a near
// quad of feature 9 (outline against 7), a quad of feature 7 in front of the
// wall (the same id: only its depth step marks it) and a quad of feature 11
// slanted away from the camera (a plane: 1 / depth affine on screen, so no
// crease inside it). With edges on, every pixel is checked against the rule
// of edge_pass.h evaluated here in double from the id and depth buffers read
// back: edge pixels darkened by (1 - strength) in linear light within 1 LSB,
// all others byte-identical. Pixels within 20 % of the crease threshold are
// left out (float against double).
TEST_F(GlTest, EdgeEnhancementDarkensOutlinesAndDepthStepsOnlyByItsFactor) {
    constexpr int kSize = 64;
    const std::vector<MaterialInfo> materials{{{0.6F, 0.6F, 0.6F}, 0}, {{0.3F, 0.5F, 0.7F}, 0}};
    auto r = renderer(materials);
    Status status;
    auto t = OffscreenTarget::create(kSize, kSize, &status, /*with_ids=*/true);
    ASSERT_TRUE(status.ok()) << status.error;
    auto quad = [&](float x0, float x1, float z0, float z1, int32_t material, uint32_t feature, float slant = 0) {
        MeshData m;
        addQuad(&m, x0, x1, z0, z1, {}, {}, material);
        std::fill(m.feature_id.begin(), m.feature_id.end(), feature);
        for (size_t v = 0; v < 4; ++v)
            if (m.positions[3 * v] == x1) m.positions[3 * v + 1] += slant;  // the right side farther away
        return r->upload(m);
    };
    GpuMesh wall = quad(-9, 9, -9, 9, 0, 7), near9 = quad(-2, -0.5F, -1, 1, 1, 9), near7 = quad(1, 3, -1, 1, 0, 7),
            slanted = quad(-1, 1.5F, -3, -2, 1, 11, 2.5F);
    const Camera camera = frontCamera(kSize);
    auto draw = [&] {
        t->bind();
        r->beginFrame(camera, {0, 0, 0, 1});
        r->drawAtlas(wall, nullptr, {0, 8, 0}, 0);
        r->drawAtlas(near9, nullptr, {0, 2, 0}, 0);
        r->drawAtlas(near7, nullptr, {0, 4, 0}, 0);
        r->drawAtlas(slanted, nullptr, {0, 3, 0}, 0);
        r->endFrame();
    };
    draw();
    std::vector<uint8_t> plain, edged;
    std::vector<uint32_t> ids;
    std::vector<float> depth;
    t->readPixels(&plain);
    ASSERT_TRUE(t->readIds(&ids));
    t->readDepth(&depth);
    EdgeStyle style;
    style.enabled = true;
    draw();
    ASSERT_TRUE(r->applyEdges(*t, style).ok());
    t->readPixels(&edged);
    std::vector<uint32_t> ids_after;
    ASSERT_TRUE(t->readIds(&ids_after));
    EXPECT_EQ(ids_after, ids) << "the pass leaves the id buffer as it was";

    // The rule, in double. Read-backs are top-down; neighbours are symmetric, so the flip does not matter.
    const double n = camera.near_m, f = camera.far_m;
    auto inv = [&](int x, int y) {
        const double z = 2.0 * depth[static_cast<size_t>(y) * kSize + x] - 1.0;
        return (f + n - z * (f - n)) / (2 * n * f);
    };
    auto id = [&](int x, int y) { return ids[static_cast<size_t>(y) * kSize + x]; };
    int outline = 0, crease_only = 0, slanted_inside = 0, plain_pixels = 0, worst = 0;
    for (int y = 1; y < kSize - 1; ++y)
        for (int x = 1; x < kSize - 1; ++x) {
            const Rgba a = pixelAt(plain, kSize, x, y), b = pixelAt(edged, kSize, x, y);
            const uint32_t c = id(x, y);
            ASSERT_NE(c, OffscreenTarget::kNoFeature);
            const bool other = id(x + 1, y) != c || id(x - 1, y) != c || id(x, y + 1) != c || id(x, y - 1) != c;
            const double ic = inv(x, y);
            const double second = std::max(std::abs(inv(x + 1, y) + inv(x - 1, y) - 2 * ic),
                                           std::abs(inv(x, y + 1) + inv(x, y - 1) - 2 * ic)) / (style.crease * ic);
            if (!other && second > 0.8 && second < 1.25) continue;  // at the threshold: float vs double
            const bool edge = other || second >= 1.25;
            if (edge) {
                const auto dark = [&](int v) { return linearToByte(byteToLinear(static_cast<uint8_t>(v)) * (1.0 - style.strength)); };
                const int d = std::max({std::abs(b.r - dark(a.r)), std::abs(b.g - dark(a.g)), std::abs(b.b - dark(a.b))});
                worst = std::max(worst, d);
                EXPECT_LE(d, 1) << "edge pixel (" << x << ", " << y << ")";
                (other ? outline : crease_only) += 1;
            } else {
                EXPECT_EQ(maxRgbDiff(a, b), 0) << "pixel (" << x << ", " << y << ") is no edge";
                ++plain_pixels;
                slanted_inside += c == 11;
            }
        }
    std::printf("edges: %d outline and %d depth-step pixels darkened (worst %d LSB off the factor), %d untouched, "
                "%d of them inside the slanted quad\n",
                outline, crease_only, worst, plain_pixels, slanted_inside);
    EXPECT_GE(outline, 100);
    EXPECT_GE(crease_only, 40) << "the same-id quad in front of the wall is marked by its depth step";
    EXPECT_GE(slanted_inside, 50) << "a slanted plane has no creases inside";
    EXPECT_GE(plain_pixels, 2000);
    // Off: nothing changes.
    draw();
    ASSERT_TRUE(r->applyEdges(*t, {}).ok());
    t->readPixels(&edged);
    EXPECT_EQ(edged, plain);
    // Without an id buffer: a clear refusal.
    auto bare = OffscreenTarget::create(kSize, kSize, &status);
    const Status refused = r->applyEdges(*bare, style);
    EXPECT_FALSE(refused.ok());
    EXPECT_NE(refused.error.find("id buffer"), std::string::npos) << refused.error;
    for (GpuMesh* g : {&wall, &near9, &near7, &slanted}) r->release(g);
}

}  // namespace
}  // namespace cityatlas::render
