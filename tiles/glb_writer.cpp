// SPDX-License-Identifier: GPL-3.0-or-later
#include "tiles/glb_writer.h"

#include "format/glb_detail.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <exception>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <unordered_set>
#include <utility>

#include <draco/compression/config/compression_shared.h>
#include <draco/compression/decode.h>
#include <draco/compression/encode.h>
#include <draco/compression/expert_encode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/core/encoder_buffer.h>
#include <draco/mesh/mesh.h>
#include <fmt/format.h>

namespace cityatlas::tiles {
namespace {

using namespace format::glb_detail;

using nlohmann::json;


// The mesh as it goes into Draco: referenced vertices only, in input order,
// float32, relative to the centre, uvs with v flipped to glTF's convention.
struct Compact {
    std::vector<uint32_t> input_vertex;          // compact vertex -> input vertex
    std::vector<std::array<uint32_t, 3>> faces;  // compact indices
    std::array<Values, kSlots> values;           // per slot; empty when absent
    std::array<bool, kSlots> present{};
    size_t dropped = 0;
};

bool fitsFloat(double v) { return std::isfinite(v) && std::isfinite(static_cast<float>(v)); }


Status checkInput(const TileMesh& m, const Vec3d& centre, const DracoSettings& s) {
    if (s.position_bits < 1 || s.position_bits > 30)
        return Status::Internal(fmt::format("tile glb: position_bits {} is outside 1..30", s.position_bits));
    if (s.uv_bits < 1 || s.uv_bits > 30)
        return Status::Internal(fmt::format("tile glb: uv_bits {} is outside 1..30", s.uv_bits));
    if (s.uv_original_bits < 0 || s.uv_original_bits > 30)
        return Status::Internal(fmt::format("tile glb: uv_original_bits {} is outside 0..30", s.uv_original_bits));
    if (s.speed < 0 || s.speed > 10) return Status::Internal(fmt::format("tile glb: speed {} is outside 0..10", s.speed));
    if (!std::isfinite(centre.x) || !std::isfinite(centre.y) || !std::isfinite(centre.z))
        return Status::Internal("tile glb: the centre is not finite");
    const size_t n = m.positions.size();
    // Draco counts points and faces in uint32 (and the glTF indices at most UNSIGNED_INT).
    if (n >= std::numeric_limits<uint32_t>::max() || m.indices.size() / 3 >= std::numeric_limits<uint32_t>::max())
        return Status::Internal(fmt::format("tile glb: {} vertices / {} indices are too many", n, m.indices.size()));
    auto sized = [n](size_t k, const char* what) {
        return k == 0 || k == n ? Status::Ok()
                                : Status::Internal(fmt::format("tile glb: {} has {} entries for {} positions", what, k, n));
    };
    for (const Status& st : {sized(m.uv_original.size(), "uv_original"), sized(m.uv_atlas.size(), "uv_atlas"),
                             sized(m.feature_id.size(), "feature_id"), sized(m.texture_id.size(), "texture_id"),
                             sized(m.material_id.size(), "material_id")})
        if (!st.ok()) return st;
    if (m.indices.size() % 3 != 0)
        return Status::Internal(fmt::format("tile glb: {} indices is not a multiple of 3", m.indices.size()));
    for (size_t i = 0; i < m.indices.size(); ++i)
        if (m.indices[i] >= n)
            return Status::Internal(fmt::format("tile glb: index {} (at {}) is out of range ({} positions)", m.indices[i], i, n));
    for (size_t i = 0; i < n; ++i) {
        const Vec3d r = m.positions[i] - centre;
        if (!fitsFloat(r.x) || !fitsFloat(r.y) || !fitsFloat(r.z))
            return Status::Internal(fmt::format("tile glb: position {} ({}, {}, {}) is not finite or does not fit float32 "
                                            "relative to the centre",
                                            i, m.positions[i].x, m.positions[i].y, m.positions[i].z));
    }
    for (const auto* uv : {&m.uv_original, &m.uv_atlas})
        for (size_t i = 0; i < uv->size(); ++i)
            if (!fitsFloat((*uv)[i].x) || !fitsFloat(1.0 - (*uv)[i].y))
                return Status::Internal(fmt::format("tile glb: texture coordinate {} ({}, {}) is not finite or does not fit "
                                                "float32",
                                                i, (*uv)[i].x, (*uv)[i].y));
    for (size_t i = 0; i < m.feature_id.size(); ++i)
        if (m.feature_id[i] > kMaxTileFeatureId)
            return Status::Internal(fmt::format("tile glb: feature id {} (vertex {}) exceeds 2^24, the largest integer a "
                                            "float32 attribute holds exactly",
                                            m.feature_id[i], i));
    for (const auto* ids : {&m.texture_id, &m.material_id})
        for (size_t i = 0; i < ids->size(); ++i)
            if ((*ids)[i] < -1 || (*ids)[i] > static_cast<int32_t>(kMaxTileFeatureId))
                return Status::Internal(fmt::format("tile glb: texture or material id {} (vertex {}) is outside -1..2^24",
                                                (*ids)[i], i));
    return Status::Ok();
}

std::array<float, 3> relativeFloat(const Vec3d& p, const Vec3d& centre) {
    const Vec3d r = p - centre;  // in double: this is where the precision is kept
    return {static_cast<float>(r.x), static_cast<float>(r.y), static_cast<float>(r.z)};
}

Compact compact(const TileMesh& m, const Vec3d& centre) {
    Compact c;
    const size_t n = m.positions.size();
    std::vector<uint32_t> remap(n, 0);
    std::vector<bool> used(n, false);
    c.faces.reserve(m.indices.size() / 3);
    for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
        const std::array<uint32_t, 3> tri{m.indices[t], m.indices[t + 1], m.indices[t + 2]};
        const auto a = relativeFloat(m.positions[tri[0]], centre), b = relativeFloat(m.positions[tri[1]], centre),
                   d = relativeFloat(m.positions[tri[2]], centre);
        // Edgebreaker builds its connectivity on position values and skips a
        // face with two equal corners; the sequential codec would keep it.
        // Dropping it here makes both codecs write the same triangles.
        if (a == b || b == d || a == d) {
            ++c.dropped;
            continue;
        }
        for (uint32_t v : tri) used[v] = true;
        c.faces.push_back(tri);
    }
    // Used vertices only, in input order: an unused one would widen Draco's
    // quantization range for nothing.
    for (size_t i = 0; i < n; ++i) {
        if (!used[i]) continue;
        remap[i] = static_cast<uint32_t>(c.input_vertex.size());
        c.input_vertex.push_back(static_cast<uint32_t>(i));
    }
    for (auto& f : c.faces)
        for (auto& v : f) v = remap[v];

