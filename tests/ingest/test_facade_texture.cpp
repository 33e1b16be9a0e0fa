// SPDX-License-Identifier: GPL-3.0-or-later
//
// Tests for the synthetic facade / paving textures. The number-reading tests decode the
// digits from the pixels alone (plate colour, ink colour, font from digitGlyph), the way a
// render check would, so they fail if the number is covered, clipped, mis-scaled or garbled.

#include "ingest/synth/facade_texture.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

namespace cs = cityatlas::synth;
namespace fs = std::filesystem;

namespace {

const uint8_t* px(const cs::Image8& img, int x, int y) {
    return img.pixels.data() + (static_cast<size_t>(y) * img.width + x) * img.channels;
}
bool isRgb(const cs::Image8& img, int x, int y, uint8_t v) {
    const uint8_t* p = px(img, x, y);
    return p[0] == v && p[1] == v && p[2] == v;
}

struct Box {
    int x0 = 0, y0 = 0, x1 = -1, y1 = -1;  // inclusive; empty when x1 < x0
    bool empty() const { return x1 < x0; }
    void add(int x, int y) {
        if (empty()) { x0 = x1 = x; y0 = y1 = y; return; }
        x0 = std::min(x0, x); x1 = std::max(x1, x); y0 = std::min(y0, y); y1 = std::max(y1, y);
    }
};

// What a reader sees on the facade: the plate, the ink, the font scale and the text.
struct Reading {
    std::string text;     // decoded digits; "" if no plate/ink, '?' for an unknown glyph
    std::string problem;  // why decoding failed, for test messages
    Box plate, ink;
    int scale = 0;
};

// Decodes the number: the plate is the box of pure white pixels, the ink the pure black
// pixels inside it. Ink height = 7 cells gives the cell size; columns with ink form one run
// per digit (every glyph touches all its 5 columns), and each run's 5x7 cell centres are
// sampled and matched against digitGlyph.
Reading readNumber(const cs::Image8& img) {
    Reading r;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            if (isRgb(img, x, y, 255)) r.plate.add(x, y);
    if (r.plate.empty()) { r.problem = "no plate"; return r; }
    // Ink colour elsewhere would make the plate ambiguous for a render check.
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            if (isRgb(img, x, y, 0) && (x < r.plate.x0 || x > r.plate.x1 || y < r.plate.y0 || y > r.plate.y1)) {
                r.problem = "ink colour outside the plate at " + std::to_string(x) + "," + std::to_string(y);
                return r;
            }

    std::vector<bool> colInk(static_cast<size_t>(img.width), false);
    long whiteOrInk = 0;
    for (int y = r.plate.y0; y <= r.plate.y1; ++y)
        for (int x = r.plate.x0; x <= r.plate.x1; ++x) {
            if (isRgb(img, x, y, 0)) { r.ink.add(x, y); colInk[static_cast<size_t>(x)] = true; ++whiteOrInk; }
            else if (isRgb(img, x, y, 255)) ++whiteOrInk;
        }
    if (r.ink.empty()) { r.problem = "no ink on the plate"; return r; }
    const long plateArea = long(r.plate.x1 - r.plate.x0 + 1) * (r.plate.y1 - r.plate.y0 + 1);
    if (whiteOrInk != plateArea) { r.problem = "plate is not a solid white/black rectangle"; return r; }

    const int inkH = r.ink.y1 - r.ink.y0 + 1;
    if (inkH % 7 != 0) { r.problem = "ink height not a multiple of 7"; return r; }
    r.scale = inkH / 7;
    const int s = r.scale;

    for (int x = r.plate.x0; x <= r.plate.x1;) {
        if (!colInk[static_cast<size_t>(x)]) { ++x; continue; }
        int end = x;
        while (end <= r.plate.x1 && colInk[static_cast<size_t>(end)]) ++end;
        if (end - x != 5 * s) { r.problem = "ink run of width " + std::to_string(end - x); return r; }
        std::array<uint8_t, 7> glyph{};
        for (int row = 0; row < 7; ++row)
            for (int c = 0; c < 5; ++c)
                if (isRgb(img, x + c * s + s / 2, r.ink.y0 + row * s + s / 2, 0)) glyph[row] |= uint8_t(0x10 >> c);
        char found = '?';
        for (char d = '0'; d <= '9'; ++d)
            if (cs::digitGlyph(d) == glyph) found = d;
        r.text += found;
        x = end;
    }
    return r;
}

cs::FacadeStyle style(uint32_t number, uint64_t seed = 1, int storeys = 3, int columns = 3, bool glass = false) {
    cs::FacadeStyle s;
    s.building_number = number;
    s.seed = seed;
    s.storeys = storeys;
    s.window_columns = columns;
    s.transparent_glass = glass;
    return s;
}

}  // namespace

