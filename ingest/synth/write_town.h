// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Writing a synthetic town to disk: CityGML 2.0, a footprint shapefile, the
/// PNG textures and truth.json. Output is byte-identical for equal settings.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/status.h"
#include "ingest/synth/town.h"

namespace cityatlas::synth {

/// File names inside the output folder.
inline constexpr const char* kCityGmlName = "town.gml";
inline constexpr const char* kShapefileName = "footprints.shp";
inline constexpr const char* kTruthName = "truth.json";

/// Called now and then with (step, done, total) while writing.
using ProgressFn = std::function<void(const char* step, uint64_t done, uint64_t total)>;

/// CityGML 2.0 with thematic surfaces (LOD2) or a solid (LOD1), appearances,
/// and every 5th building's rings written as gml:pos lists instead of posList.
Status writeCityGml(const Town& town, const std::filesystem::path& file);

/// ESRI shapefile (.shp/.shx/.dbf/.prj/.cpg) of the footprints and their
/// attributes (see README's "synth" section for the fields).
Status writeFootprintShapefile(const Town& town, const std::filesystem::path& shp_file);

/// All textures, in parallel.
Status writeTextures(const Town& town, const std::filesystem::path& dir, const ProgressFn& progress);

/// What a correct ingest of the town must produce, computed from the polygon
/// rings (never from a triangulation): see schemas/truth.schema.json.
nlohmann::ordered_json makeTruth(const Town& town);

/// Writes everything into `out_dir`, atomically: files go to a temporary
/// sibling folder that is renamed into place at the end, so a failure never
/// leaves a half-written folder. An existing `out_dir` is an error unless
/// `overwrite` is set.
Status writeTown(const Town& town, const std::filesystem::path& out_dir, bool overwrite, const ProgressFn& progress);

/// Shortest decimal text that reads back to exactly `v` (fixed notation, no
/// exponent; "-0" printed as "0"). Locale-independent.
std::string exactDecimal(double v);

}  // namespace cityatlas::synth
