// SPDX-License-Identifier: GPL-3.0-or-later
// The read stage's stylised-facades pass (cli/shards.h addStylisedFacades).

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <mutex>

#include "cli/shards.h"
#include "ingest/stylised_facades.h"
#include "tiles/texture_blocks.h"

namespace cityatlas::cli {

namespace fs = std::filesystem;

Status addStylisedFacades(const fs::path& spill, const fs::path& dir, Scene* tables, StylisedFacadeCounts* counts) {
    // Which textures walls use, and which anything else uses; and how much
    // of their walls' area they show upright.
    enum : uint8_t { kOnWalls = 1, kElsewhere = 2 };
    std::vector<uint8_t> use(tables->textures.size(), 0);
    std::vector<double> wall_area(use.size(), 0), upright_area(use.size(), 0);
    if (Status s = forEachSpilled(spill, [&](const Triangle& t) {
            if (t.texture < 0 || static_cast<size_t>(t.texture) >= use.size()) return;
            const auto k = static_cast<size_t>(t.texture);
            if (!isWall(t)) {
                use[k] |= kElsewhere;
                return;
            }
            use[k] |= kOnWalls;
            const double area = length(cross(t.position_local[1] - t.position_local[0], t.position_local[2] - t.position_local[0]));
            wall_area[k] += area;
            if (uprightOnWall(t, tables->textures[k])) upright_area[k] += area;
        });
        !s.ok())
        return s;
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) return Status::Io(fmt::format("{}: cannot create: {}", dir.string(), ec.message()));
    std::vector<size_t> facades;
    for (size_t i = 0; i < use.size(); ++i) {
        if (use[i] == kOnWalls) facades.push_back(i);
        if (use[i] & kElsewhere) counts->not_facades += 1;
    }
    std::atomic<uint64_t> stylised{0}, without_windows{0}, tilted{0}, unreadable{0};
    std::vector<std::string> write_error(facades.size()), photo_path(facades.size());
    std::mutex table_mutex;
    tbb::parallel_for(size_t{0}, facades.size(), [&](size_t k) {
        TextureRef texture;
        {
            const std::lock_guard lock(table_mutex);  // set() below appends to the table's buffers
            texture = tables->textures.ref(facades[k]);
        }
        const int channels = texture.channels == 4 ? 4 : 3;
        format::Image8 photo;
        std::string why;
        if (!tiles::readImage8(texture.path, channels, &photo, &why)) {
            unreadable += 1;
            return;
        }
        const synth::Image8 input{photo.width, photo.height, photo.channels, std::move(photo.pixels)};
        FacadeSummary summary = analyseFacade(input);
        if (upright_area[facades[k]] < 0.9 * wall_area[facades[k]]) {  // its rows are not level: its colour only
            summary.rows = summary.columns = {};
            summary.window_rgb = summary.facade_rgb;
            tilted += 1;
        }
        if (summary.rows.start.empty()) without_windows += 1;
        const fs::path png = dir / fmt::format("{}.png", facades[k]);
        if (!synth::writePng(png.string(), drawStylisedFacade(summary, input.width, input.height, channels),
                             &write_error[k]))
            return;
        photo_path[k] = std::move(texture.path);
        texture.path = png.string();
        texture.width_px = input.width, texture.height_px = input.height, texture.channels = channels;
        const std::lock_guard lock(table_mutex);
        tables->textures.set(facades[k], texture);
        stylised += 1;
    });
    for (const std::string& e : write_error)
        if (!e.empty()) return Status::Io(e);
    for (size_t k = 0; k < facades.size(); ++k)
        if (!photo_path[k].empty()) counts->photos.push_back(std::move(photo_path[k]));
    counts->stylised = stylised, counts->without_windows = without_windows, counts->tilted = tilted;
    counts->unreadable = unreadable;
    return Status::Ok();
}

}  // namespace cityatlas::cli
