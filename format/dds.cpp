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

size_t bcBlockBytes(int width, int height, int channels) {
    return size_t((width + 3) / 4) * size_t((height + 3) / 4) * blockSize(channels);
}

Image8 decodeBc(const std::vector<uint8_t>& blocks, int width, int height, int channels) {
    if (channels != 3 && channels != 4)
        throw std::invalid_argument(fmt::format("decodeBc: {} channels, expected 3 or 4", channels));
    if (width < 1 || height < 1) throw std::invalid_argument("decodeBc: empty image");
    if (blocks.size() != bcBlockBytes(width, height, channels))
        throw std::invalid_argument(fmt::format("decodeBc: {} bytes for {}x{}, expected {}", blocks.size(), width,
                                                height, bcBlockBytes(width, height, channels)));
    Image8 img{width, height, channels, std::vector<uint8_t>(size_t(width) * size_t(height) * size_t(channels))};
    const int bw = (width + 3) / 4, bh = (height + 3) / 4;
    const size_t bsize = blockSize(channels);
    const int flags = channels == 3 ? squish::kDxt1 : squish::kDxt5;
    uint8_t rgba[64];
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
    if (at(84) == fourCC("DXT1")) d.channels = 3;
    else if (at(84) == fourCC("DXT5")) d.channels = 4;
    else return Status::Invalid("DDS FourCC is neither DXT1 nor DXT5");
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
    d.expected_bytes = 128;
    for (int l = 0, x = d.width, y = d.height; l < d.mips; ++l, x = std::max(1, x / 2), y = std::max(1, y / 2))
        d.expected_bytes += bcBlockBytes(x, y, d.channels);
    *out = d;
    return Status::Ok();
}

}  // namespace cityatlas::format
