// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The tile reader of format/tileset_document.h on an already parsed JSON
/// value, for `inspect`, which walks the tree itself so that one unreadable
/// tile is one defect and its siblings are still checked.

#include <string>

#include <nlohmann/json.hpp>

#include "format/tileset_document.h"

namespace cityatlas::format {

/// Reads one tile's own fields (not its children: `children` is left empty).
/// Errors are one line starting with `where`.
Status readTileEntry(const nlohmann::json& tile, const std::string& where, TileEntry* out);

}  // namespace cityatlas::format
