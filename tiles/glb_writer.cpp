// SPDX-License-Identifier: GPL-3.0-or-later
#include "tiles/glb_writer.h"

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

using nlohmann::json;

static_assert(std::endian::native == std::endian::little, "GLB is little-endian; add byte swapping");

// GLB container (glTF 2.0, section "Binary glTF Layout").
constexpr uint32_t kGlbMagic = 0x46546C67;   // "glTF"
constexpr uint32_t kChunkJson = 0x4E4F534A;  // "JSON"
constexpr uint32_t kChunkBin = 0x004E4942;   // "BIN\0"
constexpr size_t kGlbHeader = 12, kChunkHeader = 8;

// glTF enums.
constexpr int kFloat = 5126;
constexpr int kUnsignedShort = 5123;
constexpr int kUnsignedInt = 5125;
constexpr int kTriangles = 4;

constexpr const char* kDracoExtension = "KHR_draco_mesh_compression";

// One attribute as it goes into Draco and into the glTF.
struct AttributeSpec {
    const char* label;  ///< for messages
    draco::GeometryAttribute::Type draco_type;
    int components;
    const char* gltf_type;
};
constexpr std::array<AttributeSpec, 6> kAttributes{{
    {"POSITION", draco::GeometryAttribute::POSITION, 3, "VEC3"},
    {"uv_original", draco::GeometryAttribute::TEX_COORD, 2, "VEC2"},
    {"uv_atlas", draco::GeometryAttribute::TEX_COORD, 2, "VEC2"},
    // GENERIC and never given a quantization: Draco then stores the float32
    // values verbatim, so ids up to 2^24 survive exactly.
    {kTileFeatureIdAttribute, draco::GeometryAttribute::GENERIC, 1, "SCALAR"},
    {kTileTextureIdAttribute, draco::GeometryAttribute::GENERIC, 1, "SCALAR"},
    {kTileMaterialIdAttribute, draco::GeometryAttribute::GENERIC, 1, "SCALAR"},
}};
enum Slot : size_t { kPos = 0, kUv0 = 1, kUv1 = 2, kFid = 3, kTex = 4, kMat = 5, kSlots = 6 };
constexpr std::array<Slot, 2> kSignedIdSlots{kTex, kMat};

// glTF forbids TEXCOORD_1 without TEXCOORD_0 (the validator's
// MESH_PRIMITIVE_INDEXED_SEMANTIC_CONTINUITY), so the uv sets present are
// numbered in order and the primitive's extras say which is which:
// {"cityatlas_texcoords": ["original", "atlas"]}. Without that list a reader
// takes TEXCOORD_0 as original and TEXCOORD_1 as atlas.
constexpr const char* kTexcoordExtras = "cityatlas_texcoords";
constexpr std::array<const char*, 2> kTexcoordSetNames{"original", "atlas"};  // slots kUv0, kUv1

// Decoded values of one attribute, per point, as float32.
using Values = std::vector<float>;  // components * points

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

// (Debian's libdraco does not export Status::code_string.)
std::string dracoMessage(const draco::Status& s) {
    return s.error_msg_string().empty() ? fmt::format("code {}", static_cast<int>(s.code())) : s.error_msg_string();
}

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

// A decoded Draco mesh, read defensively (the bytes may be anything).
struct Decoded {
    uint32_t points = 0;
    std::vector<std::array<uint32_t, 3>> faces;
    std::array<Values, kSlots> values;
    std::array<bool, kSlots> present{};
};

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

// Decodes a Draco blob holding the attributes in `wanted` (unique ids per slot,
// -1 = absent). Never throws.
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

uint32_t getU32(const uint8_t* p) {
    uint32_t v = 0;
    std::memcpy(&v, p, 4);
    return v;
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
                                        e.dump(-1, ' ', false, json::error_handler_t::replace)));
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

}  // namespace cityatlas::tiles
