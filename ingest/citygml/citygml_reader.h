// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Streaming CityGML reader: CityGML 1.0, 2.0 and the building subset of 3.0
/// (elements are matched by local name; namespaces identify the version).
///
/// Two passes over each file, one city object in memory at a time:
///   1. index: checks the whole file is well-formed (so a fatal error never
///      leaves half a result), finds the CRS and the envelope, collects the
///      appearance themes and the global appearances (app:appearanceMember),
///      and indexes gml:ids and xlink targets to find references that cross
///      city objects;
///   (1b. only when such references exist: extracts the referenced geometry;)
///   2. read: expands each cityObjectMember, reads Buildings and their
///      BuildingParts at the chosen LOD, applies appearances, triangulates
///      and hands the triangles to the sink.
/// Memory grows with the largest city object, the global appearances and the
/// cross-object references, not with the file.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "ingest/diagnostics.h"
#include "ingest/local_frame.h"
#include "ingest/scene_sink.h"
#include "core/status.h"

namespace cityatlas {

struct CityGmlOptions {
    int lod = 0;                  ///< 0 = best available <= 2 per building; 1 or 2 = only that LOD
    std::string theme;            ///< appearance theme; empty = the first textured one
    std::string fallback_crs;     ///< srsName for files that declare none (e.g. "EPSG:25832")
    /// Where a reader sorts what outgrows memory (a file's geometry ids);
    /// empty: the system's temporary folder.
    std::filesystem::path scratch_dir;
};

/// What an ingest read, skipped and chose; the report is made from it.
struct IngestCounts {
    std::map<std::string, uint64_t> objects_read;      ///< Building, BuildingPart
    std::map<std::string, uint64_t> objects_skipped;   ///< other city object types, by element name
    std::map<std::string, uint64_t> geometry_skipped;  ///< lod0/3/4 geometry, curves, ... by element name
    uint64_t features_lod1 = 0, features_lod2 = 0, features_without_geometry = 0;
    uint64_t polygons_read = 0, polygons_triangulated = 0, polygons_skipped = 0;
    uint64_t polygons_textured = 0, polygons_coloured = 0, polygons_semantic_inferred = 0;
    uint64_t polygons_shared = 0;  ///< used again by another part of the same building: emitted once
    uint64_t xlinks_resolved = 0, xlinks_cross_object = 0;
    double max_plane_deviation_m = 0;
    std::vector<std::string> themes;   ///< all themes found, in document order
    std::string theme_used;
    uint64_t textures_ok = 0, textures_failed = 0;
    // Footprint inputs:
    uint64_t footprints_read = 0, footprints_repaired = 0, footprints_skipped = 0;
    uint64_t party_walls = 0;       ///< shared edges between touching footprints (pairs)
    uint64_t roof_fallbacks = 0;
    std::map<std::string, uint64_t> roof_shapes;
};

struct InputFileSummary {
    std::string path;
    uint64_t bytes = 0;
    std::string citygml_version;   ///< "1.0", "2.0", "3.0"
    std::string srs_name;          ///< as declared (or the fallback)
    std::string crs;               ///< PROJ's name
    bool has_envelope = false;
    Vec3d envelope_min, envelope_max;  ///< source CRS, as written
    uint64_t buildings = 0;
};

/// State shared by all files of one ingest: the frame (set by the first
/// file), the sink, diagnostics and counts.
struct IngestState {
    CityGmlOptions options;
    SceneSink* sink = nullptr;
    std::unique_ptr<LocalFrame> frame;
    Diagnostics diagnostics;
    IngestCounts counts;
    std::vector<InputFileSummary> files;
    Box3d bounds_source;   ///< of everything read, in the frame's CRS
    /// Called now and then with the pass name and bytes done/total of the current file.
    std::function<void(const char* pass, uint64_t done, uint64_t total)> progress;
};

/// Reads one CityGML file into the state's sink. A failed Status is fatal
/// for the file; its message starts with a code from diagnostics.h.
Status readCityGml(const std::filesystem::path& file, IngestState& state);

}  // namespace cityatlas
