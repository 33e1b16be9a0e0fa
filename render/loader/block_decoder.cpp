// SPDX-License-Identifier: GPL-3.0-or-later
#include "render/loader/block_decoder.h"

#include <algorithm>
#include <numeric>

#include <fmt/format.h>

#include "format/blockmap_file.h"

#include "format/glb_reader.h"
#include "format/dds.h"

namespace cityatlas::render {

Status decodeGeometryBlock(const TilesetIndex& index, BlockId id, const std::vector<uint8_t>& bytes, MeshData* out) {
    const BlockInfo& info = index.blocks[id];
    format::TileMesh mesh;
    if (Status st = format::decodeTileGlb(bytes, {0, 0, 0}, &mesh); !st.ok()) return Status::Invalid(info.uri + ": " + st.error);
    const NodeLayer& layer = index.nodes[static_cast<size_t>(info.node)].layers[static_cast<size_t>(info.layer)];
    const size_t triangles = mesh.indices.size() / 3;
    if (triangles != layer.triangles)
        return Status::Invalid(fmt::format("{}: {} triangles, tileset.json says {}", info.uri, triangles, layer.triangles));
    const size_t n = mesh.positions.size();
    for (const uint32_t f : mesh.feature_id)
        if (f >= index.feature_count)
            return Status::Invalid(fmt::format("{}: feature id {} out of range ({} features)", info.uri, f, index.feature_count));
    for (const int32_t t : mesh.texture_id)
        if (t < -1 || t >= static_cast<int32_t>(index.textures.size()))
            return Status::Invalid(fmt::format("{}: texture id {} out of range ({} textures)", info.uri, t, index.textures.size()));
    for (const int32_t m : mesh.material_id)
        if (m < -1 || m >= static_cast<int32_t>(index.materials.size()))
            return Status::Invalid(fmt::format("{}: material id {} out of range ({} materials)", info.uri, m, index.materials.size()));

    MeshData& d = *out;
    d = MeshData{};
    d.positions.reserve(n * 3);
    for (const Vec3d& p : mesh.positions) {
        d.positions.push_back(static_cast<float>(p.x));
        d.positions.push_back(static_cast<float>(p.y));
        d.positions.push_back(static_cast<float>(p.z));
    }
    auto uvs = [](const std::vector<Vec2d>& in, std::vector<float>* o) {
        o->reserve(in.size() * 2);
        for (const Vec2d& uv : in) {
            o->push_back(static_cast<float>(uv.x));
            o->push_back(static_cast<float>(uv.y));
        }
    };
    uvs(mesh.uv_atlas, &d.uv_atlas);
    uvs(mesh.uv_original, &d.uv_original);
    d.feature_id = std::move(mesh.feature_id);
    d.texture_id = std::move(mesh.texture_id);
    d.material_id = std::move(mesh.material_id);
    if (d.texture_id.empty()) {
        d.indices = std::move(mesh.indices);
        return Status::Ok();
    }
    // Leaves: each original texture's triangles contiguous, ascending texture id
    // (-1 first), so the renderer binds each texture once.
    std::vector<uint32_t> order(triangles);
    std::iota(order.begin(), order.end(), 0u);
    auto textureOf = [&](uint32_t t) { return d.texture_id[mesh.indices[3 * t]]; };
    std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return textureOf(a) < textureOf(b); });
    d.indices.reserve(mesh.indices.size());
    for (const uint32_t t : order) {
        const int32_t tex = textureOf(t);
        if (d.texture_ranges.empty() || d.texture_ranges.back().texture != tex)
            d.texture_ranges.push_back({tex, static_cast<uint32_t>(d.indices.size()), 0, Box3d{}});
        MeshData::TextureRange& range = d.texture_ranges.back();
        for (int k = 0; k < 3; ++k) {
            const uint32_t v = mesh.indices[3 * t + static_cast<uint32_t>(k)];
            d.indices.push_back(v);
            range.bounds.extend({d.positions[3 * v], d.positions[3 * v + 1], d.positions[3 * v + 2]});
        }
        range.index_count += 3;
    }
    return Status::Ok();
}