// ---------------------------------------------------------------------------------------
// Font

TEST(DigitGlyph, TenDistinctGlyphsThatFillTheirFiveBySevenBox) {
    std::set<std::array<uint8_t, 7>> seen;
    for (char d = '0'; d <= '9'; ++d) {
        const auto g = cs::digitGlyph(d);
        uint8_t columns = 0;
        for (uint8_t row : g) {
            EXPECT_EQ(row & ~0x1F, 0) << d << ": bits outside the 5 columns";
            EXPECT_NE(row, 0) << d << ": empty row (the ink box would not be 7 cells high)";
            columns |= row;
        }
        EXPECT_EQ(columns, 0x1F) << d << ": empty column (digit runs would be narrower than 5 cells)";
        seen.insert(g);
    }
    EXPECT_EQ(seen.size(), 10u);
}

TEST(DigitGlyph, NonDigitsAreBlank) {
    for (char c : {' ', 'a', '/', ':', '\0'}) EXPECT_EQ(cs::digitGlyph(c), (std::array<uint8_t, 7>{}));
}

// ---------------------------------------------------------------------------------------
// Facade: determinism and variety

TEST(DrawFacade, SameStyleAndSizeGiveIdenticalBytes) {
    const auto s = style(1234, 99, 5, 4, true);
    EXPECT_EQ(cs::drawFacade(s, 256, 320).pixels, cs::drawFacade(s, 256, 320).pixels);
}

TEST(DrawFacade, DifferentNumbersGiveDifferentImages) {
    EXPECT_NE(cs::drawFacade(style(41), 128, 128).pixels, cs::drawFacade(style(42), 128, 128).pixels);
}

TEST(DrawFacade, DifferentSeedsGiveDifferentLooks) {
    EXPECT_NE(cs::drawFacade(style(42, 1), 128, 128).pixels, cs::drawFacade(style(42, 2), 128, 128).pixels);
}

TEST(DrawFacade, HasRequestedSizeAndChannels) {
    const auto rgb = cs::drawFacade(style(5), 200, 120);
    EXPECT_EQ(rgb.width, 200);
    EXPECT_EQ(rgb.height, 120);
    EXPECT_EQ(rgb.channels, 3);
    EXPECT_EQ(rgb.pixels.size(), 200u * 120u * 3u);
    const auto rgba = cs::drawFacade(style(5, 1, 3, 3, true), 200, 120);
    EXPECT_EQ(rgba.channels, 4);
    EXPECT_EQ(rgba.pixels.size(), 200u * 120u * 4u);
}

TEST(DrawFacade, RejectsSizesBelowSixteenAndEmptyGrids) {
    EXPECT_THROW(cs::drawFacade(style(1), 15, 64), std::invalid_argument);
    EXPECT_THROW(cs::drawFacade(style(1), 64, 15), std::invalid_argument);
    EXPECT_THROW(cs::drawFacade(style(1, 1, 0, 3), 64, 64), std::invalid_argument);
    EXPECT_THROW(cs::drawFacade(style(1, 1, 3, 0), 64, 64), std::invalid_argument);
}

TEST(DrawFacade, ExtremeGridsStillDrawTheNumber) {
    // Storeys/columns too many to draw degrade to plain wall instead of failing or hanging.
    for (auto s : {style(77, 1, 1000000000, 3), style(77, 1, 3, 1000000000), style(77, 1, 40, 40)}) {
        const auto r = readNumber(cs::drawFacade(s, 128, 128));
        EXPECT_EQ(r.text, "77") << r.problem;
    }
}

// ---------------------------------------------------------------------------------------
// Facade: the number is readable

TEST(DrawFacade, NumberDecodesAtSupportedSizes) {
    const uint32_t numbers[] = {0, 1, 7, 42, 1234, 999999, 1234567890};
    const std::pair<int, int> sizes[] = {{64, 64}, {128, 128}, {512, 512}, {96, 200}, {300, 100}, {1024, 256}};
    for (uint32_t n : numbers)
        for (auto [w, h] : sizes) {
            const std::string want = std::to_string(n);
            if (static_cast<int>(6 * want.size() + 3) > w) continue;  // documented: does not fit
            const auto r = readNumber(cs::drawFacade(style(n, n + 11), w, h));
            EXPECT_EQ(r.text, want) << w << "x" << h << ": " << r.problem;
        }
}

