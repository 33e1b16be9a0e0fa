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

}  // namespace cityatlas::format
