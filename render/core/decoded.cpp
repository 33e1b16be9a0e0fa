// SPDX-License-Identifier: GPL-3.0-or-later
#include "render/core/decoded.h"

namespace cityatlas::render {

uint64_t MeshData::cpuBytes() const {
    return sizeof(float) * (positions.size() + uv_atlas.size() + uv_original.size()) +
           sizeof(uint32_t) * (feature_id.size() + indices.size()) +
           sizeof(int32_t) * (texture_id.size() + material_id.size()) + sizeof(TextureRange) * texture_ranges.size();
}

}  // namespace cityatlas::render
