// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/texture_resolver.h"

#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

namespace cityatlas {
namespace fs = std::filesystem;

int32_t TextureResolver::resolve(const fs::path& base_dir, const std::string& uri, WrapMode wrap,
                                 const DiagnosticExample& where) {
    const bool remote = uri.find("://") != std::string::npos;
    const fs::path path = remote ? fs::path() : (base_dir / fs::path(uri)).lexically_normal();
    const std::string key = (remote ? uri : path.string()) + "#" + std::to_string(static_cast<int>(wrap));
    if (auto it = cache_.find(key); it != cache_.end()) return it->second;

    int32_t index = -1;
    auto fail = [&](const char* code, std::string detail) {
        DiagnosticExample ex = where;
        ex.detail = std::move(detail);
        diagnostics_.warn(code, std::move(ex));
    };
    std::error_code ec;
    if (remote) {
        fail(warn::kTextureMissing, fmt::format("{}: remote images are not fetched", uri));
    } else if (!fs::is_regular_file(path, ec)) {
        fail(warn::kTextureMissing, fmt::format("{}: no such file", path.string()));
    } else if (auto in = OIIO::ImageInput::open(path.string()); !in) {
        OIIO::geterror();  // clear OIIO's error state
        fail(warn::kTextureUnreadable, fmt::format("{}: not a readable image", path.string()));
    } else {
        const OIIO::ImageSpec& spec = in->spec();
        TextureRef ref;
        ref.path = path.string();
        ref.width_px = spec.width;
        ref.height_px = spec.height;
        ref.channels = spec.nchannels;
        ref.wrap = wrap;
        in->close();
        index = sink_.addTexture(ref);
        refs_[index] = ref;
    }
    (index >= 0 ? ok_ : failed_)++;
    cache_[key] = index;
    return index;
}

}  // namespace cityatlas
