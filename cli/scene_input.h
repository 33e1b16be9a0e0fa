// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// What every command that reads city data shares: the input options, reading
// CityGML and footprint files into one sink, and tying the frame to the Earth.

#include <filesystem>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "cli/progress.h"
#include "ingest/citygml/citygml_reader.h"
#include "ingest/georef.h"
#include "ingest/output_folder.h"
#include "ingest/scene_sink.h"

namespace cityatlas::cli {

struct SceneInputOptions {
    std::vector<std::string> inputs;
    std::string lod = "best";
    std::string theme;
    std::string crs;
    // Footprints:
    std::vector<std::string> maps;  // ROLE=FIELD
    std::string height_unit = "m";
    double default_height_m = 10, storey_height_m = 3;
    std::string base = "auto";
};

/// Files, folders (searched recursively for city data) and glob patterns ->
/// the input files, in a stable order.
Status expandInputs(const std::vector<std::string>& args, std::vector<std::filesystem::path>* files);

/// Registers the positional inputs and the reading options on `cmd`.
void addSceneInputOptions(CLI::App* cmd, SceneInputOptions* opt);

/// Reads every input into `state.sink` (set by the caller), all in the frame
/// the first one defines; warns (inputs_overlap) about inputs that hold the
/// same buildings. A bad option value fails with StatusCode::kUsage.
Status readInputs(const SceneInputOptions& opt, Progress& progress, IngestState& state,
                  std::vector<std::filesystem::path>* files);

/// Computes the link to the Earth for a scene with these local bounds and
/// hands it to `state.sink` (starting from `current`); a local CRS, or a CRS
/// PROJ cannot place, is a counted warning, not an error.
std::optional<GeorefSummary> attachGeoreference(IngestState& state, const Box3d& bounds_local,
                                                Georeference current, const std::filesystem::path& first_file);

/// "Warnings: N" and, per code, its count and first example (file:line id: detail), on stdout.
void printWarnings(const Diagnostics& diagnostics);

/// Writes `text` to `path` through a sibling temporary file and a rename.
Status writeTextAtomically(const std::filesystem::path& path, const std::string& text);
/// The same for text `write` streams (a document too large to hold as a string).
Status writeAtomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write);

// Output folders: replaceFolder(), startWorkingFolder() (ingest/output_folder.h).
using cityatlas::replaceFolder;
using cityatlas::startWorkingFolder;

}  // namespace cityatlas::cli