Status decodeDds(const uint8_t* data, size_t size, int expect_channels, CompressedTexture* out) {
    format::DdsInfo info;
    if (Status st = format::parseDdsHeader(data, size, &info); !st.ok()) return st;
    if (info.expected_bytes != size)
        return Status::Invalid(fmt::format("{} bytes, the DDS header needs {}", size, info.expected_bytes));
    // BC4 (a computed texture) only where asked for: the renderer samples BC1 and BC3.
    if ((expect_channels && info.channels != expect_channels) || (!expect_channels && info.channels == 1))
        return Status::Invalid(fmt::format("{} in the header, tileset.json says {}", format::bcFormatName(info.channels),
                                        expect_channels ? format::bcFormatName(expect_channels) : "BC1 or BC3"));
    CompressedTexture& t = *out;
    t = CompressedTexture{};
    t.width = info.width;
    t.height = info.height;
    t.channels = info.channels;
    uint64_t offset = 0;
    int w = info.width, h = info.height;
    for (int level = 0; level < info.mips; ++level) {
        const uint64_t bytes = format::bcBlockBytes(w, h, info.channels);
        t.levels.push_back({w, h, offset, bytes});
        offset += bytes;
        w = std::max(1, w / 2);
        h = std::max(1, h / 2);
    }
    t.data.assign(data + info.header_bytes, data + size);
    return Status::Ok();
}

Status decodeBlock(const TilesetIndex& index, BlockId id, const std::vector<uint8_t>& bytes, DecodedBlock* out) {
    const BlockInfo& info = index.blocks[id];
    if (bytes.size() != info.bytes)
        return Status::Invalid(fmt::format("{}: {} bytes, tileset.json says {}", info.uri, bytes.size(), info.bytes));
    out->id = id;
    out->kind = info.kind;
    out->bytes_read = bytes.size();
    switch (info.kind) {
        case BlockKind::Geometry: return decodeGeometryBlock(index, id, bytes, &out->mesh);
        case BlockKind::Atlas: {
            const NodeLayer& l = index.nodes[static_cast<size_t>(info.node)].layers[static_cast<size_t>(info.layer)];
            if (Status st = decodeDds(bytes.data(), bytes.size(), l.atlas_channels, &out->atlas); !st.ok())
                return Status::Invalid(info.uri + ": " + st.error);
            return Status::Ok();
        }
        case BlockKind::Computed:  // a computed texture: BC4, delivered as an atlas is
            if (Status st = decodeDds(bytes.data(), bytes.size(), 1, &out->atlas); !st.ok())
                return Status::Invalid(info.uri + ": " + st.error);
            return Status::Ok();
        case BlockKind::Textures: {
            out->textures.clear();
            for (size_t t = 0; t < index.textures.size(); ++t) {
                const TextureInfo& ti = index.textures[t];
                if (ti.block != info.texture_block) continue;
                CompressedTexture tex;
                if (Status st = decodeDds(bytes.data() + ti.offset, ti.bytes, ti.channels, &tex); !st.ok())
                    return Status::Invalid(fmt::format("{}: texture {} at byte {}: {}", info.uri, t, ti.offset, st.error));
                out->textures.emplace_back(static_cast<int32_t>(t), std::move(tex));
            }
            return Status::Ok();
        }
        case BlockKind::BlockMap: {
            if (Status st = format::decodeBlockMapFile(bytes, info.uri, &out->blockmap); !st.ok()) return st;
            // Its ids reach the id buffer and the lenses' per-building tables.
            for (size_t k = 0; k < out->blockmap.features.size(); ++k)
                if (out->blockmap.features[k] >= index.feature_count)
                    return Status::Invalid(fmt::format("{}: building {} of {} has id {}, the folder has {} buildings",
                                                       info.uri, k, out->blockmap.features.size(),
                                                       out->blockmap.features[k], index.feature_count));
            return Status::Ok();
        }
    }
    return Status::Invalid(info.uri + ": unknown block kind");
}

}  // namespace cityatlas::render
