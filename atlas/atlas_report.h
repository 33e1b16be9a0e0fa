// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// The atlas report (schema: schemas/atlas_report.schema.json).

#include <nlohmann/json.hpp>

#include "atlas/atlas_tree.h"

namespace cityatlas::atlas {

/// Coverage of a leaf layer: packed region area over A^2.
double leafCoverage(const AtlasTree& tree, const NodeLayer& layer);

nlohmann::ordered_json makeAtlasReport(const AtlasTree& tree, const Scene& scene, const Diagnostics& diagnostics);

}  // namespace cityatlas::atlas
