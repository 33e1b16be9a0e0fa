// SPDX-License-Identifier: GPL-3.0-or-later
//
// Procedural facade and paving textures for synthetic towns; see facade_texture.h for the
// layout and the number-plate contract.
//
// Everything is drawn with axis-aligned rectangle fills in integer arithmetic: it is fast
// (thousands of textures per run) and bit-for-bit reproducible, which the fixtures need
// because expected renders and checksums are compared across machines.

#include "ingest/synth/facade_texture.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cstdio>
#include <stdexcept>

namespace cityatlas::synth {
namespace {

constexpr int kMinSize = 16;
constexpr int kMaxSize = 16384;  // keeps width*height*channels far below INT_MAX

// ---------------------------------------------------------------------------------------
// Deterministic hashing. splitmix64 is tiny, well mixed and defined purely by integer
// operations, unlike std:: distributions whose output differs between standard libraries.

uint64_t splitmix64(uint64_t x) {
    x += 0x9E3779B97F4A7C15ULL;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
    return x ^ (x >> 31);
}

uint64_t hash(uint64_t a, uint64_t b) { return splitmix64(a ^ splitmix64(b)); }
uint64_t hash(uint64_t a, uint64_t b, uint64_t c) { return hash(hash(a, b), c); }

// Sequential generator for per-building choices (palette, proportions).
struct Rng {
    uint64_t state;
    uint64_t next() { return splitmix64(state++); }
    // Uniform-enough integer in [lo, hi] (modulo bias is irrelevant for textures).
    int range(int lo, int hi) { return lo + static_cast<int>(next() % static_cast<uint64_t>(hi - lo + 1)); }
};

// ---------------------------------------------------------------------------------------
// Colours. Everything except the plate and the digits is clamped to 8..247 so that the
// pure white plate and pure black digits stay unique on the facade (see the header).

struct Rgba {
    uint8_t r, g, b, a;
};

constexpr Rgba kPlateWhite{255, 255, 255, 255};
constexpr Rgba kDigitBlack{0, 0, 0, 255};
constexpr Rgba kPlateBorder{28, 32, 58, 255};

uint8_t clampWall(int v) { return static_cast<uint8_t>(std::clamp(v, 8, 247)); }

Rgba shade(Rgba c, int delta) {
    return {clampWall(c.r + delta), clampWall(c.g + delta), clampWall(c.b + delta), c.a};
}

// Luminance jitter of +-amount plus a faint +-2 tint per channel, driven by hash bits;
// looks like natural variation between bricks/slabs instead of coloured confetti.
Rgba jitter(Rgba c, int amount, uint64_t h) {
    const int d = static_cast<int>(h % static_cast<uint64_t>(2 * amount + 1)) - amount;
    const int tr = static_cast<int>((h >> 20) % 5) - 2;
    const int tg = static_cast<int>((h >> 28) % 5) - 2;
    const int tb = static_cast<int>((h >> 36) % 5) - 2;
    return {clampWall(c.r + d + tr), clampWall(c.g + d + tg), clampWall(c.b + d + tb), c.a};
}

Rgba pick(const Rgba* palette, int count, Rng& rng) { return palette[rng.range(0, count - 1)]; }

// Palette entry plus jitter. Deliberately two statements: both steps draw from rng and the
// evaluation order of function arguments is unspecified (GCC and Clang differ), so
// `jitter(pick(p, n, rng), a, rng.next())` would give compiler-dependent images.
Rgba pickJittered(const Rgba* palette, int count, int amount, Rng& rng) {
    const Rgba base = pick(palette, count, rng);
    return jitter(base, amount, rng.next());
}

constexpr Rgba kWallPalette[] = {
    {150, 72, 56, 255},   // red brick
    {198, 180, 142, 255}, // sandstone
    {150, 150, 146, 255}, // concrete grey
    {190, 150, 84, 255},  // ochre
    {160, 178, 198, 255}, // pale blue plaster
    {140, 160, 128, 255}, // sage
    {122, 92, 72, 255},   // brown
    {222, 212, 186, 255}, // cream
};
constexpr Rgba kGlassPalette[] = {
    {40, 62, 92, 255}, {48, 90, 100, 255}, {70, 76, 82, 255}, {58, 88, 70, 255}, {84, 100, 130, 255},
};
constexpr Rgba kLitGlass{214, 184, 112, 255};
constexpr Rgba kFramePalette[] = {
    {232, 230, 222, 255}, {52, 52, 58, 255}, {102, 72, 50, 255}, {50, 82, 62, 255}, {150, 40, 36, 255},
};
constexpr Rgba kDoorPalette[] = {
    {110, 70, 40, 255}, {40, 80, 60, 255}, {130, 40, 40, 255}, {40, 60, 110, 255}, {70, 70, 74, 255},
};
constexpr Rgba kPavingPalette[] = {
    {150, 150, 148, 255}, // granite grey
    {190, 176, 146, 255}, // sandstone
    {160, 102, 86, 255},  // red concrete
    {112, 116, 126, 255}, // basalt
    {200, 190, 170, 255}, // beige
};

// ---------------------------------------------------------------------------------------
// Rectangle painting with clipping: the only drawing primitive, so "never draw outside
// the image" is guaranteed in one place.

class Canvas {
public:
    explicit Canvas(Image8& image, FacadeTruth* truth = nullptr) : img_(image), truth_(truth) {}

