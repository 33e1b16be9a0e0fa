// SPDX-License-Identifier: GPL-3.0-or-later
// Tests of tiles/texture_codec: linear-light mip chains, BC1/BC3 blocks and the
// DDS container. OpenImageIO reads the DDS files back as the independent
// oracle for the container; squish::Decompress (the reference decoder) checks
// the blocks themselves.
#include "tiles/texture_codec.h"

#include <algorithm>
#include <random>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <OpenImageIO/imageio.h>
#include <squish.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include "ingest/synth/facade_texture.h"

namespace fs = std::filesystem;
using cityatlas::tiles::BcQuality;
using cityatlas::tiles::Image8;
namespace tiles = cityatlas::tiles;

namespace {

// ---------------------------------------------------------------- helpers

// splitmix64: seeded, platform-independent noise (std:: distributions are not
// specified bit-exactly across standard libraries).
uint64_t mix(uint64_t z) {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}
int noise(uint64_t seed, int x, int y, int c, int amplitude) {  // uniform in [-amplitude, amplitude]
    const uint64_t h = mix(seed ^ mix(uint64_t(x) * 73856093u ^ uint64_t(y) * 19349663u ^ uint64_t(c) * 83492791u));
    return int(h % uint64_t(2 * amplitude + 1)) - amplitude;
}
uint8_t clamp8(double v) { return uint8_t(std::clamp(std::lround(v), 0L, 255L)); }

// A photo-like test image: smooth gradients, a grid of hard-edged dark
// "windows", and seeded noise; RGBA gets a smooth alpha ramp with translucent
// windows (the case BC3 is for).
Image8 photoLike(int w, int h, int channels, uint64_t seed) {
    Image8 img{w, h, channels, std::vector<uint8_t>(size_t(w) * size_t(h) * size_t(channels))};
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double rgb[3] = {128 + 90 * std::sin(x * 0.021 + y * 0.007), 120 + 80 * std::cos(y * 0.017 - x * 0.004),
                             100 + 60 * std::sin((x + y) * 0.011)};
            const bool window = x % 48 >= 8 && x % 48 < 30 && y % 40 >= 6 && y % 40 < 28;
            if (window) {
                rgb[0] = 30 + (x % 48) * 0.8;
                rgb[1] = 38;
                rgb[2] = 60 + (y % 40);
            }
            uint8_t* p = &img.pixels[(size_t(y) * size_t(w) + size_t(x)) * size_t(channels)];
            for (int c = 0; c < 3; ++c) p[c] = clamp8(rgb[c] + noise(seed, x, y, c, 5));
            if (channels == 4)
                p[3] = window ? clamp8(70 + noise(seed, x, y, 3, 4))
                              : clamp8(200 + 50 * std::sin(x * 0.013) * std::cos(y * 0.009) + noise(seed, x, y, 3, 2));
        }
    return img;
}

Image8 facade(uint32_t number, bool rgba, int size) {
    cityatlas::synth::FacadeStyle style;
    style.building_number = number;
    style.storeys = 5;
    style.window_columns = 4;
    style.transparent_glass = rgba;
    style.seed = 1000 + number;
    const cityatlas::synth::Image8 f = cityatlas::synth::drawFacade(style, size, size);
    return Image8{f.width, f.height, f.channels, f.pixels};
}

// Reads a DDS with OpenImageIO: every mip level as 8-bit, as many channels as
// OIIO reports.
struct DdsRead {
    int width = 0, height = 0, channels = 0;
    std::vector<Image8> levels;
};
DdsRead readDds(const fs::path& path) {
    DdsRead r;
    auto in = OIIO::ImageInput::open(path.string());
    if (!in) {
        ADD_FAILURE() << "OIIO cannot open " << path << ": " << OIIO::geterror();
        return r;
    }
    r.width = in->spec().width;
    r.height = in->spec().height;
    r.channels = in->spec().nchannels;
    for (int m = 0; in->seek_subimage(0, m); ++m) {
        const OIIO::ImageSpec& s = in->spec();
        Image8 level{s.width, s.height, s.nchannels,
                     std::vector<uint8_t>(size_t(s.width) * size_t(s.height) * size_t(s.nchannels))};
        if (!in->read_image(0, m, 0, s.nchannels, OIIO::TypeDesc::UINT8, level.pixels.data()))
            ADD_FAILURE() << "OIIO cannot read level " << m << " of " << path << ": " << in->geterror();
        r.levels.push_back(std::move(level));
    }
    in->close();
    return r;
}

// A scratch folder, removed afterwards.
struct TempDir {
    fs::path dir;
    TempDir() {
        dir = fs::temp_directory_path() /
              ("cityatlas_texture_codec_" + std::to_string(::getpid()) + "_" +
               ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir);
        fs::create_directories(dir);
    }
    ~TempDir() {
        std::error_code ec;
        fs::remove_all(dir, ec);
    }
};

// PSNR of channel `c` only (for alpha).
double psnrChannel(const Image8& a, const Image8& b, int c) {
    double sq = 0;
    const size_t n = size_t(a.width) * size_t(a.height);
    for (size_t i = 0; i < n; ++i) {
        const double d = double(a.pixels[i * size_t(a.channels) + size_t(c)]) -
                         double(b.pixels[i * size_t(b.channels) + size_t(c)]);
        sq += d * d;
    }
    return sq == 0 ? std::numeric_limits<double>::infinity() : 10 * std::log10(255.0 * 255.0 * double(n) / sq);
}

Image8 padToBlocks(const Image8& img) {  // the test's own edge replication
    const int w = (img.width + 3) / 4 * 4, h = (img.height + 3) / 4 * 4, ch = img.channels;
    Image8 out{w, h, ch, std::vector<uint8_t>(size_t(w) * size_t(h) * size_t(ch))};
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < ch; ++c)
                out.pixels[(size_t(y) * size_t(w) + size_t(x)) * size_t(ch) + size_t(c)] =
                    img.pixels[(size_t(std::min(y, img.height - 1)) * size_t(img.width) +
                                size_t(std::min(x, img.width - 1))) * size_t(ch) + size_t(c)];
    return out;
}

