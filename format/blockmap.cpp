// SPDX-License-Identifier: GPL-3.0-or-later
// The BlockMap value type's rules that the builder and the ray caster share.
#include "format/blockmap.h"

#include <algorithm>
#include <bit>
#include <cmath>

namespace cityatlas::format {

uint16_t BlockMap::quantize(double z) const {
    const double span = z_hi - origin.z;
    if (!(span > 0)) return 0;
    return static_cast<uint16_t>(std::clamp(std::round((z - origin.z) / span * 65535.0), 0.0, 65535.0));
}

uint8_t BlockMap::exposedSides(int x, int y) const {
    if (!inside(x, y) || !cells[index(x, y)].occupied()) return 0;
    const BlockMapCell& c = cells[index(x, y)];
    uint8_t mask = 0;
    for (int k = 0; k < 4; ++k) {
        const int nx = x + kSideDx[static_cast<size_t>(k)], ny = y + kSideDy[static_cast<size_t>(k)];
        const bool covered = inside(nx, ny) && cells[index(nx, ny)].occupied() && cells[index(nx, ny)].top >= c.top &&
                             cells[index(nx, ny)].base <= c.base;
        if (!covered) mask |= static_cast<uint8_t>(1u << k);
    }
    return mask;
}

uint32_t BlockMap::columnOf(int x, int y, int side) const {
    const uint8_t mask = exposedSides(x, y);
    if (!(mask >> side & 1u)) return kBlockMapNone;
    const auto before = static_cast<uint32_t>(std::popcount(static_cast<unsigned>(mask & ((1u << side) - 1u))));
    return cells[index(x, y)].first_column + before;
}

std::vector<uint8_t> chebyshevDistances(const BlockMap& bm) {
    const int nx = bm.nx, ny = bm.ny;
    std::vector<int> d(bm.cells.size());
    for (size_t i = 0; i < d.size(); ++i) d[i] = bm.cells[i].occupied() ? 0 : 1 << 24;
    auto relax = [&](int x, int y, int px, int py) {
        if (px >= 0 && py >= 0 && px < nx && py < ny) d[bm.index(x, y)] = std::min(d[bm.index(x, y)], d[bm.index(px, py)] + 1);
    };
    for (int y = 0; y < ny; ++y)
        for (int x = 0; x < nx; ++x) {
            relax(x, y, x - 1, y);
            relax(x, y, x - 1, y - 1);
            relax(x, y, x, y - 1);
            relax(x, y, x + 1, y - 1);
        }
    for (int y = ny - 1; y >= 0; --y)
        for (int x = nx - 1; x >= 0; --x) {
            relax(x, y, x + 1, y);
            relax(x, y, x + 1, y + 1);
            relax(x, y, x, y + 1);
            relax(x, y, x - 1, y + 1);
        }
    std::vector<uint8_t> out(d.size());
    for (size_t i = 0; i < d.size(); ++i) out[i] = static_cast<uint8_t>(std::min(d[i], 255));
    return out;
}

}  // namespace cityatlas::format