TEST(DrawFacade, NumberDecodesForManyStylesIncludingTransparentGlass) {
    // Windows, doors and walls must never produce plate-white or ink-black pixels, and
    // nothing may cover the plate, whatever the seed picks.
    for (uint64_t seed = 0; seed < 60; ++seed) {
        const uint32_t n = static_cast<uint32_t>(seed * 7919 % 1000000);
        const auto s = style(n, seed, 1 + int(seed % 9), 1 + int(seed % 6), seed % 2 == 0);
        const auto r = readNumber(cs::drawFacade(s, 128, 160));
        EXPECT_EQ(r.text, std::to_string(n)) << "seed " << seed << ": " << r.problem;
    }
}

TEST(DrawFacade, EvenTinyTexturesCarryTheNumberWhenItFits) {
    EXPECT_EQ(readNumber(cs::drawFacade(style(7), 16, 16)).text, "7");
    EXPECT_EQ(readNumber(cs::drawFacade(style(42), 16, 16)).text, "42");
    EXPECT_EQ(readNumber(cs::drawFacade(style(123456), 39, 16)).text, "123456");
    // Too long to fit: clipped, but the image is still well formed.
    const auto img = cs::drawFacade(style(4294967295u), 16, 16);
    EXPECT_EQ(img.pixels.size(), 16u * 16u * 3u);
}

TEST(DrawFacade, DigitsAreLargeCentredAndInTheUpperHalf) {
    for (int size : {64, 128, 512})
        for (uint32_t n : {1u, 42u, 1234u}) {
            const auto r = readNumber(cs::drawFacade(style(n), size, size));
            ASSERT_EQ(r.text, std::to_string(n)) << r.problem;
            const double digitHeight = double(r.ink.y1 - r.ink.y0 + 1) / size;
            EXPECT_GE(digitHeight, 0.20) << size;
            EXPECT_LE(digitHeight, 0.25) << size;
            EXPECT_LE(std::abs((r.plate.x0 + r.plate.x1 + 1) - size), 1) << "plate not centred";
            const int centreY = (r.plate.y0 + r.plate.y1) / 2;
            EXPECT_GE(centreY, size / 8);
            EXPECT_LE(centreY, size / 2);
        }
}

TEST(DrawFacade, LongNumbersShrinkToFitTheWidthWithMargins) {
    const auto r = readNumber(cs::drawFacade(style(999999), 128, 512));
    ASSERT_EQ(r.text, "999999") << r.problem;
    EXPECT_GT(r.plate.x0, 0);
    EXPECT_LT(r.plate.x1, 127);
    EXPECT_LT(r.ink.y1 - r.ink.y0 + 1, 512 / 5);  // shrunk below the nominal height
}

TEST(DrawFacade, FontCellsAreAtLeastTwoPixelsFromTheDocumentedLegibleSize) {
    // Header: numbers of up to 6 digits get >= 2 px cells from 78 x 63 upwards.
    for (auto [w, h] : {std::pair{78, 63}, std::pair{128, 128}, std::pair{512, 512}, std::pair{80, 400}}) {
        const auto r = readNumber(cs::drawFacade(style(888888), w, h));
        ASSERT_EQ(r.text, "888888") << r.problem;
        EXPECT_GE(r.scale, 2) << w << "x" << h;
    }
    EXPECT_GE(readNumber(cs::drawFacade(style(888888), 128, 128)).scale, 3);
}

// ---------------------------------------------------------------------------------------
// Facade: transparency

TEST(DrawFacade, TransparentGlassHasTranslucentPanesAndAnOpaquePlate) {
    const auto img = cs::drawFacade(style(2024, 4, 4, 4, true), 256, 256);
    ASSERT_EQ(img.channels, 4);
    long translucent = 0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const uint8_t a = px(img, x, y)[3];
            EXPECT_TRUE(a == 255 || a <= 100) << "alpha " << int(a) << " at " << x << "," << y;
            if (a < 128) ++translucent;
        }
    EXPECT_GT(translucent, img.width * img.height / 100);  // at least 1% of the facade is glass

    const auto r = readNumber(img);
    ASSERT_EQ(r.text, "2024") << r.problem;
    for (int y = r.plate.y0; y <= r.plate.y1; ++y)
        for (int x = r.plate.x0; x <= r.plate.x1; ++x) ASSERT_EQ(px(img, x, y)[3], 255) << x << "," << y;
}

