// SPDX-License-Identifier: GPL-3.0-or-later
#include "tiles/computed_files.h"

#include <cmath>

#include <fmt/format.h>

namespace cityatlas::tiles {
namespace fs = std::filesystem;

std::string computedUri(size_t k, atlas::Layer layer, int32_t node) {
    return fmt::format("computed/{}/{}/{}.dds", k, atlas::layerName(layer), node);
}

std::vector<atlas::ScalarImage> computedMips(const atlas::ScalarImage& image) {
    std::vector<atlas::ScalarImage> levels{image};
    while (levels.back().width > 1 || levels.back().height > 1) {
        const atlas::ScalarImage& in = levels.back();
        atlas::ScalarImage out;
        out.width = std::max(1, in.width / 2), out.height = std::max(1, in.height / 2);
        out.value.assign(static_cast<size_t>(out.width) * static_cast<size_t>(out.height), atlas::kNoValue);
        // Output texel i covers 2i and 2i + 1, the last one also the final input texel of an odd side.
        auto span = [](int i, int out_n, int in_n) {
            const int first = std::min(2 * i, in_n - 1);
            const int last = i == out_n - 1 ? in_n - 1 : std::min(2 * i + 1, in_n - 1);
            return std::pair{first, last};
        };
        for (int y = 0; y < out.height; ++y) {
            const auto [y0, y1] = span(y, out.height, in.height);
            for (int x = 0; x < out.width; ++x) {
                const auto [x0, x1] = span(x, out.width, in.width);
                double sum = 0;
                int n = 0;
                for (int yy = y0; yy <= y1; ++yy)
                    for (int xx = x0; xx <= x1; ++xx) {
                        const float v = in.value[static_cast<size_t>(yy) * static_cast<size_t>(in.width) + static_cast<size_t>(xx)];
                        if (!std::isnan(v)) sum += v, ++n;
                    }
                if (n > 0) out.value[static_cast<size_t>(y) * static_cast<size_t>(out.width) + static_cast<size_t>(x)] =
                    static_cast<float>(sum / n);
            }
        }
        levels.push_back(std::move(out));
    }
    return levels;
}

Status writeComputedImage(const atlas::ScalarImage& image, BcQuality quality, const fs::path& out_dir,
                          const std::string& uri, format::ComputedFileEntry* out) {
    if (image.width <= 0 || image.height <= 0) return Status::Invalid(fmt::format("{}: an empty computed image", uri));
    std::vector<format::Image8> mips;
    for (const atlas::ScalarImage& level : computedMips(image)) mips.push_back(atlas::quantizeUnit(level));
    const fs::path path = out_dir / uri;
    std::error_code ec;
    fs::create_directories(path.parent_path(), ec);
    if (ec) return Status::Io(fmt::format("{}: cannot create: {}", path.parent_path().string(), ec.message()));
    if (Status s = writeDds(path, mips, quality); !s.ok()) return s;
    out->file = {uri, fs::file_size(path, ec)};
    if (ec) return Status::Io(fmt::format("{}: {}", path.string(), ec.message()));
    out->width_px = image.width, out->height_px = image.height;
    out->mips = static_cast<int>(mips.size());
    return Status::Ok();
}

}  // namespace cityatlas::tiles
