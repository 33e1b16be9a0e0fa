// SPDX-License-Identifier: GPL-3.0-or-later
#include "format/dds.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include <fmt/format.h>
#include <squish.h>

namespace cityatlas::format {
using dds_detail::blockSize;
using dds_detail::fourCC;
using dds_detail::kDdpfFourCC;

const char* bcFormatName(int channels) { return channels == 1 ? "BC4" : channels == 4 ? "BC3" : "BC1"; }

size_t bcBlockBytes(int width, int height, int channels) {
    return size_t((width + 3) / 4) * size_t((height + 3) / 4) * blockSize(channels);
}

namespace {
// One BC4 block: two 8-bit endpoints, then sixteen 3-bit indices (little
// endian, texel 0 first). e0 > e1: six values between them; else four,
// then 0 and 255.
void decodeBc4Block(const uint8_t* b, uint8_t out[16]) {
    const int e0 = b[0], e1 = b[1];
    int palette[8] = {e0, e1};
    if (e0 > e1) {
        for (int i = 1; i <= 6; ++i) palette[i + 1] = ((7 - i) * e0 + i * e1 + 3) / 7;
    } else {
        for (int i = 1; i <= 4; ++i) palette[i + 1] = ((5 - i) * e0 + i * e1 + 2) / 5;
        palette[6] = 0;
        palette[7] = 255;
    }
    uint64_t bits = 0;
    for (int i = 0; i < 6; ++i) bits |= uint64_t(b[2 + i]) << (8 * i);
    for (int t = 0; t < 16; ++t) out[t] = uint8_t(palette[(bits >> (3 * t)) & 7]);
}
}  // namespace

Image8 decodeBc(const std::vector<uint8_t>& blocks, int width, int height, int channels) {
    if (channels != 1 && channels != 3 && channels != 4)
        throw std::invalid_argument(fmt::format("decodeBc: {} channels, expected 1, 3 or 4", channels));
    if (width < 1 || height < 1) throw std::invalid_argument("decodeBc: empty image");
    if (blocks.size() != bcBlockBytes(width, height, channels))
        throw std::invalid_argument(fmt::format("decodeBc: {} bytes for {}x{}, expected {}", blocks.size(), width,
                                                height, bcBlockBytes(width, height, channels)));
    Image8 img{width, height, channels, std::vector<uint8_t>(size_t(width) * size_t(height) * size_t(channels))};
    const int bw = (width + 3) / 4, bh = (height + 3) / 4;
    const size_t bsize = blockSize(channels);
    const int flags = channels == 3 ? squish::kDxt1 : squish::kDxt5;
    uint8_t rgba[64];
    if (channels == 1) {
        uint8_t v[16];
        for (int by = 0; by < bh; ++by)
            for (int bx = 0; bx < bw; ++bx) {
                decodeBc4Block(&blocks[(size_t(by) * size_t(bw) + size_t(bx)) * bsize], v);
                for (int py = 0; py < 4 && by * 4 + py < height; ++py)
                    for (int px = 0; px < 4 && bx * 4 + px < width; ++px)
                        img.pixels[size_t(by * 4 + py) * size_t(width) + size_t(bx * 4 + px)] = v[py * 4 + px];
            }
        return img;
    }
    for (int by = 0; by < bh; ++by)
        for (int bx = 0; bx < bw; ++bx) {
            squish::Decompress(rgba, &blocks[(size_t(by) * size_t(bw) + size_t(bx)) * bsize], flags);
            for (int py = 0; py < 4 && by * 4 + py < height; ++py)
                for (int px = 0; px < 4 && bx * 4 + px < width; ++px) {
                    const uint8_t* s = &rgba[(py * 4 + px) * 4];
                    uint8_t* d = &img.pixels[(size_t(by * 4 + py) * size_t(width) + size_t(bx * 4 + px)) *
                                             size_t(channels)];
                    std::memcpy(d, s, size_t(channels));
                }
        }
    return img;
}

Status parseDdsHeader(const uint8_t* data, size_t size, DdsInfo* out) {
    if (data == nullptr || size < 128)
        return Status::Invalid(fmt::format("{} bytes: shorter than a DDS header (128)", size));
    auto at = [&](size_t off) {
        return uint32_t(data[off]) | uint32_t(data[off + 1]) << 8 | uint32_t(data[off + 2]) << 16 |
               uint32_t(data[off + 3]) << 24;
    };
    if (at(0) != fourCC("DDS ")) return Status::Invalid("no DDS magic");
    if (at(4) != 124) return Status::Invalid(fmt::format("DDS header size {} (expected 124)", at(4)));
    if (at(76) != 32) return Status::Invalid(fmt::format("DDS pixel format size {} (expected 32)", at(76)));
    if ((at(80) & kDdpfFourCC) == 0) return Status::Invalid("DDS pixel format is not a FourCC format");
    DdsInfo d;
    if (at(84) == fourCC("DXT1")) {
        d.channels = 3;
    } else if (at(84) == fourCC("DXT5")) {
        d.channels = 4;
    } else if (at(84) == fourCC("DX10")) {
        if (size < 128 + dds_detail::kDx10HeaderBytes)
            return Status::Invalid(fmt::format("{} bytes: shorter than a DDS header with its DX10 part (148)", size));
        if (at(128) != dds_detail::kDxgiBc4Unorm)
            return Status::Invalid(fmt::format("DDS DX10 format {} is not BC4_UNORM (80)", at(128)));
        if (at(132) != dds_detail::kDimensionTexture2d || at(140) != 1)
            return Status::Invalid("DDS DX10 header is not a single 2D texture");
        d.channels = 1;
        d.header_bytes = 128 + dds_detail::kDx10HeaderBytes;
    } else {
        return Status::Invalid("DDS FourCC is none of DXT1, DXT5 and DX10");
    }
    const uint32_t h = at(12), w = at(16), mips = std::max<uint32_t>(1, at(28));
    // 2^16 is far above any texture this project writes and keeps every size below in range.
    if (w < 1 || h < 1 || w > 65536 || h > 65536)
        return Status::Invalid(fmt::format("DDS size {}x{} is out of range", w, h));
    d.width = int(w);
    d.height = int(h);
    uint32_t full = 1;
    for (uint32_t x = w, y = h; x > 1 || y > 1; x = std::max(1u, x / 2), y = std::max(1u, y / 2)) ++full;
    if (mips > full)
        return Status::Invalid(fmt::format("DDS claims {} mip levels, a {}x{} image has at most {}", mips, w, h, full));
    d.mips = int(mips);
    d.expected_bytes = d.header_bytes;
    for (int l = 0, x = d.width, y = d.height; l < d.mips; ++l, x = std::max(1, x / 2), y = std::max(1, y / 2))
        d.expected_bytes += bcBlockBytes(x, y, d.channels);
    *out = d;
    return Status::Ok();
}

}  // namespace cityatlas::format