uint32_t le32(const std::vector<uint8_t>& b, size_t offset) {
    return uint32_t(b[offset]) | uint32_t(b[offset + 1]) << 8 | uint32_t(b[offset + 2]) << 16 |
           uint32_t(b[offset + 3]) << 24;
}

std::string fmtDouble(double v) {
    std::ostringstream s;
    s.precision(4);
    s << std::fixed << v;
    return s.str();
}

double seconds(std::chrono::steady_clock::time_point since) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// Writes `base`'s full chain as DDS with `q`, reads it back with OIIO and
// returns OIIO's base-level PSNR (RGB) after checking the container metadata
// and that OIIO decodes every level like squish::Decompress does; `alpha_psnr`
// gets the alpha PSNR for RGBA sources.
double roundTripPsnr(const fs::path& path, const Image8& base, BcQuality q, double* alpha_psnr = nullptr) {
    const std::vector<Image8> mips = tiles::mipChain(base);
    const cityatlas::Status st = tiles::writeDds(path, mips, q);
    EXPECT_TRUE(st.ok()) << st.error;
    const DdsRead r = readDds(path);
    EXPECT_EQ(r.width, base.width);
    EXPECT_EQ(r.height, base.height);
    // DXT5 is RGBA. OIIO 2.4 reports DXT1 as RGBA too (alpha must then be
    // opaque everywhere, checked below); RGB is accepted for readers that
    // report an opaque DXT1 as RGB.
    if (base.channels == 4) {
        EXPECT_EQ(r.channels, 4);
    } else {
        EXPECT_TRUE(r.channels == 3 || r.channels == 4) << r.channels;
    }
    EXPECT_EQ(r.levels.size(), mips.size());
    if (r.levels.empty() || r.channels < 3) return 0;
    for (size_t m = 0; m < std::min(r.levels.size(), mips.size()); ++m) {
        const Image8& got = r.levels[m];
        EXPECT_EQ(got.width, mips[m].width) << "level " << m;
        EXPECT_EQ(got.height, mips[m].height) << "level " << m;
        if (got.width != mips[m].width || got.height != mips[m].height) continue;
        // The two decoders round 565 expansion and the 1/3 interpolation
        // differently, by one code; anything more means the container is off
        // (wrong level offset, size or format).
        const Image8 ref = tiles::decodeBc(tiles::encodeBc(mips[m], q), got.width, got.height, base.channels);
        int max_diff = 0;
        size_t not_opaque = 0;
        for (size_t i = 0; i < size_t(got.width) * size_t(got.height); ++i) {
            for (size_t c = 0; c < size_t(base.channels); ++c)
                max_diff = std::max(max_diff, std::abs(int(got.pixels[i * size_t(got.channels) + c]) -
                                                       int(ref.pixels[i * size_t(ref.channels) + c])));
            if (base.channels == 3 && got.channels == 4 && got.pixels[i * 4 + 3] != 255) ++not_opaque;
        }
        EXPECT_LE(max_diff, 2) << "OIIO against squish::Decompress, level " << m;
        EXPECT_EQ(not_opaque, 0u) << "DXT1 texels with alpha < 255, level " << m;
    }
    if (alpha_psnr && r.channels == 4) *alpha_psnr = psnrChannel(base, r.levels[0], 3);
    return tiles::psnrRgb(base, r.levels[0]);
}

// ------------------------------------------------------------------ tests

TEST(TextureCodec, QualityNamesRoundTrip) {
    for (BcQuality q : {BcQuality::Fast, BcQuality::Best})
        EXPECT_EQ(tiles::bcQualityFromName(tiles::bcQualityName(q)), q);
    EXPECT_EQ(tiles::bcQualityName(BcQuality::Fast), "fast");
    EXPECT_EQ(tiles::bcQualityName(BcQuality::Best), "best");
    EXPECT_FALSE(tiles::bcQualityFromName("Fast").has_value());  // names are exact, lower case
    EXPECT_FALSE(tiles::bcQualityFromName("").has_value());
}

TEST(TextureCodec, PsnrKnownValues) {
    Image8 a{2, 2, 3, std::vector<uint8_t>(12, 10)};
    EXPECT_TRUE(std::isinf(tiles::psnrRgb(a, a)));
    Image8 b = a;
    for (auto& v : b.pixels) v = 11;  // MSE 1 -> 20 log10(255) = 48.13 dB
    EXPECT_NEAR(tiles::psnrRgb(a, b), 48.1308, 1e-3);
    // Alpha is not part of the measure: an RGBA copy with any alpha is equal.
    Image8 c{2, 2, 4, {10, 10, 10, 0, 10, 10, 10, 1, 10, 10, 10, 2, 10, 10, 10, 3}};
    EXPECT_TRUE(std::isinf(tiles::psnrRgb(a, c)));
    Image8 d{2, 1, 3, std::vector<uint8_t>(6, 10)};
    EXPECT_THROW(tiles::psnrRgb(a, d), std::invalid_argument);
}

