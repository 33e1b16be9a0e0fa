// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// The tiles stage (not implemented yet; see issue "Tiles stage"): writes an
/// AtlasTree as a static folder — tileset.json, Draco glTF geometry and DDS
/// (BC1/BC3) textures — and reads it back for the client.

#include "atlas/atlas_tree.h"
