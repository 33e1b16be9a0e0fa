// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The read side of the folder's textures: 8-bit images, S3TC block sizes,
/// the BC1/BC3 decoder (libsquish) and the DDS header as tiles/texture_codec.h
/// writes it. For the client (CPU decode where a GPU lacks S3TC), `inspect` and
/// tests; the encoders stay in tiles/.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/status.h"

namespace cityatlas::format {

/// 8-bit image, rows top-down (file order), 3 (RGB) or 4 (RGBA, straight alpha)
/// channels, sRGB-encoded colour; alpha is linear coverage.
struct Image8 {
    int width = 0, height = 0, channels = 0;
    std::vector<uint8_t> pixels;  ///< width*height*channels bytes
};

/// Block bytes of one level: 8 per 4x4 block for BC1 (3 channels), 16 for BC3.
size_t bcBlockBytes(int width, int height, int channels);

/// Decodes BC1/BC3 blocks back to an Image8 of `channels` channels (3: BC1,
/// 4: BC3) and exactly width x height (the padding is dropped), with
/// squish::Decompress per block. For tests and PSNR reports.
Image8 decodeBc(const std::vector<uint8_t>& blocks, int width, int height, int channels);

/// What a DDS header (as encodeDds writes it) says about its file.
struct DdsInfo {
    int width = 0, height = 0;
    int mips = 0;      ///< dwMipMapCount, 0 read as 1
    int channels = 0;  ///< 3: DXT1 (BC1), 4: DXT5 (BC3)
    size_t expected_bytes = 0;  ///< 128 + bcBlockBytes of every level: the whole file
};

/// Parses the first 128 bytes of a DDS file (`size` may be the whole file or
/// just its header): "DDS " magic, dwSize 124, a 32-byte pixel format with
/// DDPF_FOURCC, FourCC DXT1 or DXT5, width and height >= 1 (and <= 2^16, so
/// that expected_bytes cannot overflow), a mip count (0 read as 1) no longer
/// than the full chain. Fails with a one-line reason; never reads past `size`.
/// Does not compare expected_bytes with anything: the caller knows the length.
Status parseDdsHeader(const uint8_t* data, size_t size, DdsInfo* out);

namespace dds_detail {
constexpr size_t blockSize(int channels) { return channels == 3 ? 8 : 16; }
constexpr uint32_t fourCC(const char (&s)[5]) {
    return uint32_t(uint8_t(s[0])) | uint32_t(uint8_t(s[1])) << 8 | uint32_t(uint8_t(s[2])) << 16 |
           uint32_t(uint8_t(s[3])) << 24;
}
constexpr uint32_t kDdpfFourCC = 0x4;  // DDS_PIXELFORMAT.dwFlags: the FourCC is valid
}  // namespace dds_detail

}  // namespace cityatlas::format