    c.present = {true,
                 !m.uv_original.empty(),
                 !m.uv_atlas.empty(),
                 !m.feature_id.empty(),
                 !m.texture_id.empty(),
                 !m.material_id.empty()};
    const size_t k = c.input_vertex.size();
    for (size_t s = 0; s < kSlots; ++s)
        if (c.present[s]) c.values[s].reserve(k * kAttributes[s].components);
    for (uint32_t i : c.input_vertex) {
        const auto p = relativeFloat(m.positions[i], centre);
        c.values[kPos].insert(c.values[kPos].end(), p.begin(), p.end());
        // glTF puts v = 0 at the top of the image, the project at the bottom.
        if (c.present[kUv0]) {
            c.values[kUv0].push_back(static_cast<float>(m.uv_original[i].x));
            c.values[kUv0].push_back(static_cast<float>(1.0 - m.uv_original[i].y));
        }
        if (c.present[kUv1]) {
            c.values[kUv1].push_back(static_cast<float>(m.uv_atlas[i].x));
            c.values[kUv1].push_back(static_cast<float>(1.0 - m.uv_atlas[i].y));
        }
        if (c.present[kFid]) c.values[kFid].push_back(static_cast<float>(m.feature_id[i]));
        if (c.present[kTex]) c.values[kTex].push_back(static_cast<float>(m.texture_id[i]));
        if (c.present[kMat]) c.values[kMat].push_back(static_cast<float>(m.material_id[i]));
    }
    return c;
}

// The Draco mesh; attribute unique ids are the slot numbers.
std::unique_ptr<draco::Mesh> dracoMesh(const Compact& c) {
    auto mesh = std::make_unique<draco::Mesh>();
    const auto n = static_cast<uint32_t>(c.input_vertex.size());
    mesh->set_num_points(n);
    for (size_t s = 0; s < kSlots; ++s) {
        if (!c.present[s]) continue;
        const AttributeSpec& spec = kAttributes[s];
        draco::GeometryAttribute ga;
        ga.Init(spec.draco_type, nullptr, static_cast<uint8_t>(spec.components), draco::DT_FLOAT32, false,
                static_cast<int64_t>(sizeof(float)) * spec.components, 0);
        const int id = mesh->AddAttribute(ga, true, n);
        draco::PointAttribute* att = mesh->attribute(id);
        att->set_unique_id(static_cast<uint32_t>(s));
        for (uint32_t i = 0; i < n; ++i)
            att->SetAttributeValue(draco::AttributeValueIndex(i), c.values[s].data() + size_t{i} * spec.components);
    }
    mesh->SetNumFaces(c.faces.size());
    for (size_t f = 0; f < c.faces.size(); ++f)
        mesh->SetFace(draco::FaceIndex(static_cast<uint32_t>(f)),
                      {draco::PointIndex(c.faces[f][0]), draco::PointIndex(c.faces[f][1]), draco::PointIndex(c.faces[f][2])});
    // Equal values (a corner shared by a wall and a roof with different uvs)
    // become one entry, so edgebreaker sees one vertex with an attribute seam
    // instead of two unconnected ones. Point ids are kept.
    mesh->DeduplicateAttributeValues();
    return mesh;
}



int uvOriginalBits(const DracoSettings& s) { return s.uv_original_bits > 0 ? s.uv_original_bits : s.uv_bits; }

Status encodeDraco(const draco::Mesh& mesh, const DracoSettings& s, bool sequential, draco::EncoderBuffer* out) {
    // Per attribute (unique id = slot): the original uvs may need more bits
    // than the atlas uvs (a texture repeated many times within one leaf).
    draco::ExpertEncoder encoder(mesh);
    for (int32_t a = 0; a < mesh.num_attributes(); ++a) {
        const uint32_t slot = mesh.attribute(a)->unique_id();
        if (slot == kPos) encoder.SetAttributeQuantization(a, s.position_bits);
        if (slot == kUv0) encoder.SetAttributeQuantization(a, uvOriginalBits(s));
        if (slot == kUv1) encoder.SetAttributeQuantization(a, s.uv_bits);
    }
    encoder.SetSpeedOptions(s.speed, s.speed);
    if (sequential) encoder.SetEncodingMethod(draco::MESH_SEQUENTIAL_ENCODING);
    const draco::Status st = encoder.EncodeToBuffer(out);
    if (!st.ok()) return Status::Internal(fmt::format("tile glb: Draco cannot encode the mesh: {}", dracoMessage(st)));
    return Status::Ok();
}

// Draco's quantization step for one attribute: the largest extent over the
// components (computed in float32, as Draco does) over 2^bits - 1.
double quantizationStep(const Values& v, int components, int bits) {
    if (v.empty()) return 0;
    std::array<float, 3> lo{}, hi{};
    for (int c = 0; c < components; ++c) lo[c] = hi[c] = v[c];
    for (size_t i = 0; i < v.size(); i += components)
        for (int c = 0; c < components; ++c) {
            lo[c] = std::min(lo[c], v[i + c]);
            hi[c] = std::max(hi[c], v[i + c]);
        }
    float range = 0;
    for (int c = 0; c < components; ++c) range = std::max(range, hi[c] - lo[c]);
    if (range == 0) range = 1;  // Draco's choice for a constant attribute
    return static_cast<double>(range) / static_cast<double>((uint64_t{1} << bits) - 1);
}

// A position as a hashable key (the float bits).
struct PositionKey {
    std::array<uint32_t, 3> bits;
    bool operator==(const PositionKey&) const = default;
};
struct PositionKeyHash {
    size_t operator()(const PositionKey& k) const {
        uint64_t h = 1469598103934665603ull;
        for (uint32_t b : k.bits) h = (h ^ b) * 1099511628211ull;
        return static_cast<size_t>(h);
    }
};
PositionKey keyOf(const float* p) {
    PositionKey k{};
    for (int c = 0; c < 3; ++c) k.bits[c] = std::bit_cast<uint32_t>(p[c] == 0.0f ? 0.0f : p[c]);
    return k;
}

json minMax(const Values& v, int components, bool want_max) {
    json out = json::array();
    for (int c = 0; c < components; ++c) {
        float m = v[c];
        for (size_t i = c; i < v.size(); i += components) m = want_max ? std::max(m, v[i]) : std::min(m, v[i]);
        out.push_back(static_cast<double>(m));  // the float's exact value; printed so it reads back as that
    }
    return out;
}

void putU32(std::vector<uint8_t>& b, uint32_t v) {
    uint8_t raw[4];
    std::memcpy(raw, &v, 4);
    b.insert(b.end(), raw, raw + 4);
}


}  // namespace

