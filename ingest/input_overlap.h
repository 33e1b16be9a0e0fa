// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Inputs that hold the same buildings twice (a synth folder's CityGML and its
/// footprint shapefile; two exports of one district; a tile read twice under
/// two names) would draw every such building twice. OverlapWatch sits between
/// the readers and the real sink, keeps per building only its id's hash, its
/// file and its ground-plan box (32 bytes), and at the end names every pair of files that share
/// most of their buildings: by gml:id (copies within 50 m of each other), or
/// by footprint (ground-plan boxes equal within kOverlapTolerance_m). It warns; it does not drop anything, since which copy
/// is the one wanted is the user's call.
///
/// A city comes in many files (Berlin's LOD2 in ~1,000 tiles, a federal
/// state's in tens of thousands), so what the watch holds does not grow with
/// it: the buildings' records and the feature -> building map are windowed
/// (core/windowed_records.h: the newest 65,536 in memory, older ones in a
/// scratch file), and the report compares them in two sorted passes
/// (core/external_sort.h, 32 MB each): by id hash, and by ground-plan cell
/// row after row with three rows of cells in memory. Until stop 55 the
/// report's hash maps took ~150 bytes a building at the read's end (1.5 GB
/// for 10 million).

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/status.h"
#include "core/windowed_records.h"
#include "ingest/diagnostics.h"
#include "ingest/scene_sink.h"

namespace cityatlas {

inline constexpr double kOverlapTolerance_m = 1.0;  ///< roof overhangs and rounding between producers
inline constexpr double kOverlapShare = 0.5;        ///< of the smaller file's buildings: "heavily"

class OverlapWatch : public SceneSink {
public:
    /// Records past `window` buildings and sorts past `sort_bytes` go to
    /// scratch files in `scratch_dir` (empty: the system's temporary folder).
    explicit OverlapWatch(SceneSink& inner, const std::filesystem::path& scratch_dir = {},
                          size_t window = size_t{1} << 16, size_t sort_bytes = size_t{32} << 20)
        : inner_(inner), scratch_dir_(scratch_dir), sort_bytes_(sort_bytes), buildings_(scratch_dir, window),
          building_of_(scratch_dir, window) {}
    /// The file the next features come from.
    void beginFile(const std::string& path);
    /// Warns (inputs_overlap) once per pair of files that overlap heavily.
    /// An error: a scratch file could not be written or read (disk full).
    Status report(Diagnostics& diagnostics);

    void setGeoreference(const Georeference& g) override { inner_.setGeoreference(g); }
    int32_t addTexture(const TextureRef& t) override { return inner_.addTexture(t); }
    const TextureTable& textures() const override { return inner_.textures(); }
    int32_t addMaterial(const Material& m) override { return inner_.addMaterial(m); }
    uint32_t addFeature(Feature f) override;
    void setFeatureLod(uint32_t feature, int8_t lod) override { inner_.setFeatureLod(feature, lod); }
    void addTriangles(std::vector<Triangle>& triangles) override;

private:
    // A city's worth of these is held through the read: its id as a hash (a
    // collision would count one false match among a file's thousands), its box
    // in float (metres in the local frame: millimetres against a 1 m tolerance).
    struct Building {
        uint64_t id_hash = 0;
        uint32_t file = 0;
        bool has_id = false;
        float min_x = 1e30f, min_y = 1e30f, max_x = -1e30f, max_y = -1e30f;
    };
    static_assert(sizeof(Building) == 32);
    SceneSink& inner_;
    std::filesystem::path scratch_dir_;
    size_t sort_bytes_;
    std::vector<std::string> files_;
    WindowedRecords<Building> buildings_;    // top-level features only
    WindowedRecords<uint32_t> building_of_;  // feature index -> index into buildings_
    size_t building_count_ = 0;
};

}  // namespace cityatlas