// Fast (stb_dxt) on the synthetic facades and on a photo-like image, RGB->BC1
// and RGBA->BC3, decoded by OpenImageIO.
TEST(TextureCodec, FastRoundTripThroughOiio) {
    TempDir tmp;
    struct Case {
        std::string name;
        Image8 image;
    };
    std::vector<Case> cases;
    cases.push_back({"facade_rgb", facade(42, false, 512)});
    cases.push_back({"facade_rgba", facade(1234, true, 512)});
    cases.push_back({"photo_rgb", photoLike(512, 512, 3, 7)});
    cases.push_back({"photo_rgba", photoLike(512, 512, 4, 8)});
    for (const Case& c : cases) {
        ASSERT_EQ(c.image.channels, c.name.find("rgba") != std::string::npos ? 4 : 3) << c.name;
        double alpha = 0;
        const auto t0 = std::chrono::steady_clock::now();
        const double p = roundTripPsnr(tmp.dir / (c.name + ".dds"), c.image, BcQuality::Fast, &alpha);
        const double s = seconds(t0);
        EXPECT_GE(p, 32.0) << c.name;
        RecordProperty("psnr_fast_" + c.name, fmtDouble(p));
        std::cout << "[fast] " << c.name << ": RGB PSNR " << fmtDouble(p) << " dB";
        if (c.image.channels == 4) {
            // BC3 alpha: 8-level interpolation inside each block's range.
            EXPECT_GE(alpha, 36.0) << c.name;
            RecordProperty("alpha_psnr_fast_" + c.name, fmtDouble(alpha));
            std::cout << ", alpha PSNR " << fmtDouble(alpha) << " dB";
        }
        std::cout << " (mip chain + encode + write + OIIO read " << fmtDouble(s) << " s)\n";
    }
}

// Best (squish cluster fit) is never worse than Fast by more than 0.05 dB and
// both speeds are reported; small images keep the slow encoder quick.
TEST(TextureCodec, BestAtLeastAsGoodAsFast) {
    TempDir tmp;
    struct Case {
        std::string name;
        Image8 image;
    };
    std::vector<Case> cases;
    cases.push_back({"photo_rgb", photoLike(128, 128, 3, 21)});
    cases.push_back({"photo_rgba", photoLike(128, 128, 4, 22)});
    cases.push_back({"facade_rgb", facade(7, false, 128)});
    for (const Case& c : cases) {
        double psnr[2] = {0, 0}, mps[2] = {0, 0};
        for (BcQuality q : {BcQuality::Fast, BcQuality::Best}) {
            const int qi = q == BcQuality::Fast ? 0 : 1;
            // Repeat the fast encode so the timer sees more than a fraction of a ms.
            const int reps = q == BcQuality::Fast ? 20 : 1;
            std::vector<uint8_t> blocks;
            const auto t0 = std::chrono::steady_clock::now();
            for (int i = 0; i < reps; ++i) blocks = tiles::encodeBc(c.image, q);
            const double s = seconds(t0) / reps;
            mps[qi] = double(c.image.width) * c.image.height / 1e6 / s;
            psnr[qi] = tiles::psnrRgb(c.image, tiles::decodeBc(blocks, c.image.width, c.image.height,
                                                               c.image.channels));
            // The same blocks through the DDS file and OIIO's decoder (which
            // rounds slightly differently: the PSNRs agree to ~0.1 dB).
            EXPECT_NEAR(roundTripPsnr(tmp.dir / (c.name + ".dds"), c.image, q), psnr[qi], 0.2) << c.name;
        }
        EXPECT_GE(psnr[1], psnr[0] - 0.05) << c.name;
        EXPECT_GE(psnr[0], 32.0) << c.name;
        RecordProperty("psnr_fast_" + c.name, fmtDouble(psnr[0]));
        RecordProperty("psnr_best_" + c.name, fmtDouble(psnr[1]));
        RecordProperty("mps_fast_" + c.name, fmtDouble(mps[0]));
        RecordProperty("mps_best_" + c.name, fmtDouble(mps[1]));
        std::cout << c.name << " " << c.image.width << "x" << c.image.height << ": fast " << fmtDouble(psnr[0])
                  << " dB at " << fmtDouble(mps[0]) << " MP/s, best " << fmtDouble(psnr[1]) << " dB at "
                  << fmtDouble(mps[1]) << " MP/s (" << tbb::this_task_arena::max_concurrency() << " threads)\n";
    }
}

// Every header field against the DDS_HEADER documentation, and the file size.
TEST(TextureCodec, DdsHeaderFields) {
    struct Case {
        Image8 base;
        bool chain;
    };
    const std::vector<Case> cases = {{photoLike(64, 32, 3, 1), true},
                                     {photoLike(1, 1, 4, 2), true},
                                     {photoLike(20, 12, 4, 3), false},
                                     {photoLike(37, 5, 3, 4), true}};
    for (const Case& c : cases) {
        const std::vector<Image8> mips = c.chain ? tiles::mipChain(c.base) : std::vector<Image8>{c.base};
        const std::vector<uint8_t> dds = tiles::encodeDds(mips, BcQuality::Fast);
        SCOPED_TRACE(std::to_string(c.base.width) + "x" + std::to_string(c.base.height) + "x" +
                     std::to_string(c.base.channels) + " levels " + std::to_string(mips.size()));
        ASSERT_GE(dds.size(), 128u);
        const size_t block = c.base.channels == 3 ? 8 : 16;
        size_t body = 0;
        for (const Image8& m : mips) body += size_t((m.width + 3) / 4) * size_t((m.height + 3) / 4) * block;
        EXPECT_EQ(dds.size(), 128 + body);

        EXPECT_EQ(std::string(dds.begin(), dds.begin() + 4), "DDS ");
        EXPECT_EQ(le32(dds, 4), 124u);                                     // dwSize
        EXPECT_EQ(le32(dds, 8), 0x1u | 0x2u | 0x4u | 0x1000u | 0x20000u | 0x80000u);  // dwFlags
        EXPECT_EQ(le32(dds, 12), uint32_t(c.base.height));                 // dwHeight
        EXPECT_EQ(le32(dds, 16), uint32_t(c.base.width));                  // dwWidth
        EXPECT_EQ(le32(dds, 20), uint32_t((c.base.width + 3) / 4 * ((c.base.height + 3) / 4) * int(block)));
        EXPECT_EQ(le32(dds, 24), 0u);                                      // dwDepth
        EXPECT_EQ(le32(dds, 28), uint32_t(mips.size()));                   // dwMipMapCount
        for (size_t off = 32; off < 76; off += 4) EXPECT_EQ(le32(dds, off), 0u) << "dwReserved1 at " << off;
        EXPECT_EQ(le32(dds, 76), 32u);                                     // ddspf.dwSize
        EXPECT_EQ(le32(dds, 80), 0x4u);                                    // DDPF_FOURCC
        EXPECT_EQ(std::string(dds.begin() + 84, dds.begin() + 88), c.base.channels == 3 ? "DXT1" : "DXT5");
        for (size_t off = 88; off < 108; off += 4) EXPECT_EQ(le32(dds, off), 0u) << "bit count / mask at " << off;
        const uint32_t caps = mips.size() > 1 ? 0x1000u | 0x400000u | 0x8u : 0x1000u;  // TEXTURE [|MIPMAP|COMPLEX]
        EXPECT_EQ(le32(dds, 108), caps);
        for (size_t off = 112; off < 128; off += 4) EXPECT_EQ(le32(dds, off), 0u) << "dwCaps2.. at " << off;

        // The levels follow in order, each exactly its encodeBc bytes.
        size_t off = 128;
        for (const Image8& m : mips) {
            const std::vector<uint8_t> blocks = tiles::encodeBc(m, BcQuality::Fast);
            ASSERT_LE(off + blocks.size(), dds.size());
            EXPECT_TRUE(std::equal(blocks.begin(), blocks.end(), dds.begin() + std::ptrdiff_t(off)));
            off += blocks.size();
        }
    }
}