TEST(DrawFacade, TransparentGlassOnlyAddsAlpha) {
    // Same look either way: the colour channels of the RGBA facade equal the RGB facade.
    const auto rgb = cs::drawFacade(style(31, 8, 3, 3, false), 96, 96);
    const auto rgba = cs::drawFacade(style(31, 8, 3, 3, true), 96, 96);
    ASSERT_EQ(rgb.channels, 3);
    for (int y = 0; y < 96; ++y)
        for (int x = 0; x < 96; ++x)
            for (int c = 0; c < 3; ++c) ASSERT_EQ(px(rgb, x, y)[c], px(rgba, x, y)[c]);
}

// ---------------------------------------------------------------------------------------
// Paving

namespace {
// Mean absolute difference between two columns (or rows when `rows`) over all channels.
double lineDiff(const cs::Image8& img, int a, int b, bool rows) {
    const int n = rows ? img.width : img.height;
    long sum = 0;
    for (int i = 0; i < n; ++i) {
        const uint8_t* p = rows ? px(img, i, a) : px(img, a, i);
        const uint8_t* q = rows ? px(img, i, b) : px(img, b, i);
        for (int c = 0; c < img.channels; ++c) sum += std::abs(int(p[c]) - int(q[c]));
    }
    return double(sum) / (n * img.channels);
}

// Seam criterion: stepping across the wrap (last line -> first line) must change the image
// no more than a typical step inside the tile (the median adjacent-line difference). A
// seam shows up as a step far above the typical one; the median ignores the few genuine
// slab/joint edges inside the tile.
bool wrapsSeamlessly(const cs::Image8& img, bool rows, std::string* why) {
    const int n = rows ? img.height : img.width;
    std::vector<double> steps;
    for (int i = 0; i + 1 < n; ++i) steps.push_back(lineDiff(img, i, i + 1, rows));
    std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
    const double median = steps[steps.size() / 2];
    const double wrap = lineDiff(img, n - 1, 0, rows);
    *why = "wrap step " + std::to_string(wrap) + " vs median step " + std::to_string(median);
    return wrap <= median;
}
}  // namespace

TEST(DrawPaving, TilesSeamlesslyInBothDirections) {
    for (int size : {16, 100, 256, 512})
        for (uint64_t seed : {0u, 1u, 17u}) {
            const auto img = cs::drawPaving(size, seed);
            ASSERT_EQ(img.width, size);
            ASSERT_EQ(img.height, size);
            ASSERT_EQ(img.channels, 3);
            std::string why;
            EXPECT_TRUE(wrapsSeamlessly(img, false, &why)) << size << " columns: " << why;
            EXPECT_TRUE(wrapsSeamlessly(img, true, &why)) << size << " rows: " << why;
        }
}

TEST(DrawPaving, SeamCriterionDetectsACutThroughASlab) {
    // Negative control: cropping the tile to 7/8 of its width puts the wrap in mid-slab,
    // a visible seam that the criterion must catch.
    const auto full = cs::drawPaving(256, 3);
    cs::Image8 crop;
    crop.width = 224;
    crop.height = 256;
    crop.channels = 3;
    for (int y = 0; y < 256; ++y)
        crop.pixels.insert(crop.pixels.end(), px(full, 0, y), px(full, 0, y) + 224 * 3);
    std::string why;
    EXPECT_FALSE(wrapsSeamlessly(crop, false, &why)) << why;
}

TEST(DrawPaving, HasSlabsAndJointsNotAFlatColour) {
    const auto img = cs::drawPaving(256, 9);
    std::set<uint32_t> colours;
    int darkest = 255, brightest = 0;
    for (int y = 0; y < 256; ++y)
        for (int x = 0; x < 256; ++x) {
            const uint8_t* p = px(img, x, y);
            colours.insert(uint32_t(p[0]) << 16 | uint32_t(p[1]) << 8 | p[2]);
            darkest = std::min(darkest, int(p[0]));
            brightest = std::max(brightest, int(p[0]));
        }
    EXPECT_GT(colours.size(), 20u);
    EXPECT_GT(brightest - darkest, 40) << "joints should contrast with the slabs";
}

