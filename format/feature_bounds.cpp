// SPDX-License-Identifier: GPL-3.0-or-later
#include "format/feature_bounds.h"

#include <string>

#include <fmt/format.h>

#include "format/little_endian.h"

namespace cityatlas::format {

static_assert(sizeof(float) == 4);

std::vector<uint8_t> encodeFeatureBounds(std::span<const FeatureBoundsRecord> records) {
    std::vector<uint8_t> bytes(records.size() * kFeatureBoundsBytes);
    for (size_t i = 0; i < records.size(); ++i) {
        const FeatureBoundsRecord& r = records[i];
        uint8_t* p = bytes.data() + i * kFeatureBoundsBytes;
        for (int k = 0; k < 3; ++k) putLe(p + 4 * k, r.min[k]);
        for (int k = 0; k < 3; ++k) putLe(p + 12 + 4 * k, r.max[k]);
        putLe(p + 24, r.base_z);
        putLe(p + 28, r.azimuth_half);
        putLe(p + 30, r.flags);
    }
    return bytes;
}

Status decodeFeatureBounds(std::span<const uint8_t> bytes, const std::string& where,
                           std::vector<FeatureBoundsRecord>* out) {
    out->clear();
    if (bytes.size() % kFeatureBoundsBytes != 0)
        return Status::Invalid(fmt::format("{}: {} bytes is not a whole number of {}-byte feature records", where,
                                           bytes.size(), kFeatureBoundsBytes));
    constexpr uint16_t kKnown =
        FeatureBoundsRecord::kHasGeometry | FeatureBoundsRecord::kHasWall | FeatureBoundsRecord::kTextured;
    out->resize(bytes.size() / kFeatureBoundsBytes);
    for (size_t i = 0; i < out->size(); ++i) {
        const uint8_t* p = bytes.data() + i * kFeatureBoundsBytes;
        FeatureBoundsRecord& r = (*out)[i];
        for (int k = 0; k < 3; ++k) r.min[k] = getLe<float>(p + 4 * k);
        for (int k = 0; k < 3; ++k) r.max[k] = getLe<float>(p + 12 + 4 * k);
        r.base_z = getLe<float>(p + 24);
        r.azimuth_half = getLe<uint16_t>(p + 28);
        r.flags = getLe<uint16_t>(p + 30);
        if ((r.flags & ~kKnown) != 0)
            return Status::Invalid(fmt::format("{}: feature record {} has unknown flags 0x{:x}", where, i, r.flags));
    }
    return Status::Ok();
}

}  // namespace cityatlas::format