// Sizes that are odd, not multiples of 4, or 1: block counts, edge padding by
// replication (and nothing of it in the decoded image), mip sizes, and OIIO.
TEST(TextureCodec, OddSizes) {
    TempDir tmp;
    struct Size {
        int w, h;
    };
    for (const Size sz : {Size{37, 5}, Size{1, 1}, Size{3, 300}, Size{5, 4}, Size{4, 4}, Size{6, 7}})
        for (int ch : {3, 4}) {
            SCOPED_TRACE(std::to_string(sz.w) + "x" + std::to_string(sz.h) + "x" + std::to_string(ch));
            const Image8 img = photoLike(sz.w, sz.h, ch, uint64_t(sz.w * 1000 + sz.h));
            const size_t blocks = size_t((sz.w + 3) / 4) * size_t((sz.h + 3) / 4);
            EXPECT_EQ(tiles::bcBlockBytes(sz.w, sz.h, ch), blocks * (ch == 3 ? 8 : 16));
            for (BcQuality q : {BcQuality::Fast, BcQuality::Best}) {
                const std::vector<uint8_t> enc = tiles::encodeBc(img, q);
                EXPECT_EQ(enc.size(), blocks * (ch == 3 ? 8u : 16u));
                // Partial blocks are the blocks of the image padded by repeating the
                // last row and column (the test's own padding): nothing else (zeros,
                // the next row, stale memory) gets into a block.
                EXPECT_EQ(enc, tiles::encodeBc(padToBlocks(img), q)) << tiles::bcQualityName(q);
                const Image8 dec = tiles::decodeBc(enc, sz.w, sz.h, ch);
                EXPECT_EQ(dec.width, sz.w);
                EXPECT_EQ(dec.height, sz.h);
                EXPECT_EQ(dec.channels, ch);
                ASSERT_EQ(dec.pixels.size(), img.pixels.size());
                // The valid region decodes close to the source.
                EXPECT_GE(tiles::psnrRgb(img, dec), 30.0) << tiles::bcQualityName(q);
            }
        }

    // One flat colour per 4x4 cell that BC1 stores exactly (565 endpoints):
    // with replication every edge block stays one colour, so the decoded
    // valid region is exact; a leak of other texels would add colours.
    {
        const int w = 37, h = 5;
        Image8 img{w, h, 3, std::vector<uint8_t>(size_t(w) * h * 3)};
        auto expand5 = [](int v) { return uint8_t(v << 3 | v >> 2); };
        auto expand6 = [](int v) { return uint8_t(v << 2 | v >> 4); };
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const int cell = (y / 4) * 16 + x / 4;
                uint8_t* p = &img.pixels[(size_t(y) * w + size_t(x)) * 3];
                p[0] = expand5((cell * 7) % 32);
                p[1] = expand6((cell * 13 + 5) % 64);
                p[2] = expand5((cell * 11 + 3) % 32);
            }
        for (BcQuality q : {BcQuality::Fast, BcQuality::Best}) {
            const Image8 dec = tiles::decodeBc(tiles::encodeBc(img, q), w, h, 3);
            EXPECT_EQ(dec.pixels, img.pixels) << tiles::bcQualityName(q);
        }
    }

    // Mip sizes: floor halving, at least 1, down to 1x1.
    auto sizes = [](int w, int h) {
        std::vector<std::pair<int, int>> s;
        for (const Image8& m : tiles::mipChain(photoLike(w, h, 3, 9))) s.emplace_back(m.width, m.height);
        return s;
    };
    using V = std::vector<std::pair<int, int>>;
    EXPECT_EQ(sizes(37, 5), (V{{37, 5}, {18, 2}, {9, 1}, {4, 1}, {2, 1}, {1, 1}}));
    EXPECT_EQ(sizes(1, 1), (V{{1, 1}}));
    EXPECT_EQ(sizes(3, 300), (V{{3, 300}, {1, 150}, {1, 75}, {1, 37}, {1, 18}, {1, 9}, {1, 4}, {1, 2}, {1, 1}}));

    // OIIO reads the odd chains with the same level sizes.
    for (const Size sz : {Size{37, 5}, Size{1, 1}, Size{3, 300}})
        for (int ch : {3, 4}) {
            SCOPED_TRACE(std::to_string(sz.w) + "x" + std::to_string(sz.h) + "x" + std::to_string(ch));
            const Image8 img = photoLike(sz.w, sz.h, ch, 77);
            const double p = roundTripPsnr(tmp.dir / "odd.dds", img, BcQuality::Fast);
            EXPECT_GE(p, 30.0);
        }
}

// The test's own sRGB transfer functions (IEC 61966-2-1), in double.
double srgbToLinear(uint8_t v) {
    const double c = v / 255.0;
    return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}