size_t drawableTriangles(const TileMesh& mesh, const Vec3d& centre) {
    if (!checkInput(mesh, centre, DracoSettings{}).ok()) return std::max<size_t>(1, mesh.indices.size() / 3);
    return compact(mesh, centre).faces.size();
}

Status encodeTileGlb(const TileMesh& mesh, const Vec3d& centre, const DracoSettings& settings, GlbResult* out,
                     const nlohmann::json& extras) {
    if (Status st = checkInput(mesh, centre, settings); !st.ok()) return st;
    const Compact c = compact(mesh, centre);
    if (c.faces.empty())
        return Status::Internal(fmt::format("tile glb: no triangles to encode ({} given, {} degenerate)",
                                        mesh.indices.size() / 3, c.dropped));
    const std::unique_ptr<draco::Mesh> dm = dracoMesh(c);

    draco::EncoderBuffer blob;
    if (Status st = encodeDraco(*dm, settings, settings.preserve_order, &blob); !st.ok()) return st;

    // Decode the blob that goes into the file: counts and min/max come from it.
    std::array<int64_t, kSlots> wanted{};
    for (size_t s = 0; s < kSlots; ++s) wanted[s] = c.present[s] ? static_cast<int64_t>(s) : -1;
    Decoded file;
    if (auto why = decodeDraco(reinterpret_cast<const uint8_t*>(blob.data()), blob.size(), wanted, &file))
        return Status::Internal("tile glb: decoding our own Draco blob failed: " + *why);

    // The measurement needs each decoded vertex's input vertex. Edgebreaker
    // renumbers vertices (and may split some); the sequential codec keeps them
    // in order and quantizes exactly as edgebreaker does (same Draco
    // quantization transform, computed from the attribute values alone; the
    // prediction that follows is lossless). So the error is measured on a
    // sequential encoding of the same mesh, and every position decoded from the
    // file must be one of those values, bit for bit: a check that the measured
    // numbers describe the file.
    Decoded ordered;
    if (settings.preserve_order) {
        ordered = file;
    } else {
        draco::EncoderBuffer seq;
        if (Status st = encodeDraco(*dm, settings, true, &seq); !st.ok()) return st;
        if (auto why = decodeDraco(reinterpret_cast<const uint8_t*>(seq.data()), seq.size(), wanted, &ordered))
            return Status::Internal("tile glb: decoding the sequential reference failed: " + *why);
    }
    const size_t n = c.input_vertex.size();
    // The correspondence rests on the sequential codec keeping both orders;
    // equal faces prove it for this mesh.
    if (ordered.points != n || ordered.faces != c.faces)
        return Status::Internal(fmt::format("tile glb: Draco's sequential codec did not keep the vertex and triangle order "
                                        "({} -> {} vertices, {} -> {} triangles)",
                                        n, ordered.points, c.faces.size(), ordered.faces.size()));
    if (file.faces.size() != c.faces.size())
        return Status::Internal(fmt::format("tile glb: Draco wrote {} of {} triangles", file.faces.size(), c.faces.size()));

    GlbResult r;
    r.centre = centre;
    for (size_t i = 0; i < n; ++i) {
        const uint32_t in = c.input_vertex[i];
        const float* p = &ordered.values[kPos][3 * i];
        const Vec3d world{static_cast<double>(p[0]) + centre.x, static_cast<double>(p[1]) + centre.y,
                          static_cast<double>(p[2]) + centre.z};
        r.max_position_error_m = std::max(r.max_position_error_m, length(world - mesh.positions[in]));
        auto uvError = [&](Slot s, const std::vector<Vec2d>& uv, double* worst) {
            if (!c.present[s]) return;
            const float* q = &ordered.values[s][2 * i];
            *worst = std::max({*worst, std::abs(static_cast<double>(q[0]) - uv[in].x),
                               std::abs((1.0 - static_cast<double>(q[1])) - uv[in].y)});
        };
        uvError(kUv0, mesh.uv_original, &r.max_uv_original_error);
        uvError(kUv1, mesh.uv_atlas, &r.max_uv_atlas_error);
        if (c.present[kFid] && ordered.values[kFid][i] != static_cast<float>(mesh.feature_id[in]))
            return Status::Internal(fmt::format("tile glb: Draco changed feature id {} of vertex {} to {}", mesh.feature_id[in],
                                            in, ordered.values[kFid][i]));
        for (Slot s : kSignedIdSlots) {
            const auto& ids = s == kTex ? mesh.texture_id : mesh.material_id;
            if (c.present[s] && ordered.values[s][i] != static_cast<float>(ids[in]))
                return Status::Internal(fmt::format("tile glb: Draco changed {} {} of vertex {} to {}", kAttributes[s].label,
                                                ids[in], in, ordered.values[s][i]));
        }
    }
    if (!settings.preserve_order) {
        std::unordered_set<PositionKey, PositionKeyHash> known;
        known.reserve(n);
        for (size_t i = 0; i < n; ++i) known.insert(keyOf(&ordered.values[kPos][3 * i]));
        for (uint32_t i = 0; i < file.points; ++i)
            if (!known.contains(keyOf(&file.values[kPos][3 * i])))
                return Status::Internal(fmt::format("tile glb: the file's vertex {} was quantized differently from the "
                                                "measured reference; the reported error would not describe it",
                                                i));
    }
    r.position_step_m = quantizationStep(c.values[kPos], 3, settings.position_bits);
    r.uv_original_step = quantizationStep(c.values[kUv0], 2, uvOriginalBits(settings));
    r.uv_atlas_step = quantizationStep(c.values[kUv1], 2, settings.uv_bits);
    r.triangles = file.faces.size();
    r.vertices = file.points;
    r.degenerate_triangles_dropped = c.dropped;
    r.draco_bytes = blob.size();

    // --- glTF JSON ---
    json accessors = json::array(), attributes = json::object(), draco_attributes = json::object();
    json texcoord_sets = json::array();
    for (size_t s = 0; s < kSlots; ++s) {
        if (!file.present[s]) continue;
        const AttributeSpec& spec = kAttributes[s];
        std::string name = s == kPos ? "POSITION" : kAttributes[s].label;
        if (s == kUv0 || s == kUv1) {
            name = fmt::format("TEXCOORD_{}", texcoord_sets.size());
            texcoord_sets.push_back(kTexcoordSetNames[s - kUv0]);
        }
        // No bufferView: the extension supplies the data (KHR_draco_mesh_compression).
        accessors.push_back({{"componentType", kFloat},
                             {"count", file.points},
                             {"type", spec.gltf_type},
                             {"min", minMax(file.values[s], spec.components, false)},
                             {"max", minMax(file.values[s], spec.components, true)}});
        attributes[name] = accessors.size() - 1;
        draco_attributes[name] = s;  // the Draco unique id
    }
    // The largest index must stay below the component type's maximum (glTF
    // reserves it as primitive restart).
    accessors.push_back({{"componentType", file.points <= 0xFFFF ? kUnsignedShort : kUnsignedInt},
                         {"count", 3 * file.faces.size()},
                         {"type", "SCALAR"}});
    const size_t indices_accessor = accessors.size() - 1;

    json asset = json::object();
    asset["version"] = "2.0";
    asset["generator"] = "cityatlas";
    if (!extras.is_null()) asset["extras"] = extras;
    json draco_ext = json::object();
    draco_ext["bufferView"] = 0;
    draco_ext["attributes"] = draco_attributes;
    json primitive = json::object();
    primitive["attributes"] = attributes;
    primitive["indices"] = indices_accessor;
    primitive["mode"] = kTriangles;
    primitive["extensions"][kDracoExtension] = draco_ext;
    if (!texcoord_sets.empty()) primitive["extras"][kTexcoordExtras] = texcoord_sets;
    json view = json::object();
    view["buffer"] = 0;
    view["byteOffset"] = 0;
    view["byteLength"] = blob.size();
    json buffer = json::object();
    buffer["byteLength"] = blob.size();

    // Built member by member: nlohmann's nested brace lists are ambiguous
    // between arrays and objects.
    json gltf = json::object();
    gltf["asset"] = asset;
    gltf["extensionsUsed"] = json::array({kDracoExtension});
    gltf["extensionsRequired"] = json::array({kDracoExtension});
    gltf["scene"] = 0;
    gltf["scenes"] = json::array({json::object({{"nodes", json::array({0})}})});
    gltf["nodes"] = json::array({json::object({{"mesh", 0}})});
    gltf["meshes"] = json::array({json::object({{"primitives", json::array({primitive})}})});
    gltf["accessors"] = accessors;
    gltf["bufferViews"] = json::array({view});
    gltf["buffers"] = json::array({buffer});
    // Invalid UTF-8 in caller extras becomes U+FFFD instead of throwing.
    std::string text = gltf.dump(-1, ' ', false, json::error_handler_t::replace);
    text.append((4 - text.size() % 4) % 4, ' ');  // chunks are 4-byte aligned; JSON pads with spaces
    const size_t bin = (blob.size() + 3) / 4 * 4;
    const uint64_t total = kGlbHeader + kChunkHeader + text.size() + kChunkHeader + bin;
    if (total > std::numeric_limits<uint32_t>::max())
        return Status::Internal(fmt::format("tile glb: {} bytes exceed the 4 GiB a GLB can hold", total));

    r.bytes.reserve(total);
    putU32(r.bytes, kGlbMagic);
    putU32(r.bytes, 2);
    putU32(r.bytes, static_cast<uint32_t>(total));
    putU32(r.bytes, static_cast<uint32_t>(text.size()));
    putU32(r.bytes, kChunkJson);
    r.bytes.insert(r.bytes.end(), text.begin(), text.end());
    putU32(r.bytes, static_cast<uint32_t>(bin));
    putU32(r.bytes, kChunkBin);
    const auto* b = reinterpret_cast<const uint8_t*>(blob.data());
    r.bytes.insert(r.bytes.end(), b, b + blob.size());
    r.bytes.resize(total, 0);  // BIN pads with zeros
    *out = std::move(r);
    return Status::Ok();
}

int usefulPositionBits(const TileMesh& m, const Vec3d& centre) {
    Box3d b;
    for (const Vec3d& p : m.positions) b.extend(p - centre);
    const Vec3d size = b.max - b.min;
    const double extent = std::max({size.x, size.y, size.z});
    const double farthest = std::max({std::abs(b.min.x), std::abs(b.min.y), std::abs(b.min.z), std::abs(b.max.x),
                                      std::abs(b.max.y), std::abs(b.max.z)});
    const auto f = static_cast<float>(farthest);
    const double spacing = static_cast<double>(std::nextafter(f, std::numeric_limits<float>::infinity()) - f);
    for (int bits = 1; bits < 30; ++bits)
        if (extent / static_cast<double>((uint64_t{1} << bits) - 1) <= spacing) return bits;
    return 30;
}

}  // namespace cityatlas::tiles
