// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/texture_file.h"

#include <algorithm>

namespace cityatlas::atlas {

// 8-bit scanline files (PNG, JPEG: nearly every texture) go row by row:
// OpenImageIO 2.4's whole-image read_image of a PNG, which its ImageCache
// uses too, decodes through a fresh buffer on every call, and first-touch
// page faults made it 2.5x slower (500 reads of a 512^2 RGB PNG: 2.03 s and
// 109 k faults; row by row 0.80 s and 13 k).
std::shared_ptr<const DecodedTexture> readTextureFile(const std::string& path, std::string* why, bool straight_alpha) {
    OIIO::ImageSpec config;
    if (straight_alpha) config.attribute("oiio:UnassociatedAlpha", 1);  // PNG alpha is straight: do not premultiply the codes
    auto in = OIIO::ImageInput::open(path, &config);
    if (!in) {
        *why = OIIO::geterror();
        return nullptr;
    }
    auto d = std::make_shared<DecodedTexture>();
    d->spec = in->spec();
    const OIIO::ImageSpec& spec = d->spec;
    if (spec.width < 1 || spec.height < 1 || spec.nchannels < 1) {
        *why = "empty image";
        return nullptr;
    }
    const int nc = std::min(spec.nchannels, 4);
    d->channels = nc;
    const size_t n = static_cast<size_t>(spec.width) * spec.height;
    bool ok = true;
    if (spec.format == OIIO::TypeDesc::UINT8 && spec.tile_width == 0) {
        d->raw8.resize(n * nc);
        std::vector<uint8_t> row(static_cast<size_t>(spec.width) * spec.nchannels);
        for (int y = 0; y < spec.height && ok; ++y) {
            ok = in->read_scanline(spec.y + y, spec.z, OIIO::TypeDesc::UINT8, row.data());
            uint8_t* out = &d->raw8[static_cast<size_t>(y) * spec.width * nc];
            if (nc == spec.nchannels)
                std::copy(row.begin(), row.end(), out);
            else
                for (int x = 0; x < spec.width; ++x)
                    std::copy_n(&row[static_cast<size_t>(x) * spec.nchannels], nc, out + static_cast<size_t>(x) * nc);
        }
    } else if (spec.format == OIIO::TypeDesc::UINT8) {
        d->raw8.resize(n * nc);
        ok = in->read_image(0, 0, 0, nc, OIIO::TypeDesc::UINT8, d->raw8.data());
    } else {
        d->raw16.resize(n * nc);
        ok = in->read_image(0, 0, 0, nc, OIIO::TypeDesc::UINT16, d->raw16.data());
    }
    if (!ok) {
        *why = in->geterror();
        return nullptr;
    }
    return d;
}

}  // namespace cityatlas::atlas