double linearToSrgbCode(double l) {
    const double c = l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1 / 2.4) - 0.055;
    return 255.0 * c;
}

// An independent premultiplied, linear-light box mean of `src` (footprints:
// pairs, the last one takes three texels on an odd axis).
Image8 referenceDownsample(const Image8& src) {
    const int ow = std::max(1, src.width / 2), oh = std::max(1, src.height / 2), ch = src.channels;
    Image8 out{ow, oh, ch, std::vector<uint8_t>(size_t(ow) * size_t(oh) * size_t(ch))};
    for (int oy = 0; oy < oh; ++oy)
        for (int ox = 0; ox < ow; ++ox) {
            const int x0 = 2 * ox, x1 = ox == ow - 1 ? src.width : 2 * ox + 2;
            const int y0 = 2 * oy, y1 = oy == oh - 1 ? src.height : 2 * oy + 2;
            double sum[3] = {0, 0, 0}, wsum[3] = {0, 0, 0}, asum = 0, n = 0;
            for (int y = y0; y < y1; ++y)
                for (int x = x0; x < x1; ++x) {
                    const uint8_t* p = &src.pixels[(size_t(y) * size_t(src.width) + size_t(x)) * size_t(ch)];
                    const double a = ch == 4 ? p[3] / 255.0 : 1.0;
                    for (int c = 0; c < 3; ++c) {
                        sum[c] += srgbToLinear(p[c]);
                        wsum[c] += srgbToLinear(p[c]) * a;
                    }
                    asum += a;
                    n += 1;
                }
            uint8_t* d = &out.pixels[(size_t(oy) * size_t(ow) + size_t(ox)) * size_t(ch)];
            for (int c = 0; c < 3; ++c)
                d[c] = clamp8(linearToSrgbCode(asum > 0 ? wsum[c] / asum : sum[c] / n));
            if (ch == 4) d[3] = clamp8(255.0 * asum / n);
        }
    return out;
}

void expectWithinOne(const Image8& got, const Image8& want, const std::string& what) {
    ASSERT_EQ(got.width, want.width) << what;
    ASSERT_EQ(got.height, want.height) << what;
    ASSERT_EQ(got.channels, want.channels) << what;
    for (size_t i = 0; i < got.pixels.size(); ++i)
        EXPECT_LE(std::abs(int(got.pixels[i]) - int(want.pixels[i])), 1)
            << what << " texel " << i / size_t(got.channels) << " channel " << i % size_t(got.channels);
}

TEST(TextureCodec, MipValuesAreLinearLightPremultipliedBoxMeans) {
    // 7x5 RGBA: odd on both axes (3-texel footprints), random alpha including
    // a fully transparent footprint (top-left 2x2) and opaque ones.
    Image8 img{7, 5, 4, std::vector<uint8_t>(7 * 5 * 4)};
    for (int y = 0; y < 5; ++y)
        for (int x = 0; x < 7; ++x) {
            uint8_t* p = &img.pixels[(size_t(y) * 7 + size_t(x)) * 4];
            for (int c = 0; c < 3; ++c) p[c] = uint8_t(mix(uint64_t(y * 7 + x) * 4 + uint64_t(c)) & 255);
            p[3] = uint8_t(mix(1000 + uint64_t(y * 7 + x)) & 255);
            if (x < 2 && y < 2) p[3] = 0;
            if (x >= 4 && y >= 2) p[3] = 255;
        }
    const std::vector<Image8> chain = tiles::mipChain(img);
    ASSERT_EQ(chain.size(), 3u);  // 7x5 -> 3x2 -> 1x1
    EXPECT_EQ(chain[0].pixels, img.pixels);
    expectWithinOne(chain[1], referenceDownsample(img), "level 1 (RGBA)");
    expectWithinOne(chain[2], referenceDownsample(chain[1]), "level 2 (RGBA)");
    EXPECT_EQ(chain[1].pixels[3], 0);  // the transparent footprint stays transparent

    // The same for RGB (no alpha weighting).
    Image8 rgb{7, 5, 3, {}};
    for (size_t i = 0; i < img.pixels.size(); i += 4) rgb.pixels.insert(rgb.pixels.end(), &img.pixels[i], &img.pixels[i + 3]);
    const std::vector<Image8> rgb_chain = tiles::mipChain(rgb);
    ASSERT_EQ(rgb_chain.size(), 3u);
    expectWithinOne(rgb_chain[1], referenceDownsample(rgb), "level 1 (RGB)");

    // Premultiplied: a transparent texel's colour does not bleed. 2x1 RGBA:
    // opaque red next to transparent blue -> red, alpha half.
    const Image8 bleed{2, 1, 4, {255, 0, 0, 255, 0, 0, 255, 0}};
    const Image8 b1 = tiles::mipChain(bleed)[1];
    EXPECT_EQ(b1.pixels, (std::vector<uint8_t>{255, 0, 0, 128}));

    // Black/white checkerboard: the linear mean of 0 and 255 is 0.5, code 188;
    // averaging the sRGB codes would give 128 (visibly too dark).
    Image8 checker{8, 8, 3, std::vector<uint8_t>(8 * 8 * 3)};
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x)
            for (int c = 0; c < 3; ++c) checker.pixels[(size_t(y) * 8 + size_t(x)) * 3 + size_t(c)] = (x + y) % 2 ? 255 : 0;
    const Image8 c1 = tiles::mipChain(checker)[1];
    const int naive = int(std::lround((0 + 255) / 2.0));
    EXPECT_EQ(naive, 128);
    EXPECT_EQ(int(std::lround(linearToSrgbCode(0.5))), 188);
    for (uint8_t v : c1.pixels) {
        EXPECT_EQ(v, 188);
        EXPECT_NE(v, naive);
    }
}

