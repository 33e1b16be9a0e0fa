// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target for texture blocks (textures/<k>.bin) as the client reads
// them: the texture table of tileset.json says where each DDS lies in the
// block (parseTilesetIndex checks it), render::decodeBlock slices and decodes
// every DDS of the block, and the renderer's CPU path decodes each level
// (format::decodeBc). Both the table and the block are untrusted, so the input
// carries both:
//
//   byte 0          n = byte % 9 textures
//   n x 9 bytes     offset (u32 LE), bytes (u32 LE), flags (bit 0: BC3, bit 1: block -1)
//   the rest        the block's bytes
//
// Any input gives a Status, never a crash, an exception, a hang or a sanitizer report.
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "render/loader/block_decoder.h"
#include "tests/fuzz/fuzz_support.h"
#include "format/dds.h"

using namespace cityatlas;
using namespace cityatlas::render;
using nlohmann::json;

namespace {

// The smallest tileset.json the client accepts: one node, one texture block.
const char* const kTileset = R"({
  "asset": {"version": "1.1", "tilesetVersion": "fuzz"},
  "geometricError": 1,
  "extras": {"cityatlas": {
    "format_version": 1,
    "build": {"d_min_m": 300, "atlas_size_px": 256, "screen_width_px": 1920, "screen_height_px": 1080,
              "vertical_fov_deg": 60, "focal_px": 935.3, "corner_factor": 1.44, "tau": 1},
    "georeference": {"source_crs": "EPSG:25832", "local_to_ecef": null},
    "materials": [{"diffuse": [0.8, 0.8, 0.8], "transparency": 0}],
    "texture_blocks": [],
    "textures": [],
    "features": {"count": 1, "block_size": 4096, "tables": [{"uri": "features/0.json", "bytes": 10}]}
  }},
  "root": {
    "boundingVolume": {"box": [0, 0, 5, 10, 0, 0, 0, 10, 0, 0, 0, 5]},
    "geometricError": 0.3,
    "refine": "REPLACE",
    "extras": {"cityatlas": {
      "id": 0, "min_distance_m": 300, "world_texel_m": 0.3, "centre": [0, 0, 5],
      "layers": {"opaque": {"triangles": 2, "geometric_error_m": 0, "position_error_mm": 1,
                            "geometry": {"uri": "geometry/opaque/0.glb", "bytes": 1000},
                            "atlas": {"uri": "atlas/opaque/0.dds", "bytes": 1000, "width_px": 64,
                                      "height_px": 64, "format": "BC1", "mips": 7}}},
      "texture_blocks": [0],
      "features": {"count": 1, "tables": [0]}
    }}
  }
})";

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size < 1) return 0;
    const size_t n = data[0] % 9;
    const size_t header = 1 + 9 * n;
    if (size < header) return 0;
    static const json base = json::parse(kTileset);
    json doc = base;
    json& ca = doc["extras"]["cityatlas"];
    const uint64_t block_bytes = size - header;
    ca["texture_blocks"] = json::array({{{"uri", "textures/0.bin"}, {"bytes", block_bytes}}});
    for (size_t i = 0; i < n; ++i) {
        const uint8_t* r = data + 1 + 9 * i;
        const bool bc3 = (r[8] & 1) != 0;
        ca["textures"].push_back({{"block", (r[8] & 2) != 0 ? -1 : 0},
                                  {"offset", fuzz::le32(r)},
                                  {"bytes", fuzz::le32(r + 4)},
                                  {"width", 4},
                                  {"height", 4},
                                  {"mips", 1},
                                  {"format", bc3 ? "BC3" : "BC1"},
                                  {"wrap", "wrap"}});
    }
    TilesetIndex index;
    if (!parseTilesetIndex(doc.dump(), "fuzz/tileset.json", &index).ok()) return 0;
    if (index.texture_block_ids.size() != 1) __builtin_trap();

    const std::vector<uint8_t> block(data + header, data + size);
    DecodedBlock out;
    if (!decodeBlock(index, index.texture_block_ids[0], block, &out).ok()) return 0;
    for (const auto& [texture, t] : out.textures) {
        if (texture < 0 || static_cast<size_t>(texture) >= index.textures.size()) __builtin_trap();
        for (const CompressedTexture::Level& level : t.levels) {
            if (level.offset > t.data.size() || level.bytes > t.data.size() - level.offset) __builtin_trap();
            const std::vector<uint8_t> blocks(t.data.begin() + static_cast<std::ptrdiff_t>(level.offset),
                                              t.data.begin() + static_cast<std::ptrdiff_t>(level.offset + level.bytes));
            (void)format::decodeBc(blocks, level.width, level.height, t.channels);
        }
    }
    return 0;
}
