// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Atlas sizes and offsets (atlas_tree.h, "Atlas sizes" and "Texture
/// coordinates"): leaves shrink to their content, inner nodes pack their
/// children's halves, offsets follow top-down. Internal to the atlas stage.

#include <vector>

#include "atlas/atlas_tree.h"

namespace cityatlas::atlas {

/// Re-packs regions already placed in an A x A atlas into the smallest atlas
/// of binsByArea(A/16, A, A, 2) that holds them; sets x, y, rotated (and the
/// footprint w, h). Returns that atlas's size; A x A when nothing smaller fits.
BinSize shrinkLeafAtlas(PackingMethod method, int atlas_size, std::vector<PackedRegion>& regions);

/// Where each child's halved atlas lies in its parent's, per layer.
struct ChildPlacement {
    int32_t child = -1;
    int x = 0, y = 0;  ///< texels in the parent's atlas (v up)
};

/// Sizes every inner node layer's atlas (width, height) from its children's
/// (leaves must be sized already) and sets every node layer's offset,
/// root first: offset(root) = 0, offset(child) = 2 (offset(parent) + position).
/// Layers without an atlas get size 0 and their parent's offset doubled.
void placeAtlases(AtlasTree& tree);

/// Each child's position in `node`'s atlas of `layer`, from the offsets.
std::vector<ChildPlacement> childPlacements(const AtlasTree& tree, int32_t node, int layer);

}  // namespace cityatlas::atlas