    // What the following fills draw (only recorded when a truth is kept).
    void part(FacadePart p) { part_ = p; }

    // Fills [x0,x1) x [y0,y1), clipped to the image. Alpha is written only for RGBA.
    void fill(int x0, int y0, int x1, int y1, Rgba c) {
        if (!clip(x0, y0, x1, y1)) return;
        const int ch = img_.channels;
        label(x0, y0, x1, y1);
        for (int y = y0; y < y1; ++y) {
            uint8_t* p = row(y) + static_cast<size_t>(x0) * ch;
            if (ch == 4) {
                for (int x = x0; x < x1; ++x, p += 4) {
                    p[0] = c.r; p[1] = c.g; p[2] = c.b; p[3] = c.a;
                }
            } else {
                for (int x = x0; x < x1; ++x, p += 3) {
                    p[0] = c.r; p[1] = c.g; p[2] = c.b;
                }
            }
        }
    }

    // Adds delta to the colour channels (not alpha) in a rectangle: bevels and shading.
    void brighten(int x0, int y0, int x1, int y1, int delta) {
        if (!clip(x0, y0, x1, y1)) return;
        const int ch = img_.channels;
        label(x0, y0, x1, y1);
        for (int y = y0; y < y1; ++y) {
            uint8_t* p = row(y) + static_cast<size_t>(x0) * ch;
            for (int x = x0; x < x1; ++x, p += ch)
                for (int k = 0; k < 3; ++k) p[k] = clampWall(p[k] + delta);
        }
    }

