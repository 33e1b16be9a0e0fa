// SPDX-License-Identifier: GPL-3.0-or-later
#include "format/glb_reader.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <memory>
#include <optional>
#include <string>

#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/mesh/mesh.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "format/glb_detail.h"

namespace cityatlas::format {
namespace glb_detail {
namespace {

// Reads attribute `unique_id` as `components` float32 per point.
std::optional<std::string> readAttribute(const draco::Mesh& mesh, uint32_t unique_id, const AttributeSpec& spec,
                                         Values* out) {
    const draco::PointAttribute* att = mesh.GetAttributeByUniqueId(unique_id);
    if (att == nullptr) return fmt::format("the Draco mesh has no attribute {} for {}", unique_id, spec.label);
    if (att->data_type() != draco::DT_FLOAT32 || att->num_components() != spec.components)
        return fmt::format("{} in the Draco mesh is not {} float32 component(s)", spec.label, spec.components);
    const uint32_t n = mesh.num_points();
    if (!att->is_mapping_identity() && att->indices_map_size() < n)
        return fmt::format("{} in the Draco mesh maps fewer values than points", spec.label);
    out->assign(size_t{n} * spec.components, 0.0f);
    for (uint32_t p = 0; p < n; ++p) {
        const draco::AttributeValueIndex avi = att->mapped_index(draco::PointIndex(p));
        if (avi.value() >= att->size()) return fmt::format("{} in the Draco mesh maps a point out of range", spec.label);
        bool ok = false;
        float* dst = out->data() + size_t{p} * spec.components;
        if (spec.components == 3) {
            std::array<float, 3> v{};
            ok = att->GetValue<float, 3>(avi, &v);
            std::copy(v.begin(), v.end(), dst);
        } else if (spec.components == 2) {
            std::array<float, 2> v{};
            ok = att->GetValue<float, 2>(avi, &v);
            std::copy(v.begin(), v.end(), dst);
        } else {
            std::array<float, 1> v{};
            ok = att->GetValue<float, 1>(avi, &v);
            dst[0] = v[0];
        }
        if (!ok) return fmt::format("{} in the Draco mesh reads past its data", spec.label);
    }
    return std::nullopt;
}


}  // namespace

std::optional<std::string> decodeDraco(const uint8_t* data, size_t size, const std::array<int64_t, kSlots>& wanted,
                                       Decoded* out) {
    try {
        draco::DecoderBuffer buffer;
        buffer.Init(reinterpret_cast<const char*>(data), size);
        draco::Decoder decoder;
        auto result = decoder.DecodeMeshFromBuffer(&buffer);
        if (!result.ok()) return fmt::format("Draco cannot decode the mesh: {}", dracoMessage(result.status()));
        const std::unique_ptr<draco::Mesh>& mesh = result.value();
        if (mesh == nullptr) return std::string("Draco returned no mesh");
        out->points = mesh->num_points();
        out->faces.resize(mesh->num_faces());
        for (uint32_t f = 0; f < mesh->num_faces(); ++f) {
            const draco::Mesh::Face& face = mesh->face(draco::FaceIndex(f));
            for (int k = 0; k < 3; ++k) {
                if (face[k].value() >= out->points)
                    return fmt::format("Draco triangle {} names point {} of {}", f, face[k].value(), out->points);
                out->faces[f][k] = face[k].value();
            }
        }
        for (size_t s = 0; s < kSlots; ++s) {
            out->present[s] = wanted[s] >= 0;
            if (!out->present[s]) continue;
            if (auto why = readAttribute(*mesh, static_cast<uint32_t>(wanted[s]), kAttributes[s], &out->values[s]))
                return why;
        }
        return std::nullopt;
    } catch (const std::exception& e) {  // bad_alloc on absurd counts in a damaged blob
        return fmt::format("Draco failed: {}", e.what());
    }
}

}  // namespace glb_detail

using nlohmann::json;
using namespace glb_detail;

namespace {

// JSON helpers that never throw: the JSON chunk may be anything.
const json* member(const json& j, const char* key) {
    if (!j.is_object()) return nullptr;
    auto it = j.find(key);
    return it == j.end() ? nullptr : &*it;
}
std::optional<uint64_t> asIndex(const json* j) {
    if (j == nullptr || !j->is_number_unsigned()) return std::nullopt;
    return j->get<uint64_t>();
}
const json* element(const json& root, const char* array, const json* index) {
    const json* a = member(root, array);
    const auto i = asIndex(index);
    if (a == nullptr || !a->is_array() || !i || *i >= a->size()) return nullptr;
    return &(*a)[static_cast<size_t>(*i)];
}

struct Chunks {
    const uint8_t* json = nullptr;
    size_t json_size = 0;
    const uint8_t* bin = nullptr;
    size_t bin_size = 0;
    bool has_bin = false;
};

Status readChunks(const std::vector<uint8_t>& bytes, Chunks* out) {
    const size_t size = bytes.size();
    if (size < kGlbHeader)
        return Status::Invalid(fmt::format("tile glb: truncated: {} bytes, the GLB header alone has 12", size));
    if (getU32(bytes.data()) != kGlbMagic) return Status::Invalid("tile glb: bad magic: not a binary glTF file");
    if (const uint32_t v = getU32(bytes.data() + 4); v != 2)
        return Status::Invalid(fmt::format("tile glb: GLB version {}, expected 2", v));
    const uint64_t length = getU32(bytes.data() + 8);
    if (length > size)
        return Status::Invalid(fmt::format("tile glb: truncated: the header says {} bytes, {} present", length, size));
    if (length < size)
        return Status::Invalid(fmt::format("tile glb: {} bytes after the {} the header declares", size - length, length));
    uint64_t at = kGlbHeader;
    for (int chunk = 0; at < length; ++chunk) {
        if (length - at < kChunkHeader)
            return Status::Invalid(fmt::format("tile glb: truncated chunk header at byte {}", at));
        const uint64_t n = getU32(bytes.data() + at);
        const uint32_t type = getU32(bytes.data() + at + 4);
        at += kChunkHeader;
        if (n > length - at)
            return Status::Invalid(fmt::format("tile glb: truncated: chunk {} at byte {} needs {} bytes, {} left", chunk,
                                            at - kChunkHeader, n, length - at));
        if (chunk == 0 && type != kChunkJson) return Status::Invalid("tile glb: the first chunk is not JSON");
        if (chunk == 0) {
            out->json = bytes.data() + at;
            out->json_size = n;
        } else if (chunk == 1 && type == kChunkBin) {
            out->bin = bytes.data() + at;
            out->bin_size = n;
            out->has_bin = true;
        }  // other chunks: ignored, as the spec says
        at += n;
    }
    if (out->json == nullptr) return Status::Invalid("tile glb: no JSON chunk");
    return Status::Ok();
}

// Checks that the accessor for `name` states what Draco decoded.
std::optional<std::string> checkAccessor(const json& gltf, const json* index, const char* name, int component_type,
                                         const char* type, uint64_t count) {
    const json* acc = element(gltf, "accessors", index);
    if (acc == nullptr) return fmt::format("{} names no accessor", name);
    const auto ct = asIndex(member(*acc, "componentType"));
    const json* t = member(*acc, "type");
    const auto n = asIndex(member(*acc, "count"));
    if (!ct || (component_type >= 0 && *ct != static_cast<uint64_t>(component_type)) || t == nullptr ||
        !t->is_string() || t->get_ref<const std::string&>() != type)
        return fmt::format("the {} accessor is not {} of the expected component type", name, type);
    if (!n || *n != count) return fmt::format("the {} accessor has count {} but Draco decoded {}", name, n.value_or(0), count);
    return std::nullopt;
}

}  // namespace

Status decodeTileGlb(const std::vector<uint8_t>& bytes, const Vec3d& centre, TileMesh* out) {
    Chunks chunks;
    if (Status st = readChunks(bytes, &chunks); !st.ok()) return st;
    const json gltf = json::parse(chunks.json, chunks.json + chunks.json_size, nullptr, false);
    if (gltf.is_discarded() || !gltf.is_object()) return Status::Invalid("tile glb: the JSON chunk is not a JSON object");
    auto fail = [](const std::string& why) { return Status::Invalid("tile glb: " + why); };

    const json* version = member(gltf, "asset") != nullptr ? member(*member(gltf, "asset"), "version") : nullptr;
    if (version == nullptr || !version->is_string() || version->get_ref<const std::string&>() != "2.0")
        return fail("asset.version is not \"2.0\"");
    if (const json* req = member(gltf, "extensionsRequired"); req != nullptr) {
        if (!req->is_array()) return fail("extensionsRequired is not an array");
        for (const json& e : *req)
            if (!e.is_string() || e.get_ref<const std::string&>() != kDracoExtension)
                return fail(fmt::format("requires extension {}, which this reader does not know",
                                        // only a string is dumped: dump recurses once per nesting level
                                        e.is_string() ? e.dump(-1, ' ', false, json::error_handler_t::replace)
                                                      : std::string("(not a string)")));
    }
    const json* meshes = member(gltf, "meshes");
    if (meshes == nullptr || !meshes->is_array() || meshes->size() != 1) return fail("expected exactly one mesh");
    const json* prims = member((*meshes)[0], "primitives");
    if (prims == nullptr || !prims->is_array() || prims->size() != 1)
        return fail("expected exactly one primitive in the mesh");
    const json& prim = (*prims)[0];
    if (const json* mode = member(prim, "mode"); mode != nullptr && asIndex(mode) != uint64_t{kTriangles})
        return fail("the primitive is not TRIANGLES");
    const json* exts = member(prim, "extensions");
    const json* draco_ext = exts != nullptr ? member(*exts, kDracoExtension) : nullptr;
    if (draco_ext == nullptr) return fail(fmt::format("the primitive has no {} extension", kDracoExtension));
    const json* draco_attrs = member(*draco_ext, "attributes");
    const json* prim_attrs = member(prim, "attributes");
    if (draco_attrs == nullptr || !draco_attrs->is_object() || prim_attrs == nullptr || !prim_attrs->is_object())
        return fail("the primitive or its Draco extension has no attributes object");

    // The blob: a bufferView of the GLB's own buffer (buffer 0 without uri).
    const json* view = element(gltf, "bufferViews", member(*draco_ext, "bufferView"));
    if (view == nullptr) return fail("the Draco extension names no bufferView");
    const json* buffer = element(gltf, "buffers", member(*view, "buffer"));
    if (buffer == nullptr || asIndex(member(*view, "buffer")) != uint64_t{0} || member(*buffer, "uri") != nullptr)
        return fail("the Draco bufferView is not in the GLB's BIN chunk (buffer 0 without uri)");
    if (!chunks.has_bin) return fail("no BIN chunk");
    const auto offset = member(*view, "byteOffset") != nullptr ? asIndex(member(*view, "byteOffset")) : uint64_t{0};
    const auto length = asIndex(member(*view, "byteLength"));
    if (!offset || !length || *offset > chunks.bin_size || *length > chunks.bin_size - *offset)
        return fail(fmt::format("the Draco bufferView (offset {}, length {}) lies outside the {}-byte BIN chunk",
                                offset.value_or(0), length.value_or(0), chunks.bin_size));

    // glTF attribute name of each slot (empty: absent).
    std::array<std::string, kSlots> names{"POSITION",         "TEXCOORD_0", "TEXCOORD_1", kTileFeatureIdAttribute,
                                          kTileTextureIdAttribute, kTileMaterialIdAttribute};
    if (const json* extras = member(prim, "extras"); extras != nullptr && member(*extras, kTexcoordExtras) != nullptr) {
        const json& sets = *member(*extras, kTexcoordExtras);
        names[kUv0].clear();
        names[kUv1].clear();
        if (!sets.is_array() || sets.size() > 2) return fail(fmt::format("{} is not a list of uv sets", kTexcoordExtras));
        for (size_t k = 0; k < sets.size(); ++k) {
            const auto* set = sets[k].is_string() ? &sets[k].get_ref<const std::string&>() : nullptr;
            const size_t slot = set != nullptr && *set == kTexcoordSetNames[0] ? kUv0
                                : set != nullptr && *set == kTexcoordSetNames[1] ? kUv1
                                                                                 : kSlots;
            if (slot == kSlots || !names[slot].empty())
                return fail(fmt::format("{} names an unknown or repeated uv set", kTexcoordExtras));
            names[slot] = fmt::format("TEXCOORD_{}", k);
        }
    }
    std::array<int64_t, kSlots> wanted{};
    for (size_t s = 0; s < kSlots; ++s) {
        wanted[s] = -1;
        const json* id = names[s].empty() ? nullptr : member(*draco_attrs, names[s].c_str());
        if (id == nullptr) continue;
        const auto v = asIndex(id);
        if (!v || *v > std::numeric_limits<uint32_t>::max())
            return fail(fmt::format("the Draco id of {} is not an unsigned integer", names[s]));
        if (member(*prim_attrs, names[s].c_str()) == nullptr)
            return fail(fmt::format("{} is compressed but not an attribute of the primitive", names[s]));
        wanted[s] = static_cast<int64_t>(*v);
    }
    if (wanted[kPos] < 0) return fail("the Draco extension has no POSITION");

    Decoded d;
    if (auto why = decodeDraco(chunks.bin + *offset, static_cast<size_t>(*length), wanted, &d)) return fail(*why);

    for (size_t s = 0; s < kSlots; ++s) {
        if (!d.present[s]) continue;
        const AttributeSpec& spec = kAttributes[s];
        if (auto why = checkAccessor(gltf, member(*prim_attrs, names[s].c_str()), names[s].c_str(), kFloat, spec.gltf_type,
                                     d.points))
            return fail(*why);
    }
    if (auto why = checkAccessor(gltf, member(prim, "indices"), "indices", -1, "SCALAR", 3 * d.faces.size()))
        return fail(*why);

    TileMesh m;
    m.positions.resize(d.points);
    for (uint32_t i = 0; i < d.points; ++i) {
        const float* p = &d.values[kPos][3 * size_t{i}];
        m.positions[i] = {static_cast<double>(p[0]) + centre.x, static_cast<double>(p[1]) + centre.y,
                          static_cast<double>(p[2]) + centre.z};
    }
    auto uvs = [&](Slot s, std::vector<Vec2d>* dst) {
        if (!d.present[s]) return;
        dst->resize(d.points);
        for (uint32_t i = 0; i < d.points; ++i)
            (*dst)[i] = {static_cast<double>(d.values[s][2 * size_t{i}]),
                         1.0 - static_cast<double>(d.values[s][2 * size_t{i} + 1])};
    };
    uvs(kUv0, &m.uv_original);
    uvs(kUv1, &m.uv_atlas);
    if (d.present[kFid]) {
        m.feature_id.resize(d.points);
        for (uint32_t i = 0; i < d.points; ++i) {
            const float f = d.values[kFid][i];
            // Written as exact integers; anything else means a damaged file.
            if (!(f >= 0.0f && f <= static_cast<float>(kMaxTileFeatureId)) || f != std::floor(f))
                return fail(fmt::format("feature id {} of vertex {} is not an integer in 0..2^24", f, i));
            m.feature_id[i] = static_cast<uint32_t>(f);
        }
    }
    for (Slot s : kSignedIdSlots) {
        if (!d.present[s]) continue;
        auto& ids = s == kTex ? m.texture_id : m.material_id;
        ids.resize(d.points);
        for (uint32_t i = 0; i < d.points; ++i) {
            const float f = d.values[s][i];
            if (!(f >= -1.0f && f <= static_cast<float>(kMaxTileFeatureId)) || f != std::floor(f))
                return fail(fmt::format("{} {} of vertex {} is not an integer in -1..2^24", kAttributes[s].label, f, i));
            ids[i] = static_cast<int32_t>(f);
        }
    }
    m.indices.reserve(3 * d.faces.size());
    for (const auto& f : d.faces) m.indices.insert(m.indices.end(), f.begin(), f.end());
    *out = std::move(m);
    return Status::Ok();
}


}  // namespace cityatlas::format
