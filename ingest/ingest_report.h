// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// The ingest report (report.json; schema: schemas/ingest_report.schema.json).

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "ingest/citygml/citygml_reader.h"
#include "ingest/georef.h"

namespace cityatlas {

struct StepTiming {
    std::string name;
    double seconds = 0;
    double peak_rss_mb = 0;  ///< process peak so far, at the end of the step
};

/// Warnings by code, with their examples: {"code": {"count": n, "examples": [...]}}.
nlohmann::ordered_json warningsJson(const Diagnostics& diagnostics);

nlohmann::ordered_json makeIngestReport(const IngestState& state, const SceneStats& stats, size_t features,
                                        size_t textures, size_t materials, const std::vector<StepTiming>& steps,
                                        const std::string& glb_path, const GeorefSummary* georef = nullptr);

}  // namespace cityatlas
