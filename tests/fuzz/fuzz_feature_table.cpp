// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target for feature tables (features/<k>.json). Neither reader
// takes bytes: the client's StreamingClient::featureRecord fetches the table
// itself (what `cityatlas view` shows for a picked building), and `cityatlas
// inspect` (tiles::inspectTileFolder) reads it from the folder. So the input
// becomes features/0.json of a small tile folder in /dev/shm whose tileset.json
// gives it the input's size, and both readers run on it. Any bytes give a
// Status or defect lines, never a crash, an exception, a hang or a sanitizer report.
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "render/client/streaming_client.h"
#include "tests/fuzz/fuzz_support.h"
#include "tiles/inspect.h"

using namespace cityatlas;
using namespace cityatlas::render;
using nlohmann::json;

namespace {

// A one-node tile folder's index with 3 features in one table; the node's
// blocks are absent (inspect reports them, the client never loads them here).
const char* const kTileset = R"({
  "asset": {"version": "1.1", "tilesetVersion": "fuzz"},
  "geometricError": 0.6,
  "extras": {"cityatlas": {
    "format_version": 1,
    "build": {"d_min_m": 300, "atlas_size_px": 256, "screen_width_px": 1920, "screen_height_px": 1080,
              "vertical_fov_deg": 60, "focal_px": 935.3, "corner_factor": 1.44, "tau": 1},
    "georeference": {"source_crs": "EPSG:25832", "local_to_ecef": null},
    "materials": [{"diffuse": [0.8, 0.8, 0.8], "transparency": 0}],
    "texture_blocks": [],
    "textures": [],
    "features": {"count": 3, "block_size": 4096, "tables": [{"uri": "features/0.json", "bytes": 1}]}
  }},
  "root": {
    "boundingVolume": {"box": [0, 0, 5, 10, 0, 0, 0, 10, 0, 0, 0, 5]},
    "geometricError": 0.3,
    "refine": "REPLACE",
    "extras": {"cityatlas": {
      "id": 0, "level": 0, "quadrant": -1, "min_distance_m": 300, "world_texel_m": 0.3, "centre": [0, 0, 5],
      "layers": {"opaque": {"triangles": 2, "geometric_error_m": 0, "position_error_mm": 1,
                            "geometry": {"uri": "geometry/opaque/0.glb", "bytes": 1000},
                            "atlas": null}},
      "features": {"count": 3, "tables": [0]}
    }}
  }
})";

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    static const std::filesystem::path dir = [] {
        const std::filesystem::path d = fuzz::scratchDir("feature_table");
        std::error_code ec;
        std::filesystem::create_directories(d / "features", ec);
        return d;
    }();
    static const json base = json::parse(kTileset);
    json doc = base;
    doc["extras"]["cityatlas"]["features"]["tables"][0]["bytes"] = std::max<size_t>(size, 1);
    const std::string tileset = doc.dump(1);
    if (!fuzz::writeFile(dir / "tileset.json", tileset.data(), tileset.size())) return 0;
    if (!fuzz::writeFile(dir / "features" / "0.json", data, size)) return 0;

    // The viewer: open the folder, then the records of a few picked features.
    ClientOptions options;
    options.loader.decode_threads = 1;
    Status st;
    std::unique_ptr<StreamingClient> client = StreamingClient::open(dir.string(), options, &st);
    if (!client) __builtin_trap();  // the folder's index is fine: only the table is fuzzed
    for (const uint32_t feature : {0u, 2u, 1u, 3u}) {
        std::string record;
        (void)client->featureRecord(feature, &record);
    }
    client.reset();

    // inspect: every problem is a defect line.
    (void)tiles::inspectTileFolder(dir, 1);
    return 0;
}
