// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// The atlas stage (not implemented yet; see issue "Atlas stage"): builds the
/// multiresolution texture-atlas tree of papers/001 §5 from a Scene.
///
/// Contract, as DESIGN.md states it: input a Scene (ingest/scene.h); output an
/// AtlasTree — nodes with bounds and minDistance, per-node atlas images on
/// disk, leaf triangle sets with original and root-atlas texture coordinates,
/// and one contiguous triangle range per node.

#include "ingest/scene.h"
