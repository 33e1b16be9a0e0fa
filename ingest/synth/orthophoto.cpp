// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/synth/orthophoto.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"

namespace cityatlas::synth {
namespace {

constexpr double kMargin_m = 2.0;
constexpr uint32_t kColourMultiplier = 0x9E3779u;  // odd: a bijection modulo 2^24
constexpr uint32_t kMask24 = 0xFFFFFFu;

// Inverse of an odd number modulo 2^24 (Newton: each step doubles the correct bits).
constexpr uint32_t inverseMod24(uint32_t a) {
    uint32_t x = a;  // correct to 3 bits for odd a
    for (int i = 0; i < 5; ++i) x = (x * (2u - a * x)) & kMask24;
    return x;
}

// Even-odd rule over all rings of a surface, projected to the ground plan.
bool insideGroundPlan(const SynthSurface& s, double x, double y) {
    bool inside = false;
    for (const auto& ring : s.rings)
        for (size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
            const Vec3d& a = ring[i];
            const Vec3d& b = ring[j];
            if ((a.y > y) != (b.y > y) && x < (b.x - a.x) * (y - a.y) / (b.y - a.y) + a.x) inside = !inside;
        }
    return inside;
}

}  // namespace

uint32_t orthophotoColour(uint32_t number) { return (number * kColourMultiplier) & kMask24; }
uint32_t orthophotoNumber(uint32_t rgb) { return ((rgb & kMask24) * inverseMod24(kColourMultiplier)) & kMask24; }

OrthophotoGrid orthophotoGrid(const Town& town, double pixel_m, int max_side_px) {
    Box3d box;
    for (const SynthBuilding& b : town.buildings)
        for (const SynthSurface& s : b.surfaces)
            if (s.semantic == SurfaceSemantic::Roof)
                for (const auto& r : s.rings)
                    for (const Vec3d& p : r) box.extend(p + town.settings.origin_source);
    OrthophotoGrid g;
    for (g.pixel_m = pixel_m;; g.pixel_m *= 2) {
        g.west_m = std::floor((box.min.x - kMargin_m) / g.pixel_m) * g.pixel_m;
        g.north_m = std::ceil((box.max.y + kMargin_m) / g.pixel_m) * g.pixel_m;
        g.width_px = static_cast<int>(std::ceil((box.max.x + kMargin_m - g.west_m) / g.pixel_m));
        g.height_px = static_cast<int>(std::ceil((g.north_m - (box.min.y - kMargin_m)) / g.pixel_m));
        if (std::max(g.width_px, g.height_px) <= max_side_px) return g;
    }
}

Image8 drawOrthophoto(const Town& town) {
    const OrthophotoGrid& g = town.orthophoto;
    Image8 img;
    img.width = g.width_px, img.height = g.height_px, img.channels = 3;
    img.pixels.resize(static_cast<size_t>(img.width) * img.height * 3);
    auto put = [&](int col, int row, uint32_t rgb) {
        uint8_t* p = &img.pixels[(static_cast<size_t>(row) * img.width + col) * 3];
        p[0] = static_cast<uint8_t>(rgb >> 16), p[1] = static_cast<uint8_t>(rgb >> 8), p[2] = static_cast<uint8_t>(rgb);
    };
    const uint32_t ground = orthophotoColour(kOrthophotoGroundNumber);
    for (int row = 0; row < img.height; ++row)
        for (int col = 0; col < img.width; ++col) put(col, row, ground);
    const Vec3d o = town.settings.origin_source;
    for (const SynthBuilding& b : town.buildings) {
        const uint32_t colour = orthophotoColour(b.number);
        for (const SynthSurface& s : b.surfaces) {
            if (s.semantic != SurfaceSemantic::Roof) continue;
            Box3d box;
            for (const auto& r : s.rings)
                for (const Vec3d& p : r) box.extend(p + o);
            const int c0 = std::max(0, static_cast<int>(std::floor((box.min.x - g.west_m) / g.pixel_m)));
            const int c1 = std::min(img.width - 1, static_cast<int>(std::floor((box.max.x - g.west_m) / g.pixel_m)));
            const int r0 = std::max(0, static_cast<int>(std::floor((g.north_m - box.max.y) / g.pixel_m)));
            const int r1 = std::min(img.height - 1, static_cast<int>(std::floor((g.north_m - box.min.y) / g.pixel_m)));
            for (int row = r0; row <= r1; ++row)
                for (int col = c0; col <= c1; ++col) {
                    // Pixel centre, in the local frame (exact: origin and grid are binary).
                    const double x = g.west_m + (col + 0.5) * g.pixel_m - o.x;
                    const double y = g.north_m - (row + 0.5) * g.pixel_m - o.y;
                    if (insideGroundPlan(s, x, y)) put(col, row, colour);
                }
        }
    }
    return img;
}

std::string worldFileText(const OrthophotoGrid& g) {
    return fmt::format("{}\n0\n0\n{}\n{}\n{}\n", exactDecimal(g.pixel_m), exactDecimal(-g.pixel_m),
                       exactDecimal(g.west_m + 0.5 * g.pixel_m), exactDecimal(g.north_m - 0.5 * g.pixel_m));
}

}  // namespace cityatlas::synth
