// SPDX-License-Identifier: GPL-3.0-or-later
#include "format/feature_bounds.h"

#include <bit>
#include <cstring>
#include <string>

#include <fmt/format.h>

namespace cityatlas::format {
namespace {

static_assert(std::endian::native == std::endian::little, "features/bounds/*.bin is little-endian, as this machine");
static_assert(sizeof(float) == 4);

template <typename T>
void put(uint8_t* at, T v) {
    std::memcpy(at, &v, sizeof(T));
}
template <typename T>
T get(const uint8_t* at) {
    T v;
    std::memcpy(&v, at, sizeof(T));
    return v;
}

}  // namespace

std::vector<uint8_t> encodeFeatureBounds(std::span<const FeatureBoundsRecord> records) {
    std::vector<uint8_t> bytes(records.size() * kFeatureBoundsBytes);
    for (size_t i = 0; i < records.size(); ++i) {
        const FeatureBoundsRecord& r = records[i];
        uint8_t* p = bytes.data() + i * kFeatureBoundsBytes;
        for (int k = 0; k < 3; ++k) put(p + 4 * k, r.min[k]);
        for (int k = 0; k < 3; ++k) put(p + 12 + 4 * k, r.max[k]);
        put(p + 24, r.base_z);
        put(p + 28, r.azimuth_half);
        put(p + 30, r.flags);
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
        for (int k = 0; k < 3; ++k) r.min[k] = get<float>(p + 4 * k);
        for (int k = 0; k < 3; ++k) r.max[k] = get<float>(p + 12 + 4 * k);
        r.base_z = get<float>(p + 24);
        r.azimuth_half = get<uint16_t>(p + 28);
        r.flags = get<uint16_t>(p + 30);
        if ((r.flags & ~kKnown) != 0)
            return Status::Invalid(fmt::format("{}: feature record {} has unknown flags 0x{:x}", where, i, r.flags));
    }
    return Status::Ok();
}

}  // namespace cityatlas::format