// BC1 is opaque: no block may use BC1's transparent index, even with black and
// dark texels (which tempt an encoder into the 3-colour mode); BC3 keeps alpha.
TEST(TextureCodec, Bc1OpaqueBc3KeepsAlpha) {
    TempDir tmp;
    Image8 rgb = photoLike(64, 64, 3, 31);
    for (int y = 0; y < 64; ++y)  // black, near-black and saturated texels
        for (int x = 0; x < 64; x += 3) {
            uint8_t* p = &rgb.pixels[(size_t(y) * 64 + size_t(x)) * 3];
            p[0] = uint8_t((x * 5) % 7);
            p[1] = 0;
            p[2] = uint8_t(y % 2 ? 0 : 255);
        }
    for (BcQuality q : {BcQuality::Fast, BcQuality::Best}) {
        const std::vector<uint8_t> enc = tiles::encodeBc(rgb, q);
        ASSERT_EQ(enc.size(), 16u * 16u * 8u);
        for (size_t b = 0; b < enc.size(); b += 8) {
            uint8_t out[64];
            squish::Decompress(out, &enc[b], squish::kDxt1);
            for (int i = 0; i < 16; ++i)
                ASSERT_EQ(out[i * 4 + 3], 255) << tiles::bcQualityName(q) << " block " << b / 8 << " texel " << i;
        }
        // OIIO too: alpha 255 and colours as squish decodes them (checked inside).
        // The black stripes make this image hard for BC1, so no PSNR bound here.
        roundTripPsnr(tmp.dir / "bc1.dds", rgb, q);
    }

    // BC3: alpha with hard steps and ramps comes back.
    Image8 rgba = photoLike(64, 64, 4, 32);
    for (int y = 0; y < 64; ++y)
        for (int x = 0; x < 64; ++x) rgba.pixels[(size_t(y) * 64 + size_t(x)) * 4 + 3] = x < 16 ? 0 : uint8_t(x * 4 - 1);
    for (BcQuality q : {BcQuality::Fast, BcQuality::Best}) {
        const Image8 dec = tiles::decodeBc(tiles::encodeBc(rgba, q), 64, 64, 4);
        int max_err = 0;
        for (size_t i = 3; i < dec.pixels.size(); i += 4)
            max_err = std::max(max_err, std::abs(int(dec.pixels[i]) - int(rgba.pixels[i])));
        // A 4-texel ramp of step 4 inside an 8-level block range: a couple of codes.
        EXPECT_LE(max_err, 3) << tiles::bcQualityName(q);
        EXPECT_EQ(dec.pixels[3], 0);  // transparent stays exactly transparent
        double alpha = 0;
        roundTripPsnr(tmp.dir / "bc3.dds", rgba, q, &alpha);
        EXPECT_GE(alpha, 40.0) << tiles::bcQualityName(q);
    }
}

TEST(TextureCodec, DeterministicForAnyThreadCount) {
    const Image8 big_rgb = photoLike(256, 192, 3, 51), big_rgba = photoLike(256, 192, 4, 52);
    const Image8 small_rgba = photoLike(64, 48, 4, 53);
    auto run = [&] {
        std::vector<std::vector<uint8_t>> out;
        out.push_back(tiles::encodeDds(tiles::mipChain(big_rgb), BcQuality::Fast));
        out.push_back(tiles::encodeDds(tiles::mipChain(big_rgba), BcQuality::Fast));
        out.push_back(tiles::encodeDds(tiles::mipChain(small_rgba), BcQuality::Best));
        return out;
    };
    const auto first = run();
    EXPECT_EQ(run(), first) << "second run";
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        EXPECT_EQ(run(), first) << "one thread";
    }
    {
        // More threads than this machine may have cores: the limit defaults to
        // the core count, so raise it for the arena to get its 4 threads.
        tbb::global_control four_limit(tbb::global_control::max_allowed_parallelism, 4);
        tbb::task_arena four(4);
        std::vector<std::vector<uint8_t>> four_out;
        four.execute([&] { four_out = run(); });
        EXPECT_EQ(four_out, first) << "four threads";
    }
}

TEST(TextureCodec, WriteDdsAtomicallyAndNamesTheFileOnError) {
    TempDir tmp;
    const std::vector<Image8> mips = tiles::mipChain(photoLike(40, 24, 4, 61));
    const fs::path path = tmp.dir / "t.dds";
    const cityatlas::Status ok = tiles::writeDds(path, mips, BcQuality::Fast);
    ASSERT_TRUE(ok.ok()) << ok.error;
    std::vector<uint8_t> bytes(fs::file_size(path));
    {
        std::FILE* f = std::fopen(path.c_str(), "rb");
        ASSERT_NE(f, nullptr);
        EXPECT_EQ(std::fread(bytes.data(), 1, bytes.size(), f), bytes.size());
        std::fclose(f);
    }
    EXPECT_EQ(bytes, tiles::encodeDds(mips, BcQuality::Fast));
    // Overwriting works and leaves only the file (no temporaries).
    ASSERT_TRUE(tiles::writeDds(path, mips, BcQuality::Fast).ok());
    size_t entries = 0;
    for (const auto& e : fs::directory_iterator(tmp.dir)) {
        ++entries;
        EXPECT_EQ(e.path().filename(), "t.dds");
    }
    EXPECT_EQ(entries, 1u);

    const fs::path bad = tmp.dir / "no_such_folder" / "x.dds";
    const cityatlas::Status st = tiles::writeDds(bad, mips, BcQuality::Fast);
    EXPECT_FALSE(st.ok());
    EXPECT_NE(st.error.find(bad.string()), std::string::npos) << st.error;
    EXPECT_FALSE(fs::exists(bad));
}

