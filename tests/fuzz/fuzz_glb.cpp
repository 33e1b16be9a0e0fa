// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target for the geometry block decoder: the GLB framing, its JSON
// chunk and the Draco blob (format::decodeTileGlb), then the client's
// render::decodeBlock for a geometry block (ids against the index, the sort of
// a leaf's triangles by texture). Any bytes give a Status, never a crash, a
// hang or a sanitizer report.
#include <cstdint>
#include <vector>

#include "render/loader/block_decoder.h"
#include "tests/fuzz/fuzz_support.h"
#include "format/glb_reader.h"

using namespace cityatlas;
using namespace cityatlas::render;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::vector<uint8_t> bytes(data, data + size);
    format::TileMesh mesh;
    if (!format::decodeTileGlb(bytes, {0, 0, 0}, &mesh).ok()) return 0;
    // What a decoded mesh promises its users.
    const size_t n = mesh.positions.size();
    if (mesh.indices.size() % 3 != 0) __builtin_trap();
    for (const uint32_t i : mesh.indices)
        if (i >= n) __builtin_trap();
    for (const size_t s : {mesh.uv_original.size(), mesh.uv_atlas.size(), mesh.feature_id.size(), mesh.texture_id.size(),
                           mesh.material_id.size()})
        if (s != 0 && s != n) __builtin_trap();

    // The same bytes as a node layer's geometry block of an index that agrees
    // on the triangle count (otherwise decodeBlock refuses it before looking
    // further), with a few textures and materials for the ids to fall in or out of.
    TilesetIndex index;
    index.nodes.resize(1);
    NodeLayer& layer = index.nodes[0].layers[0];
    layer.present = true;
    layer.geometry = 0;
    layer.triangles = static_cast<uint32_t>(mesh.indices.size() / 3);
    index.blocks.push_back({BlockKind::Geometry, 0, 0, -1, "geometry/opaque/0.glb", size});
    index.textures.resize(size % 7 + 1);
    index.materials.resize(size % 5 + 1);
    index.feature_count = 1u << 12;
    DecodedBlock out;
    if (!decodeBlock(index, 0, bytes, &out).ok()) return 0;
    uint32_t covered = 0;
    for (const MeshData::TextureRange& r : out.mesh.texture_ranges) covered += r.index_count;
    if (!out.mesh.texture_ranges.empty() && covered != out.mesh.indices.size()) __builtin_trap();
    return 0;
}