    uint8_t* row(int y) { return img_.pixels.data() + static_cast<size_t>(y) * img_.width * img_.channels; }

private:
    void label(int x0, int y0, int x1, int y1) {
        if (!truth_) return;
        for (int y = y0; y < y1; ++y)
            std::fill_n(truth_->part.begin() + static_cast<ptrdiff_t>(y) * img_.width + x0, x1 - x0, part_);
    }
    bool clip(int& x0, int& y0, int& x1, int& y1) const {
        x0 = std::max(x0, 0);
        y0 = std::max(y0, 0);
        x1 = std::min(x1, img_.width);
        y1 = std::min(y1, img_.height);
        return x0 < x1 && y0 < y1;
    }
    Image8& img_;
    FacadeTruth* truth_;
    FacadePart part_ = FacadePart::Wall;
};

Image8 makeImage(int width, int height, int channels) {
    Image8 img;
    img.width = width;
    img.height = height;
    img.channels = channels;
    img.pixels.assign(static_cast<size_t>(width) * height * channels, 255);
    return img;
}

void checkSize(int v, const char* what) {
    if (v < kMinSize || v > kMaxSize)
        throw std::invalid_argument(std::string(what) + " must be in 16..16384, got " + std::to_string(v));
}

// ---------------------------------------------------------------------------------------
// Facade parts.

// Courses of blocks in running bond; the block size picks brick, ashlar or panels.
// Mortar is drawn first as the background, blocks on top, so joints are exact.
void drawWall(Canvas& cv, int w, int h, Rgba base, int kind, uint64_t seed) {
    int course, blockW, mortar, amount;
    bool runningBond = true;
    switch (kind) {
    case 0:  // brick
        course = std::max(3, h / 40);
        blockW = course * 5 / 2;
        mortar = std::max(1, course / 6);
        amount = 12;
        break;
    case 1:  // ashlar blocks
        course = std::max(4, h / 14);
        blockW = course * 2;
        mortar = std::max(1, course / 12);
        amount = 7;
        break;
    default:  // concrete panels, stacked (no bond)
        course = std::max(6, h / 6);
        blockW = std::max(6, w / 3);
        mortar = 1;
        amount = 4;
        runningBond = false;
        break;
    }
    const Rgba mortarColour = base.r + base.g + base.b > 420 ? shade(base, -40) : shade(base, 45);
    cv.fill(0, 0, w, h, mortarColour);
    for (int r = 0; r * course < h; ++r) {
        const int y = r * course;
        const int offset = runningBond && (r & 1) ? blockW / 2 : 0;
        for (int x = -offset; x < w; x += blockW) {
            const Rgba c = jitter(base, amount, hash(seed, static_cast<uint64_t>(r), static_cast<uint64_t>(x + offset)));
            cv.fill(x + mortar, y + mortar, x + blockW, y + course, c);
        }
    }
}

struct WindowLook {
    Rgba frame, sill, glass;
    bool transparent;
};

// A framed window with glazing bars, a sill and a small reflection; glass alpha 0..100
// per window when transparent (frames and sill stay opaque).
void drawWindow(Canvas& cv, int x0, int y0, int x1, int y1, const WindowLook& look, uint64_t h) {
    const int ww = x1 - x0, wh = y1 - y0;
    if (ww < 3 || wh < 3) return;
    const int f = std::max(1, std::min(ww, wh) / 12);
    const int sillT = std::max(1, f * 3 / 2);
    cv.fill(x0 - f, y1, x1 + f, y1 + sillT, look.sill);
    cv.fill(x0, y0, x1, y1, look.frame);

    const int gx0 = x0 + f, gy0 = y0 + f, gx1 = x1 - f, gy1 = y1 - f;
    const int gw = gx1 - gx0, gh = gy1 - gy0;
    if (gw < 1 || gh < 1) return;
    Rgba glass = (h % 7 == 0) ? kLitGlass : jitter(look.glass, 6, h >> 8);  // some lit rooms
    glass.a = look.transparent ? static_cast<uint8_t>(splitmix64(h) % 101) : 255;
    cv.fill(gx0, gy0, gx1, gy1, glass);
    if (gw >= 8 && gh >= 8) {  // reflection streak in the upper-left pane
        const Rgba hi = shade(glass, 40);  // keeps the glass alpha
        cv.fill(gx0 + gw / 8, gy0 + gh / 8, gx0 + gw / 8 + std::max(1, gw / 8), gy0 + gh / 2, hi);
    }
    const int bar = std::max(1, f * 2 / 3);
    if (gw >= 10) {  // mullion
        const int cx = gx0 + (gw - bar) / 2;
        cv.fill(cx, gy0, cx + bar, gy1, look.frame);
    }
    if (gh >= 14) {  // transom
        const int ty = gy0 + gh / 3;
        cv.fill(gx0, ty, gx1, ty + bar, look.frame);
    }
}

void drawDoor(Canvas& cv, int x0, int y0, int x1, int y1, Rgba frame, Rgba leaf) {
    const int dw = x1 - x0, dh = y1 - y0;
    if (dw < 3 || dh < 3) return;
    const int f = std::max(1, dw / 10);
    cv.fill(x0 - f, y0 - f, x1 + f, y1, frame);
    cv.fill(x0, y0, x1, y1, leaf);
    if (dw >= 10 && dh >= 20) {  // two recessed panels
        const Rgba panel = shade(leaf, -22);
        const int px0 = x0 + dw / 5, px1 = x1 - dw / 5;
        cv.fill(px0, y0 + dh / 10, px1, y0 + dh * 4 / 10, panel);
        cv.fill(px0, y0 + dh * 5 / 10, px1, y0 + dh * 9 / 10, panel);
    }
    const int k = std::max(1, dw / 10);  // brass handle near the right edge, mid height
    const int hx = x1 - std::max(1, dw / 8) - k;
    cv.fill(hx, y0 + dh / 2, hx + k, y0 + dh / 2 + k, Rgba{206, 182, 104, 255});
}

// The number plate and its digits (contract in the header).
struct PlateLayout {
    int scale, x0, y0, w, h, border;
};

PlateLayout plateLayout(int digits, int width, int height) {
    PlateLayout p{};
    p.scale = std::max(1, std::min(2 * height / 63, width / (6 * digits + 3)));
    p.w = (6 * digits - 1) * p.scale + 2 * p.scale;
    p.h = 9 * p.scale;
    p.x0 = (width - p.w) / 2;
    p.y0 = height / 8;
    p.border = std::max(1, p.scale / 2);
    return p;
}

void drawPlate(Canvas& cv, const PlateLayout& p, const std::string& text) {
    const int s = p.scale;
    cv.fill(p.x0 - p.border, p.y0 - p.border, p.x0 + p.w + p.border, p.y0 + p.h + p.border, kPlateBorder);
    cv.fill(p.x0, p.y0, p.x0 + p.w, p.y0 + p.h, kPlateWhite);
    for (size_t i = 0; i < text.size(); ++i) {
        const auto glyph = digitGlyph(text[i]);
        const int gx = p.x0 + s + static_cast<int>(i) * 6 * s;
        const int gy = p.y0 + s;
        for (int r = 0; r < 7; ++r)
            for (int c = 0; c < 5; ++c)
                if (glyph[r] & (0x10 >> c)) cv.fill(gx + c * s, gy + r * s, gx + (c + 1) * s, gy + (r + 1) * s, kDigitBlack);
    }
}

}  // namespace

// ---------------------------------------------------------------------------------------

std::array<uint8_t, 7> digitGlyph(char digit) {
    // Every glyph has ink in each of its 7 rows and 5 columns (hence the full-width foot
    // on '1'): a digit's ink box is exactly its 5x7 cell box, which makes the number
    // trivially segmentable by readers (tests, render checks).
    static constexpr std::array<std::array<uint8_t, 7>, 10> kFont = {{
        {0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E},  // 0
        {0x04, 0x0C, 0x14, 0x04, 0x04, 0x04, 0x1F},  // 1
        {0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F},  // 2
        {0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E},  // 3
        {0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02},  // 4
        {0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E},  // 5
        {0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E},  // 6
        {0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08},  // 7
        {0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E},  // 8
        {0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C},  // 9
    }};
    if (digit < '0' || digit > '9') return {};
    return kFont[static_cast<size_t>(digit - '0')];
}

Image8 drawFacade(const FacadeStyle& style, int width, int height) { return drawFacade(style, width, height, nullptr); }

Image8 drawFacade(const FacadeStyle& style, int width, int height, FacadeTruth* truth) {
    checkSize(width, "facade width");
    checkSize(height, "facade height");
    if (style.storeys < 1) throw std::invalid_argument("facade storeys must be >= 1");
    if (style.window_columns < 1) throw std::invalid_argument("facade window_columns must be >= 1");

    const int w = width, h = height;
    Image8 img = makeImage(w, h, style.transparent_glass ? 4 : 3);
    if (truth) *truth = {w, h, std::vector<FacadePart>(static_cast<size_t>(w) * h, FacadePart::Wall), 0, 0};
    Canvas cv(img, truth);

    // Per-building look from the seed only (the number is drawn, not used for colours),
    // drawn in a fixed order so each choice is stable.
    Rng rng{splitmix64(style.seed ^ 0xFACADE00ULL)};
    // One rng call per statement (see pickJittered).
    const Rgba wall = pickJittered(kWallPalette, 8, 10, rng);
    const int wallKind = rng.range(0, 2);
    WindowLook look{};
    look.frame = pickJittered(kFramePalette, 5, 6, rng);
    look.sill = jitter(Rgba{200, 196, 186, 255}, 12, rng.next());
    look.glass = pick(kGlassPalette, 5, rng);
    look.transparent = style.transparent_glass;
    const Rgba doorLeaf = pickJittered(kDoorPalette, 5, 8, rng);
    const Rgba trim = shade(wall, wall.r + wall.g + wall.b > 360 ? -50 : 40);
    const int winWidthPct = rng.range(42, 62);   // of the column slot
    const int winHeightPct = rng.range(46, 60);  // of the storey height
    const uint64_t detailSeed = rng.next();

    drawWall(cv, w, h, wall, wallKind, detailSeed);

    const std::string text = std::to_string(style.building_number);
    const PlateLayout plate = plateLayout(static_cast<int>(text.size()), w, h);

    // Cornice on top and plinth at the bottom.
    cv.part(FacadePart::Trim);
    const int cornice = std::max(2, h / 32);
    cv.fill(0, 0, w, cornice, trim);
    cv.brighten(0, cornice, w, cornice + std::max(1, h / 128), -30);  // its shadow
    cv.fill(0, h - std::max(2, h / 48), w, h, shade(trim, -20));

    // Storeys below the sign band, top to bottom; the last one is the ground floor, which
    // gets 1.5 times the height of the others (2 units each, 3 for the ground floor) so
    // the door stays door-sized on tall buildings.
    const int bandBottom = !style.number_plate ? cornice + std::max(1, h / 32) : plate.y0 + plate.h + plate.border + std::max(1, h / 32);
    const int64_t avail = h - bandBottom;
    const int64_t units = 2 * static_cast<int64_t>(style.storeys) + 1;
    const int cols = style.window_columns;
    const int doorCol = (cols - 1 + static_cast<int>(detailSeed % 2)) / 2;  // centre (even: either middle slot)
    // Upper storeys below 6 px cannot hold a window: skip them (plain wall) without looping
    // over them, so an absurd storey count costs nothing; the ground floor is still drawn.
    const bool upperTooSmall = avail * 2 / units < 6;
    const bool slotsTooSmall = w / cols < 3;  // same for absurd column counts
    for (int i = upperTooSmall ? style.storeys - 1 : 0; i < style.storeys; ++i) {
        const bool ground = i == style.storeys - 1;
        const int y0 = bandBottom + static_cast<int>(avail * 2 * i / units);
        const int y1 = ground ? h : bandBottom + static_cast<int>(avail * 2 * (i + 1) / units);
        const int rh = y1 - y0;
        if (rh < 6) continue;  // too small to draw anything meaningful: plain wall
        cv.part(FacadePart::Trim);
        cv.fill(0, y0, w, y0 + std::max(1, rh / 16), trim);  // string course (floor line)
        if (truth && !slotsTooSmall) ++truth->window_rows;

        const int wh = rh * winHeightPct / 100;
        const int wy0 = ground ? y0 + rh / 5 : y0 + (rh - wh) * 2 / 5;
        const int wy1 = ground ? y1 - rh / 5 : wy0 + wh;
        for (int c = 0; c < (slotsTooSmall ? 0 : cols); ++c) {
            const int sx0 = static_cast<int>(static_cast<int64_t>(c) * w / cols);
            const int sx1 = static_cast<int>(static_cast<int64_t>(c + 1) * w / cols);
            const int sw = sx1 - sx0;
            if (ground && c == doorCol) {
                const int dw = std::min(sw * 11 / 20, std::max(3, rh * 2 / 5));
                const int dx0 = sx0 + (sw - dw) / 2;
                cv.part(FacadePart::Door);
                drawDoor(cv, dx0, y0 + rh / 5, dx0 + dw, h, look.frame, doorLeaf);
                continue;
            }
            const int ww = sw * winWidthPct / 100;
            const int wx0 = sx0 + (sw - ww) / 2;
            cv.part(FacadePart::Window);
            drawWindow(cv, wx0, wy0, wx0 + ww, wy1, look,
                       hash(detailSeed, static_cast<uint64_t>(i), static_cast<uint64_t>(c)));
        }
    }

    if (truth && !slotsTooSmall) truth->window_columns = cols;

    // The plate last, so nothing can cover the number.
    cv.part(FacadePart::Plate);
    if (style.number_plate) drawPlate(cv, plate, text);
    return img;
}

Image8 drawPaving(int size, uint64_t seed) {
    checkSize(size, "paving size");
    constexpr int kSlabs = 4;  // slabs per tile side; fixed so world scale is predictable
    Image8 img = makeImage(size, size, 3);
    Canvas cv(img);

    Rng rng{splitmix64(seed ^ 0x9A71E600ULL)};
    const Rgba base = pickJittered(kPavingPalette, 5, 8, rng);
    const Rgba joint = shade(base, -70);
    const uint64_t noiseSeed = rng.next();

    // Slab borders at i*size/kSlabs; slab (i,j) is the cell between borders, and border 0
    // is also border kSlabs (the tile edge), so slab indices wrap with the tile.
    int bounds[kSlabs + 1];
    for (int i = 0; i <= kSlabs; ++i) bounds[i] = i * size / kSlabs;
    Rgba slab[kSlabs][kSlabs];
    for (auto& rowOfSlabs : slab)
        for (auto& c : rowOfSlabs) c = jitter(base, 12, rng.next());
    std::vector<int> slabOf(static_cast<size_t>(size));
    for (int i = 0; i < kSlabs; ++i)
        for (int x = bounds[i]; x < bounds[i + 1]; ++x) slabOf[static_cast<size_t>(x)] = i;

    // Slab surface with fine grain: +-6 per pixel from a hash of the position, so it is a
    // function of (x, y) inside the tile and can never create a seam.
    for (int y = 0; y < size; ++y) {
        uint8_t* p = cv.row(y);
        const Rgba* slabRow = slab[slabOf[static_cast<size_t>(y)]];
        for (int x = 0; x < size; ++x, p += 3) {
            const Rgba c = slabRow[slabOf[static_cast<size_t>(x)]];
            const int n = static_cast<int>(splitmix64(noiseSeed + static_cast<uint64_t>(y) * size + x) % 13) - 6;
            p[0] = clampWall(c.r + n);
            p[1] = clampWall(c.g + n);
            p[2] = clampWall(c.b + n);
        }
    }

    // Joints centred on each border; the one on border 0 is split between the last and
    // first columns/rows, so the tile edge lies inside a uniform joint (seamless).
    const int jw = std::max(2, size / 48);
    const int before = jw / 2, after = jw - before;
    // Bevel: lit top/left edge and shaded bottom/right edge of each slab.
    const int bevel = std::max(1, size / 160);
    for (int i = 0; i < kSlabs; ++i) {
        const int a = bounds[i] + after, b = bounds[i + 1] - before;  // slab interior [a, b)
        if (b - a < 8) continue;
        cv.brighten(a, 0, a + bevel, size, 14);
        cv.brighten(0, a, size, a + bevel, 14);
        cv.brighten(b - bevel, 0, b, size, -14);
        cv.brighten(0, b - bevel, size, b, -14);
    }
    for (int i = 0; i < kSlabs; ++i) {
        const int b = bounds[i];
        cv.fill(b - before, 0, b + after, size, joint);
        cv.fill(0, b - before, size, b + after, joint);
        if (i == 0) {  // wrapped half of the tile-edge joint
            cv.fill(size - before, 0, size, size, joint);
            cv.fill(0, size - before, size, size, joint);
        }
    }
    return img;
}

bool writePng(const std::string& path, const Image8& image, std::string* error) {
    auto fail = [&](std::string reason) {
        std::replace(reason.begin(), reason.end(), '\n', ' ');
        while (!reason.empty() && reason.back() == ' ') reason.pop_back();
        if (error) *error = path + ": " + (reason.empty() ? std::string("unknown error") : reason);
        return false;
    };
    if (image.width <= 0 || image.height <= 0 || image.channels < 1 || image.channels > 4 ||
        image.pixels.size() != static_cast<size_t>(image.width) * image.height * image.channels)
        return fail("invalid image (size/channels do not match the pixel buffer)");

    // "png" selects the PNG writer whatever the path's extension is.
    auto out = OIIO::ImageOutput::create("png");
    if (!out) return fail("OpenImageIO has no PNG writer: " + OIIO::geterror());

    OIIO::ImageSpec spec(image.width, image.height, image.channels, OIIO::TypeDesc::UINT8);
    // Low zlib level: thousands of textures per town, write speed beats a few % of size.
    spec.attribute("png:compressionLevel", 2);
    // Fixed "Up" row filter (libpng PNG_FILTER_UP = 0x20): facades are mostly vertical runs
    // of equal colour, so it compresses as well as adaptive filtering at half the time
    // (OIIO 2.4 otherwise lets libpng try all five filters on every row).
    spec.attribute("png:filter", 0x20);
    // Our alpha is straight (not premultiplied): without this OIIO would divide the colour
    // by alpha on write and the stored glass colours would change.
    spec.attribute("oiio:UnassociatedAlpha", 1);
    // No DateTime/Software/etc. attributes are set, so the file depends only on the pixels.

    if (!out->open(path, spec)) return fail(out->geterror());
    const bool wrote = out->write_image(OIIO::TypeDesc::UINT8, image.pixels.data());
    std::string reason = wrote ? std::string() : out->geterror();
    if (!out->close() && wrote) {
        reason = out->geterror();
        if (reason.empty()) reason = "close failed";
    }
    if (!reason.empty() || !wrote) {
        std::remove(path.c_str());  // do not leave a truncated PNG behind
        return fail(reason.empty() ? "write failed" : reason);
    }
    return true;
}

}  // namespace cityatlas::synth
