// SPDX-License-Identifier: GPL-3.0-or-later
#include "tiles/blockmap_writer.h"

#include "format/blockmap_file.h"

namespace cityatlas::tiles {

std::vector<uint8_t> blockMapFileBytes(const format::BlockMap& bm, BcQuality quality) {
    std::vector<uint8_t> roof, walls;
    if (!bm.roof.empty()) {
        roof = encodeBc(format::Image8{bm.nx, bm.ny, 3, bm.roof}, quality);
        if (bm.wall_height > 0) walls = encodeBc(format::Image8{bm.wall_width, bm.wall_height, 3, bm.walls}, quality);
    }
    return format::encodeBlockMapFile(bm, roof, walls);
}

uint64_t blockMapFileSize(const format::BlockMap& bm, bool coloured) {
    std::vector<uint8_t> roof, walls;  // zeros of the BC1 planes' sizes: the encoder reads no colour of `bm`
    if (coloured) {
        roof.resize(format::bcBlockBytes(bm.nx, bm.ny, 3));
        if (bm.wall_height > 0) walls.resize(format::bcBlockBytes(bm.wall_width, bm.wall_height, 3));
    }
    return format::encodeBlockMapFile(bm, roof, walls).size();
}

}  // namespace cityatlas::tiles
