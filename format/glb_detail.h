// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The tile GLB's layout, shared by its writer (tiles/glb_writer.cpp) and its
// reader (format/glb_reader.cpp): container constants, the attribute table
// (slot -> Draco type, glTF type), the uv-set naming, and the defensive Draco
// decode both use (the writer decodes its own blob again to measure it).
// Internal to those two files.

#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include <draco/attributes/geometry_attribute.h>
#include <draco/core/status.h>
#include <fmt/format.h>

#include "format/tile_mesh.h"

namespace cityatlas::format::glb_detail {

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

// A decoded Draco mesh, read defensively (the bytes may be anything).
struct Decoded {
    uint32_t points = 0;
    std::vector<std::array<uint32_t, 3>> faces;
    std::array<Values, kSlots> values;
    std::array<bool, kSlots> present{};
};

// (Debian's libdraco does not export Status::code_string.)
inline std::string dracoMessage(const draco::Status& s) {
    return s.error_msg_string().empty() ? fmt::format("code {}", static_cast<int>(s.code())) : s.error_msg_string();
}

inline uint32_t getU32(const uint8_t* p) {
    uint32_t v = 0;
    std::memcpy(&v, p, 4);
    return v;
}

/// Decodes a Draco blob holding the attributes in `wanted` (unique ids per
/// slot, -1 = absent); nothing, or why not. Never throws.
std::optional<std::string> decodeDraco(const uint8_t* data, size_t size, const std::array<int64_t, kSlots>& wanted,
                                       Decoded* out);

}  // namespace cityatlas::format::glb_detail
