// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// The atlas tree's accounts: every atlas texel by what it holds, and the
/// bytes of atlases and originals as the tiles stage will write them.
/// Internal to the atlas stage.

#include <vector>

#include "atlas/atlas_tree.h"
#include "atlas/texel_estimate.h"

namespace cityatlas::atlas {

/// Each scene texture's size as ingest recorded it (0 where unknown).
std::vector<NativeSize> nativeSizes(const Scene& scene);
std::vector<NativeSize> nativeSizes(const TextureTable& textures);

/// The unrepeated fraction of a content box: one period over its span, per axis.
double uniqueFraction(const Vec2d& uv_min, const Vec2d& uv_max);

/// Fills tree.stats' atlas counts, texel budget, byte budget and texture
/// counts (upsampled, exact, needing originals) from a placed tree.
void accountTexels(const Scene& scene, AtlasTree& tree);

}  // namespace cityatlas::atlas
