// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target for DDS files as the client and `inspect` read them: the
// header (format::parseDdsHeader), the client's render::decodeDds (levels and
// their byte ranges) and the CPU BC1/BC3/BC4 decode of every level (format::decodeBc,
// what the renderer does where the GPU has no sRGB S3TC). Any bytes give a
// Status, never a crash, an exception, a hang or a sanitizer report.
#include <cstdint>
#include <vector>

#include "render/loader/block_decoder.h"
#include "tests/fuzz/fuzz_support.h"
#include "format/dds.h"

using namespace cityatlas;
using namespace cityatlas::render;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    // inspect reads the header alone (148 bytes: with a DX10 part) and compares the length itself.
    format::DdsInfo info;
    const bool header = format::parseDdsHeader(data, size < 148 ? size : 148, &info).ok();

    // The loader takes BC4 (a computed texture) only where tileset.json asks for it.
    CompressedTexture t;
    if (!decodeDds(data, size, header && info.channels == 1 ? 1 : 0, &t).ok()) return 0;
    // Every level lies inside the data; the CPU decode of each must not throw.
    for (const CompressedTexture::Level& level : t.levels) {
        if (level.offset > t.data.size() || level.bytes > t.data.size() - level.offset) __builtin_trap();
        const std::vector<uint8_t> blocks(t.data.begin() + static_cast<std::ptrdiff_t>(level.offset),
                                          t.data.begin() + static_cast<std::ptrdiff_t>(level.offset + level.bytes));
        const format::Image8 image = format::decodeBc(blocks, level.width, level.height, t.channels);
        if (image.pixels.size() != static_cast<size_t>(level.width) * level.height * t.channels) __builtin_trap();
    }
    return 0;
}
