// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// An original texture read from its file (OpenImageIO), as the atlas
/// stage and the BlockMaps' colours read it: one reader, so both see the
/// same texels.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <OpenImageIO/imageio.h>

namespace cityatlas::atlas {

/// An original texture as its file holds it: 8 bits per channel when the
/// file has them, else 16; at most 4 channels; alpha straight (PNG alpha is
/// not premultiplied into the colour) unless read otherwise.
struct DecodedTexture {
    OIIO::ImageSpec spec;
    int channels = 0;
    std::vector<uint8_t> raw8;
    std::vector<uint16_t> raw16;
    size_t bytes() const { return raw8.size() + 2 * raw16.size(); }
};

/// Reads one texture; nullptr with *why when it cannot be read.
/// `straight_alpha` false: the colour premultiplied by alpha as OpenImageIO
/// does by default (its ImageCache reads so), e.g. for a colour seen as
/// opaque over black.
std::shared_ptr<const DecodedTexture> readTextureFile(const std::string& path, std::string* why,
                                                      bool straight_alpha = true);

}  // namespace cityatlas::atlas
