// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// The atlas report (schema: schemas/atlas_report.schema.json).

#include <nlohmann/json.hpp>

#include "atlas/atlas_tree.h"

namespace cityatlas::atlas {

/// Coverage of a leaf layer: packed region area over its atlas's area.
double leafCoverage(const NodeLayer& layer);

/// The texel budget and the byte budget as the atlas and build reports write them.
nlohmann::ordered_json texelBudgetJson(const TexelBudget& b);
nlohmann::ordered_json byteBudgetJson(const ByteBudget& b);
/// The default d_min's candidates: [{d_m, ratio, originals_within_d_min_mb}, ...].
nlohmann::ordered_json dminCandidatesJson(const DminChoice& choice);

/// Every AtlasParams field by name (the atlas report's "parameters"; a sharded build's plan).
nlohmann::ordered_json atlasParamsJson(const AtlasParams& p);
nlohmann::ordered_json makeAtlasReport(const AtlasTree& tree, const Scene& scene, const Diagnostics& diagnostics);

}  // namespace cityatlas::atlas
