// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target for BlockMap files (format/blockmap_file.h) as the client
// and `inspect` read them. The bytes are decoded as they are, and again with
// their checksum made right (else nearly every mutation stops at the
// checksum and the plane checks are never reached). A decoded BlockMap must
// be safe to ray-cast: rays through it (render/core/blockmap_ray.h) and
// every cell's columns stay inside its planes. Any bytes give a Status,
// never a crash, an exception, a hang or a sanitizer report.
#include <xxhash.h>

#include <cstdint>
#include <cstring>
#include <vector>

#include "format/blockmap_file.h"
#include "render/core/blockmap_ray.h"
#include "tests/fuzz/fuzz_support.h"

using namespace cityatlas;

namespace {

void exercise(const format::BlockMap& bm) {
    for (int y = 0; y < bm.ny; ++y)
        for (int x = 0; x < bm.nx; ++x)
            for (int k = 0; k < 4; ++k) {
                const uint32_t c = bm.columnOf(x, y, k);
                if (c != format::kBlockMapNone && c >= bm.columns.size()) __builtin_trap();
            }
    const Vec3d centre{bm.origin.x + 0.5 * bm.nx * bm.cell_m, bm.origin.y + 0.5 * bm.ny * bm.cell_m, 0.5 * (bm.origin.z + bm.z_hi)};
    const Vec3d dirs[4] = {{1, 0.3, -0.5}, {-0.2, 1, -0.7}, {0.5, -0.5, -1}, {-1, -0.1, 0.2}};
    for (const Vec3d& d : dirs) {
        const double far = 2 * (bm.nx + bm.ny) * bm.cell_m + (bm.z_hi - bm.origin.z);
        const render::BlockMapHit h = render::castBlockMapRay(bm, centre - far * d, d);
        if (h.hit && !bm.inside(h.x, h.y)) __builtin_trap();
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    format::BlockMap bm;
    if (format::decodeBlockMapFile({data, size}, "fuzz.bin", &bm).ok()) exercise(bm);
    if (size < 8) return 0;
    std::vector<uint8_t> sealed(data, data + size);
    const uint64_t h = XXH64(sealed.data(), size - 8, 0);
    std::memcpy(sealed.data() + size - 8, &h, 8);
    if (format::decodeBlockMapFile(sealed, "fuzz.bin", &bm).ok()) exercise(bm);
    return 0;
}
