// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/texel_budget.h"

#include <algorithm>
#include <cmath>

namespace cityatlas::atlas {

uint64_t bcBytesWithMips(int width, int height, int channels) {
    constexpr uint64_t kDdsHeader = 128;
    const uint64_t block = channels == 4 ? 16 : 8;
    uint64_t bytes = kDdsHeader;
    int w = std::max(1, width), h = std::max(1, height);
    for (;;) {
        bytes += static_cast<uint64_t>((w + 3) / 4) * static_cast<uint64_t>((h + 3) / 4) * block;
        if (w == 1 && h == 1) break;
        w = std::max(1, w / 2), h = std::max(1, h / 2);
    }
    return bytes;
}

std::vector<NativeSize> nativeSizes(const Scene& scene) { return nativeSizes(scene.textures); }

std::vector<NativeSize> nativeSizes(const TextureTable& textures) {
    std::vector<NativeSize> n(textures.size());
    for (size_t i = 0; i < n.size(); ++i) n[i] = {std::max(0, textures[i].width_px), std::max(0, textures[i].height_px)};
    return n;
}

double uniqueFraction(const Vec2d& lo, const Vec2d& hi) {
    auto axis = [](double span) { return span > 1.0 ? 1.0 / span : 1.0; };
    return axis(hi.x - lo.x) * axis(hi.y - lo.y);
}

void accountTexels(const Scene& scene, AtlasTree& tree) {
    AtlasStats& s = tree.stats;
    s.atlases = s.atlas_texture_bytes = s.packed_texels = s.leaf_atlas_texels = 0;
    s.texels = {};
    s.bytes = {};
    double content_required = 0, content_native = 0, repeats = 0, borders = 0;
    uint64_t region_texels = 0;
    std::vector<uint8_t> used(scene.textures.size(), 0), capped(scene.textures.size(), 0),
        needed(scene.textures.size(), 0);
    for (const AtlasNode& n : tree.nodes) {
        for (int l = 0; l < kLayerCount; ++l) {
            const NodeLayer& nl = n.layers[l];
            if (nl.atlas_path.empty() || nl.width <= 0) continue;
            const uint64_t texels = static_cast<uint64_t>(nl.width) * static_cast<uint64_t>(nl.height);
            const int channels = l == static_cast<int>(Layer::Alpha) ? 4 : 3;
            ++s.atlases;
            s.atlas_texture_bytes += texels * static_cast<uint64_t>(channels);
            s.bytes.atlases += bcBytesWithMips(nl.width, nl.height, channels);
            if (!n.leaf()) {
                s.texels.inner += texels;
                continue;
            }
            s.leaf_atlas_texels += texels;
            s.packed_texels += nl.packed_texels;
            uint64_t covered = 0;
            for (const PackedRegion& r : nl.regions) {
                const double content = r.content_w * r.content_h;
                const double unique = content * uniqueFraction(r.content_uv_min, r.content_uv_max);
                (r.native_u || r.native_v ? content_native : content_required) += unique;
                repeats += content - unique;
                borders += (r.content_w + 2.0 * r.border_u) * (r.content_h + 2.0 * r.border_v) - content;
                covered += static_cast<uint64_t>(r.w) * static_cast<uint64_t>(r.h);
                if (r.texture >= 0 && static_cast<size_t>(r.texture) < used.size())
                    capped[static_cast<size_t>(r.texture)] |= r.native_u || r.native_v;
            }
            region_texels += covered;
            s.texels.empty += texels - std::min(texels, covered);
        }
        for (int32_t t : n.originals)
            if (t >= 0 && static_cast<size_t>(t) < needed.size()) needed[static_cast<size_t>(t)] = 1;
    }
    for (const TreeTriangle& t : tree.triangles)
        if (t.tri.texture >= 0 && static_cast<size_t>(t.tri.texture) < used.size()) used[static_cast<size_t>(t.tri.texture)] = 1;
    // Integers that add up: the rounding takes what the rounded parts leave.
    s.texels.content_required = static_cast<uint64_t>(std::llround(content_required));
    s.texels.content_native = static_cast<uint64_t>(std::llround(content_native));
    s.texels.repeats = static_cast<uint64_t>(std::llround(repeats));
    s.texels.borders = static_cast<uint64_t>(std::llround(borders));
    uint64_t parts = s.texels.content_required + s.texels.content_native + s.texels.repeats + s.texels.borders;
    if (parts > region_texels) {  // forced leaves clamp regions below content + border
        const uint64_t over = std::min(parts - region_texels, s.texels.borders);
        s.texels.borders -= over, parts -= over;
    }
    s.texels.rounding = region_texels > parts ? region_texels - parts : 0;
    s.textures_upsampled = s.textures_exact = s.textures_needing_originals = 0;
    for (size_t t = 0; t < used.size(); ++t) {
        if (!used[t]) continue;
        const TextureInfo& ref = scene.textures[t];
        const uint64_t bytes = bcBytesWithMips(std::max(1, ref.width_px), std::max(1, ref.height_px), ref.channels == 4 ? 4 : 3);
        s.bytes.originals_used += bytes;
        s.textures_upsampled += capped[t];
        if (needed[t]) {
            ++s.textures_needing_originals;
            s.bytes.originals_needed += bytes;
        } else {
            ++s.textures_exact;
        }
    }
}

}  // namespace cityatlas::atlas