TEST(DrawPaving, DeterministicPerSizeAndSeed) {
    EXPECT_EQ(cs::drawPaving(128, 4).pixels, cs::drawPaving(128, 4).pixels);
    EXPECT_NE(cs::drawPaving(128, 4).pixels, cs::drawPaving(128, 5).pixels);
    EXPECT_THROW(cs::drawPaving(15, 0), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------
// PNG writing

class WritePng : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() /
               ("cityatlas_facade_" + std::to_string(::getpid()) + "_" +
                ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }

    static std::vector<uint8_t> fileBytes(const fs::path& p) {
        std::ifstream in(p, std::ios::binary);
        return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    }

    // Reads back with OIIO, keeping straight alpha as stored (no premultiplication).
    static cs::Image8 readBack(const fs::path& p) {
        OIIO::ImageSpec config;
        config.attribute("oiio:UnassociatedAlpha", 1);
        auto in = OIIO::ImageInput::open(p.string(), &config);
        EXPECT_TRUE(in) << OIIO::geterror();
        cs::Image8 img;
        if (!in) return img;
        const auto& spec = in->spec();
        img.width = spec.width;
        img.height = spec.height;
        img.channels = spec.nchannels;
        img.pixels.resize(size_t(img.width) * img.height * img.channels);
        EXPECT_TRUE(in->read_image(0, 0, 0, img.channels, OIIO::TypeDesc::UINT8, img.pixels.data()))
            << in->geterror();
        in->close();
        return img;
    }

    fs::path dir_;
};

TEST_F(WritePng, RoundTripGivesIdenticalPixelsForRgbAndRgba) {
    for (bool glass : {false, true}) {
        const auto img = cs::drawFacade(style(321, 5, 3, 3, glass), 160, 120);
        const fs::path p = dir_ / (glass ? "rgba.png" : "rgb.png");
        std::string err;
        ASSERT_TRUE(cs::writePng(p.string(), img, &err)) << err;
        const auto back = readBack(p);
        EXPECT_EQ(back.width, img.width);
        EXPECT_EQ(back.height, img.height);
        EXPECT_EQ(back.channels, img.channels);
        EXPECT_TRUE(back.pixels == img.pixels) << (glass ? "RGBA" : "RGB") << " pixels changed";
    }
}

TEST_F(WritePng, WritingTwiceGivesByteIdenticalFilesWithoutTimestamps) {
    const auto img = cs::drawFacade(style(8, 2, 2, 2, true), 128, 128);
    std::string err;
    ASSERT_TRUE(cs::writePng((dir_ / "a.png").string(), img, &err)) << err;
    ASSERT_TRUE(cs::writePng((dir_ / "b.png").string(), img, &err)) << err;
    const auto a = fileBytes(dir_ / "a.png");
    ASSERT_GT(a.size(), 8u);
    EXPECT_EQ(a, fileBytes(dir_ / "b.png"));

    // Within one second identical timestamps would not show, so also check the chunks:
    // no time or text (Software/DateTime) chunks at all.
    for (size_t pos = 8; pos + 8 <= a.size();) {
        const uint32_t len = uint32_t(a[pos]) << 24 | uint32_t(a[pos + 1]) << 16 | uint32_t(a[pos + 2]) << 8 | a[pos + 3];
        const std::string type(a.begin() + long(pos) + 4, a.begin() + long(pos) + 8);
        EXPECT_NE(type, "tIME");
        EXPECT_NE(type, "tEXt") << "text metadata";
        EXPECT_NE(type, "zTXt") << "text metadata";
        EXPECT_NE(type, "iTXt") << "text metadata";
        pos += 12 + size_t(len);
    }
}

TEST_F(WritePng, A512FacadeIsCompressed) {
    const auto img = cs::drawFacade(style(4711, 1, 6, 4), 512, 512);
    std::string err;
    ASSERT_TRUE(cs::writePng((dir_ / "f.png").string(), img, &err)) << err;
    EXPECT_LT(fs::file_size(dir_ / "f.png"), img.pixels.size() / 4);
}

TEST_F(WritePng, MissingDirectoryFailsWithAMessageNamingThePath) {
    const std::string path = (dir_ / "no_such_dir" / "f.png").string();
    std::string err;
    EXPECT_FALSE(cs::writePng(path, cs::drawPaving(32, 1), &err));
    EXPECT_NE(err.find(path), std::string::npos) << err;
    EXPECT_EQ(err.find('\n'), std::string::npos) << "error must be one line: " << err;
    EXPECT_FALSE(fs::exists(path));
    EXPECT_FALSE(cs::writePng(path, cs::drawPaving(32, 1), nullptr));  // null error is allowed
}

TEST_F(WritePng, RejectsAnInconsistentImage) {
    cs::Image8 bad;
    bad.width = 4;
    bad.height = 4;
    bad.channels = 3;
    bad.pixels.resize(10);
    std::string err;
    const std::string path = (dir_ / "bad.png").string();
    EXPECT_FALSE(cs::writePng(path, bad, &err));
    EXPECT_NE(err.find(path), std::string::npos) << err;
    EXPECT_FALSE(fs::exists(path));
}
