// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The client's names for the folder model of the format library
// (format/tileset_index.h): the tree, its blocks and layers, as the render
// stages use them.

#include "format/tileset_index.h"

namespace cityatlas::render {

using format::BlockId;
using format::BlockInfo;
using format::BlockKind;
using format::blockKindName;
using format::BuildInfo;
using format::FeatureTableInfo;
using format::kLayerCount;
using format::kBlockKinds;
using format::kNoBlock;
using format::layerName;
using format::MaterialInfo;
using format::NodeLayer;
using format::parseTilesetIndex;
using format::TextureInfo;
using format::TileNode;
using format::TilesetIndex;

}  // namespace cityatlas::render
