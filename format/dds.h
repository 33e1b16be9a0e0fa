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

/// "BC1", "BC3" or "BC4" for 3, 4 or 1 channels (tileset.json's format names).
const char* bcFormatName(int channels);

/// Block bytes of one level: 8 per 4x4 block for BC1 (3 channels) and BC4
/// (1 channel: a linear scalar, computed textures), 16 for BC3 (4 channels).
size_t bcBlockBytes(int width, int height, int channels);

/// Decodes BC1/BC3/BC4 blocks back to an Image8 of `channels` channels (3:
/// BC1, 4: BC3, 1: BC4) and exactly width x height (the padding is dropped):
/// BC1/BC3 with squish::Decompress per block; BC4, which libsquish lacks, by
/// its definition (two endpoints, eight or six-plus-two interpolated values,
/// 3-bit indices). For the CPU-decode path, tests and PSNR reports.
Image8 decodeBc(const std::vector<uint8_t>& blocks, int width, int height, int channels);

/// What a DDS header (as encodeDds writes it) says about its file.
struct DdsInfo {
    int width = 0, height = 0;
    int mips = 0;      ///< dwMipMapCount, 0 read as 1
    int channels = 0;  ///< 3: DXT1 (BC1), 4: DXT5 (BC3), 1: BC4 (DX10 header, DXGI_FORMAT_BC4_UNORM)
    size_t header_bytes = 128;  ///< 148 with the DX10 header
    size_t expected_bytes = 0;  ///< header_bytes + bcBlockBytes of every level: the whole file
};

/// Parses the header of a DDS file (`size` may be the whole file or just its
/// header: 128 bytes, 148 with a DX10 header): "DDS " magic, dwSize 124, a
/// 32-byte pixel format with DDPF_FOURCC, FourCC DXT1 or DXT5, or DX10 with
/// DXGI_FORMAT_BC4_UNORM in a 2D texture, width and height >= 1 (and <= 2^16, so
/// that expected_bytes cannot overflow), a mip count (0 read as 1) no longer
/// than the full chain. Fails with a one-line reason; never reads past `size`.
/// Does not compare expected_bytes with anything: the caller knows the length.
Status parseDdsHeader(const uint8_t* data, size_t size, DdsInfo* out);

namespace dds_detail {
constexpr size_t blockSize(int channels) { return channels == 4 ? 16 : 8; }
constexpr uint32_t fourCC(const char (&s)[5]) {
    return uint32_t(uint8_t(s[0])) | uint32_t(uint8_t(s[1])) << 8 | uint32_t(uint8_t(s[2])) << 16 |
           uint32_t(uint8_t(s[3])) << 24;
}
constexpr uint32_t kDdpfFourCC = 0x4;  // DDS_PIXELFORMAT.dwFlags: the FourCC is valid
constexpr uint32_t kDxgiBc4Unorm = 80;    // DXGI_FORMAT_BC4_UNORM
constexpr uint32_t kDimensionTexture2d = 3;  // D3D10_RESOURCE_DIMENSION_TEXTURE2D
constexpr size_t kDx10HeaderBytes = 20;
}  // namespace dds_detail

}  // namespace cityatlas::format