TEST(TextureCodec, RejectsMalformedInput) {
    const Image8 good = photoLike(8, 8, 3, 71);
    Image8 short_buffer = good;
    short_buffer.pixels.pop_back();
    EXPECT_THROW(tiles::encodeBc(short_buffer, BcQuality::Fast), std::invalid_argument);
    Image8 two{2, 2, 2, std::vector<uint8_t>(8)};
    EXPECT_THROW(tiles::mipChain(two), std::invalid_argument);
    EXPECT_THROW(tiles::encodeDds({}, BcQuality::Fast), std::invalid_argument);
    // Level sizes must halve: 8x8 then 8x8, or anything after 1x1, is rejected.
    EXPECT_THROW(tiles::encodeDds({good, good}, BcQuality::Fast), std::invalid_argument);
    std::vector<Image8> chain = tiles::mipChain(good);
    chain.push_back(chain.back());
    EXPECT_THROW(tiles::encodeDds(chain, BcQuality::Fast), std::invalid_argument);
    // Mixed channel counts.
    std::vector<Image8> mixed = tiles::mipChain(good);
    mixed[1] = tiles::mipChain(photoLike(8, 8, 4, 72))[1];
    EXPECT_THROW(tiles::encodeDds(mixed, BcQuality::Fast), std::invalid_argument);
    EXPECT_THROW(tiles::decodeBc(std::vector<uint8_t>(7), 4, 4, 3), std::invalid_argument);
}

// BC4 (one channel: a computed texture's scalar, issue 19). OpenImageIO's
// DDS reader is the independent decoder: it reads our DX10 header and every
// level, and its texels equal our decoder's exactly; against the source each
// block is within half an interpolation step of its range (stb picks the
// block's min and max as endpoints: 7 steps, so <= range / 14, +1 rounding);
// level 1 is the rounded plain mean of level 0 (linear values, no sRGB).
TEST(TextureCodec, Bc4RoundTripThroughOiioAndOurDecoder) {
    TempDir tmp;
    Image8 base{61, 45, 1, {}};
    std::mt19937_64 rng(5);
    std::uniform_int_distribution<int> noise(-6, 6);
    for (int y = 0; y < base.height; ++y)
        for (int x = 0; x < base.width; ++x) {
            const int v = x < 30 ? 4 * x + noise(rng) : (y % 9 < 4 ? 250 : 3);  // a ramp, then stripes
            base.pixels.push_back(uint8_t(std::clamp(v, 0, 255)));
        }
    const std::vector<Image8> mips = tiles::mipChain(base);
    ASSERT_EQ(mips[1].channels, 1);
    for (int y = 0; y < mips[1].height; ++y)
        for (int x = 0; x < mips[1].width; ++x) {
            if (x == mips[1].width - 1 || y == mips[1].height - 1) continue;  // the last of an odd axis takes 3 texels
            int sum = 0;
            for (int dy = 0; dy < 2; ++dy)
                for (int dx = 0; dx < 2; ++dx) sum += base.pixels[size_t(2 * y + dy) * size_t(base.width) + size_t(2 * x + dx)];
            ASSERT_EQ(mips[1].pixels[size_t(y) * size_t(mips[1].width) + size_t(x)], (2 * sum + 4) / 8) << x << "," << y;
        }
    const std::vector<uint8_t> dds = tiles::encodeDds(mips, BcQuality::Best);
    tiles::DdsInfo info;
    ASSERT_TRUE(tiles::parseDdsHeader(dds.data(), dds.size(), &info).ok());
    EXPECT_EQ(info.channels, 1);
    EXPECT_EQ(info.header_bytes, 148u);
    EXPECT_EQ(info.expected_bytes, dds.size());
    EXPECT_EQ(info.mips, int(mips.size()));
    const fs::path path = tmp.dir / "scalar.dds";
    ASSERT_TRUE(tiles::writeDds(path, mips, BcQuality::Fast).ok());
    const DdsRead oiio = readDds(path);
    ASSERT_EQ(oiio.levels.size(), mips.size());
    size_t offset = info.header_bytes;
    int exact = 0, compared = 0;
    for (size_t m = 0; m < mips.size(); ++m) {
        const Image8& src = mips[m];
        const size_t bytes = tiles::bcBlockBytes(src.width, src.height, 1);
        const Image8 ours = tiles::decodeBc(std::vector<uint8_t>(dds.begin() + std::ptrdiff_t(offset),
                                                                 dds.begin() + std::ptrdiff_t(offset + bytes)),
                                            src.width, src.height, 1);
        offset += bytes;
        ASSERT_EQ(oiio.levels[m].width, src.width);
        ASSERT_GE(oiio.levels[m].channels, 1);
        for (int y = 0; y < src.height; ++y)
            for (int x = 0; x < src.width; ++x) {
                const size_t i = size_t(y) * size_t(src.width) + size_t(x);
                // The format defines the interpolated values as fractions (e.g. (6 e0 + e1) / 7);
                // decoders round them to 8 bits differently (we round, OIIO truncates): 1 apart at most.
                const int theirs = oiio.levels[m].pixels[i * size_t(oiio.levels[m].channels)];
                ASSERT_LE(std::abs(theirs - int(ours.pixels[i])), 1) << "level " << m << " texel " << x << "," << y;
                exact += theirs == int(ours.pixels[i]) ? 1 : 0;
                ++compared;
                int lo = 255, hi = 0;  // the texel's 4x4 block range in the source
                for (int by = y / 4 * 4; by < std::min(src.height, y / 4 * 4 + 4); ++by)
                    for (int bx = x / 4 * 4; bx < std::min(src.width, x / 4 * 4 + 4); ++bx) {
                        lo = std::min<int>(lo, src.pixels[size_t(by) * size_t(src.width) + size_t(bx)]);
                        hi = std::max<int>(hi, src.pixels[size_t(by) * size_t(src.width) + size_t(bx)]);
                    }
                ASSERT_LE(std::abs(int(ours.pixels[i]) - int(src.pixels[i])), (hi - lo) / 14 + 1)
                    << "level " << m << " texel " << x << "," << y;
            }
    }
    EXPECT_EQ(offset, dds.size());
    std::cout << "BC4: " << exact << " of " << compared << " texels equal OIIO's decoding, the rest 1 apart\n";
    EXPECT_GT(exact, compared / 2);  // endpoints and exact fractions agree
    // The DX10 part is checked: cut off, another format, or an array.
    auto with = [&](size_t at, uint32_t value) {
        std::vector<uint8_t> b = dds;
        for (int i = 0; i < 4; ++i) b[at + size_t(i)] = uint8_t(value >> (8 * i));
        return b;
    };
    tiles::DdsInfo bad;
    EXPECT_NE(tiles::parseDdsHeader(dds.data(), 128, &bad).error.find("DX10"), std::string::npos);
    const std::vector<uint8_t> bc5 = with(128, 83), array = with(140, 2);
    EXPECT_NE(tiles::parseDdsHeader(bc5.data(), bc5.size(), &bad).error.find("BC4_UNORM"), std::string::npos);
    EXPECT_NE(tiles::parseDdsHeader(array.data(), array.size(), &bad).error.find("2D"), std::string::npos);
}

