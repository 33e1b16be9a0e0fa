// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Texture encoding for the tiles stage: mip chains in linear light and S3TC
/// (BC1 for RGB, BC3 for RGBA) blocks in DDS files, which every desktop GPU
/// samples without decoding (../shared/STACK.md §3 for the encoder choice);
/// and one-channel images (a computed texture's linear scalar in [0, 1],
/// issue 19) as BC4 (RGTC1, core since GL 3.0), 4 bits a texel.
///
/// Malformed arguments (wrong buffer size, channels other than 1, 3 or 4, a mip
/// list whose sizes do not halve) are programmer errors and throw
/// std::invalid_argument; only file-system failures come back as a Status.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string_view>
#include <vector>

#include "core/status.h"
#include "format/dds.h"

namespace cityatlas::tiles {

// The read side (Image8, block sizes, the BC decoder, the DDS header) lives in
// the format library, which the client links alone.
using format::bcBlockBytes;
using format::DdsInfo;
using format::decodeBc;
using format::Image8;
using format::parseDdsHeader;

/// Fast: stb_dxt with STB_DXT_HIGHQUAL, parallel per block row (TBB).
/// Best: libsquish kColourClusterFit with uniform channel weights (the same
/// measure as psnrRgb), per block under TBB; about 60-90x slower for ~0.2 dB.
enum class BcQuality : uint8_t { Fast, Best };

std::string_view bcQualityName(BcQuality q);  ///< "fast", "best"
std::optional<BcQuality> bcQualityFromName(std::string_view name);

/// The full mip chain, base first, down to 1x1: each level halves each
/// dimension (floor, at least 1) and is the box mean of the covered texels of
/// the previous level in LINEAR light with premultiplied alpha (sRGB decode,
/// average, re-encode to the nearest code). Output texel i covers input texels
/// 2i and 2i+1 per axis; when the input size is odd the last output texel also
/// covers the final input texel (3 texels). A footprint that is fully
/// transparent keeps the plain linear mean of its colours (nothing to weight by).
/// One channel is already linear: the plain mean of the codes, rounded.
/// Level 0 is a copy of `base`.
std::vector<Image8> mipChain(const Image8& base);

/// BC1 blocks (3 channels; opaque: alpha is never encoded, so no block uses
/// BC1's transparent index), BC3 blocks (4 channels) or BC4 blocks (1
/// channel; stb_compress_bc4_block at either quality) of one image, row-major
/// blocks, partial edge blocks padded by replicating the last row/column.
/// Deterministic for any thread count (each block is encoded on its own).
std::vector<uint8_t> encodeBc(const Image8& image, BcQuality quality);

/// A complete DDS file: "DDS " + 124-byte DDS_HEADER (flags
/// CAPS|HEIGHT|WIDTH|PIXELFORMAT|MIPMAPCOUNT|LINEARSIZE, pitchOrLinearSize =
/// bytes of level 0, mipMapCount = levels, FourCC "DXT1" for 3 channels,
/// "DXT5" for 4, "DX10" for 1 followed by the 20-byte DX10 header (format
/// BC4_UNORM, a 2D texture, array size 1), caps TEXTURE, plus MIPMAP|COMPLEX
/// when more than one level), then each level's blocks. `mips` is level 0 first; each further level must
/// be the halved size of the one before (a chain may stop before 1x1).
std::vector<uint8_t> encodeDds(const std::vector<Image8>& mips, BcQuality quality);

/// encodeDds written to `path` through a sibling temporary file and a rename,
/// so a reader never sees a partial file; the error names the file.
Status writeDds(const std::filesystem::path& path, const std::vector<Image8>& mips, BcQuality quality);

/// PSNR in dB over the RGB channels of two images of the same width and height
/// (either may have 3 or 4 channels; alpha is ignored); +inf when equal.
double psnrRgb(const Image8& a, const Image8& b);

}  // namespace cityatlas::tiles
