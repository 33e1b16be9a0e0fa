// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// features/bounds/<k>.bin: what the client knows of every building without
/// its geometry (information lenses, BlockMap checks, best views). One file
/// per feature table (features/<k>.json, the same ids in the same order),
/// addressed from tileset.json (extras.cityatlas.features.tables[k].bounds),
/// 32 bytes per feature, little-endian:
///
///   offset  type        field
///   0       float32[3]  min: the feature's axis-aligned box, local frame (m),
///                       rounded outwards from double (it holds every vertex)
///   12      float32[3]  max
///   24      float32     base_z: the lowest point of its ground surfaces
///                       (its box's min z when it has none)
///   28      float16     azimuth_deg: outward normal of its longest wall,
///                       degrees clockwise from the local +y axis (grid
///                       north), in [0, 360); 0 without kHasWall
///   30      uint16      flags (below)
///
/// float32 keeps 2 mm at 16 km from the local origin (a city's extent).

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/status.h"

namespace cityatlas::format {

inline constexpr size_t kFeatureBoundsBytes = 32;

struct FeatureBoundsRecord {
    static constexpr uint16_t kHasGeometry = 1;  ///< the feature has triangles (else every field is 0)
    static constexpr uint16_t kHasWall = 2;      ///< azimuth_half is the longest wall's
    static constexpr uint16_t kTextured = 4;     ///< some triangle of it is textured
    float min[3] = {0, 0, 0};
    float max[3] = {0, 0, 0};
    float base_z = 0;
    uint16_t azimuth_half = 0;  ///< IEEE 754 binary16 bits of azimuth_deg
    uint16_t flags = 0;
};

/// The file's bytes for `records` (32 each).
std::vector<uint8_t> encodeFeatureBounds(std::span<const FeatureBoundsRecord> records);
/// The records of a file's bytes; an error (naming `where`) when the size is
/// not a multiple of 32 or a flag outside the three known is set.
Status decodeFeatureBounds(std::span<const uint8_t> bytes, const std::string& where,
                           std::vector<FeatureBoundsRecord>* out);

}  // namespace cityatlas::format