// parseDdsHeader reads back what encodeDds writes, for full and partial chains,
// from the header alone or the whole file.
TEST(TextureCodec, ParseDdsHeaderRoundTrip) {
    struct Case {
        Image8 base;
        bool chain;
    };
    const std::vector<Case> cases = {{photoLike(64, 64, 3, 81), true},
                                     {photoLike(64, 32, 4, 82), true},
                                     {photoLike(37, 5, 3, 83), true},
                                     {photoLike(1, 1, 4, 84), true},
                                     {photoLike(20, 12, 4, 85), false}};
    for (const Case& c : cases) {
        const std::vector<Image8> mips = c.chain ? tiles::mipChain(c.base) : std::vector<Image8>{c.base};
        const std::vector<uint8_t> dds = tiles::encodeDds(mips, BcQuality::Fast);
        SCOPED_TRACE(std::to_string(c.base.width) + "x" + std::to_string(c.base.height) + "x" +
                     std::to_string(c.base.channels));
        for (size_t size : {dds.size(), size_t{128}}) {
            tiles::DdsInfo info;
            const cityatlas::Status st = tiles::parseDdsHeader(dds.data(), size, &info);
            ASSERT_TRUE(st.ok()) << st.error;
            EXPECT_EQ(info.width, c.base.width);
            EXPECT_EQ(info.height, c.base.height);
            EXPECT_EQ(info.channels, c.base.channels);
            EXPECT_EQ(info.mips, int(mips.size()));
            EXPECT_EQ(info.expected_bytes, dds.size());
        }
    }
}

// Damaged headers fail with a reason and leave *out alone; short buffers are
// never read past their end (the copies below are exactly `size` bytes, so
// AddressSanitizer builds would catch an overread).
TEST(TextureCodec, ParseDdsHeaderRejectsDamage) {
    const std::vector<uint8_t> good = tiles::encodeDds(tiles::mipChain(photoLike(16, 16, 3, 91)), BcQuality::Fast);
    auto with = [&](size_t offset, uint32_t value) {
        std::vector<uint8_t> b = good;
        for (int i = 0; i < 4; ++i) b[offset + size_t(i)] = uint8_t(value >> (8 * i));
        return b;
    };
    auto expectFail = [](const std::vector<uint8_t>& b, const std::string& reason_part, const char* what) {
        tiles::DdsInfo info;
        info.width = -7;
        const cityatlas::Status st = tiles::parseDdsHeader(b.data(), b.size(), &info);
        EXPECT_FALSE(st.ok()) << what;
        EXPECT_NE(st.error.find(reason_part), std::string::npos) << what << ": " << st.error;
        EXPECT_EQ(info.width, -7) << what << ": *out changed on failure";
    };
    expectFail(with(0, 0x20534444u ^ 0xffu), "magic", "magic");
    expectFail(with(4, 128), "header size", "dwSize");
    expectFail(with(76, 31), "pixel format size", "ddspf.dwSize");
    expectFail(with(80, 0x40), "FourCC format", "DDPF_RGB instead of DDPF_FOURCC");
    expectFail(with(84, 0x33545844u), "FourCC", "DXT3");  // "DXT3"
    expectFail(with(12, 0), "out of range", "height 0");
    expectFail(with(16, 0), "out of range", "width 0");
    expectFail(with(16, 0x80000000u), "out of range", "width 2^31");
    expectFail(with(28, 6), "mip levels", "6 levels for 16x16");
    expectFail(with(28, 0xffffffffu), "mip levels", "2^32-1 levels");
    for (size_t size : {size_t{0}, size_t{3}, size_t{4}, size_t{127}})
        expectFail(std::vector<uint8_t>(good.begin(), good.begin() + std::ptrdiff_t(size)), "shorter", "truncated");
    tiles::DdsInfo info;
    EXPECT_FALSE(tiles::parseDdsHeader(nullptr, 128, &info).ok());
    // Mip count 0 is read as one level (DDSD_MIPMAPCOUNT readers treat it so).
    const std::vector<uint8_t> zero = with(28, 0);
    ASSERT_TRUE(tiles::parseDdsHeader(zero.data(), zero.size(), &info).ok());
    EXPECT_EQ(info.mips, 1);
    EXPECT_EQ(info.expected_bytes, 128u + 16u * 8u);
    // Random headers behind a valid magic never crash and never claim more than the full chain.
    uint64_t seed = 1;
    for (int i = 0; i < 2000; ++i) {
        std::vector<uint8_t> b(128);
        for (uint8_t& v : b) v = uint8_t(mix(seed++));
        std::copy(good.begin(), good.begin() + 4, b.begin());
        if (i % 2) std::copy(good.begin() + 76, good.begin() + 88, b.begin() + 76);
        tiles::DdsInfo r;
        if (tiles::parseDdsHeader(b.data(), b.size(), &r).ok()) {
            EXPECT_GE(r.width, 1);
            EXPECT_GE(r.height, 1);
            EXPECT_GE(r.mips, 1);
            EXPECT_GT(r.expected_bytes, 128u);
        }
    }
}

}  // namespace
