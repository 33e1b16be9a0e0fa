// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/procedural_facades.h"

#include <algorithm>
#include <cctype>
#include <cmath>

namespace cityatlas {
namespace {

// The nearest colour BC1 stores exactly: 5 bits of red and blue, 6 of green,
// expanded by bit replication as BC1 decoders do.
std::array<uint8_t, 3> rgb565(int r, int g, int b) {
    auto five = [](int v) {
        const int c = std::clamp((v * 31 + 127) / 255, 0, 31);
        return static_cast<uint8_t>((c << 3) | (c >> 2));
    };
    const int c6 = std::clamp((g * 63 + 127) / 255, 0, 63);
    return {five(r), static_cast<uint8_t>((c6 << 2) | (c6 >> 4)), five(b)};
}

std::string lower(std::string s) {
    for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

std::optional<double> numberAttribute(const Feature& f, std::initializer_list<const char*> names) {
    for (const char* name : names)
        for (const auto& [key, value] : f.attributes) {
            if (lower(key) != name) continue;
            try {
                size_t used = 0;
                const double v = std::stod(value, &used);
                if (used > 0 && std::isfinite(v) && v > 0) return v;
            } catch (const std::exception&) {
            }
        }
    return std::nullopt;
}

}  // namespace

const std::vector<FacadePalette>& facadePalettes() {
    static const std::vector<FacadePalette> palettes = [] {
        // Wall colours: plasters, brick, sandstone, grey; the slab a darker wall, windows dark glass.
        const int walls[][3] = {{226, 214, 190}, {204, 120, 88}, {232, 232, 224}, {176, 170, 160},
                                {214, 188, 140}, {150, 92, 70},  {196, 204, 188}, {240, 220, 170}};
        std::vector<FacadePalette> p;
        for (const auto& w : walls)
            p.push_back({rgb565(w[0], w[1], w[2]), rgb565(w[0] * 3 / 5, w[1] * 3 / 5, w[2] * 3 / 5), rgb565(52, 64, 80)});
        return p;
    }();
    return palettes;
}

size_t paletteOf(const std::string& building_id) {
    // FNV-1a: stable across platforms and runs (std::hash is not).
    uint64_t h = 1469598103934665603ull;
    for (const char c : building_id) h = (h ^ static_cast<uint8_t>(c)) * 1099511628211ull;
    return static_cast<size_t>(h % facadePalettes().size());
}

synth::Image8 facadeCell(const FacadePalette& p, int n) {
    synth::Image8 img{n, n, 3, std::vector<uint8_t>(static_cast<size_t>(n) * n * 3)};
    for (int row = 0; row < n; ++row) {
        const int up = n - 1 - row;  // texels from the bottom (v up)
        for (int x = 0; x < n; ++x) {
            const bool slab = up < n / 8;
            const bool window = up >= 3 * n / 8 && up < 7 * n / 8 && x >= n / 4 && x < 3 * n / 4;
            const std::array<uint8_t, 3>& c = slab ? p.slab : window ? p.window : p.wall;
            std::copy(c.begin(), c.end(), img.pixels.begin() + (static_cast<ptrdiff_t>(row) * n + x) * 3);
        }
    }
    return img;
}

bool isBareWall(const Triangle& t) { return t.texture < 0 && isWall(t); }

bool isWall(const Triangle& t) {
    if (t.semantic != SurfaceSemantic::Wall && t.semantic != SurfaceSemantic::Unclassified) return false;
    const std::array<Vec3d, 3>& p = t.position_local;
    const Vec3d n = cross(p[1] - p[0], p[2] - p[0]);
    const double l = length(n);
    return l > 0 && std::abs(n.z) / l < std::sin(15.0 * M_PI / 180.0);
}

std::optional<double> storeysAttribute(const Feature& f) {
    return numberAttribute(f, {"storeys", "storeysaboveground", "levels", "building_levels", "building:levels",
                               "floors_ag", "num_floors", "anzahl_geschosse", "geschosse"});
}
std::optional<double> storeyHeightAttribute(const Feature& f) {
    return numberAttribute(f, {"storey_h", "storey_height", "floor_height", "storeyheightsaboveground"});
}

FacadeLayout facadeLayout(const std::string& building_id, double wall_min_z, double wall_max_z,
                          std::optional<double> storeys, std::optional<double> storey_height,
                          const ProceduralFacadeParams& params) {
    FacadeLayout l;
    l.palette = paletteOf(building_id);
    l.base_z = wall_min_z;
    const double h = std::max(0.0, wall_max_z - wall_min_z);
    if (storey_height) {
        l.storey_height_m = *storey_height;
        l.storeys = std::max(1, static_cast<int>(std::lround(h / *storey_height)));
    } else {
        l.storeys = storeys ? std::max(1, static_cast<int>(std::lround(*storeys)))
                            : std::max(1, static_cast<int>(std::lround(h / params.storey_height_m)));
        l.storey_height_m = h > 0 ? h / l.storeys : params.storey_height_m;
    }
    return l;
}

void applyFacade(const FacadeLayout& layout, const ProceduralFacadeParams& params, int32_t texture, Triangle* t) {
    const std::array<Vec3d, 3>& p = t->position_local;
    const Vec3d n = cross(p[1] - p[0], p[2] - p[0]);
    // Along the wall, horizontal, so that u grows to the right seen from outside.
    const double hl = std::hypot(n.x, n.y);
    const Vec3d along = hl > 0 ? Vec3d{-n.y / hl, n.x / hl, 0} : Vec3d{1, 0, 0};
    for (int k = 0; k < 3; ++k)
        t->uv[static_cast<size_t>(k)] = {dot(p[static_cast<size_t>(k)] - layout.origin, along) / params.window_pitch_m,
                                         (p[static_cast<size_t>(k)].z - layout.base_z) / layout.storey_height_m};
    t->texture = texture;
}

}  // namespace cityatlas
