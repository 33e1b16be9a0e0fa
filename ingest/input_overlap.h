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

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "ingest/diagnostics.h"
#include "ingest/scene_sink.h"

namespace cityatlas {

inline constexpr double kOverlapTolerance_m = 1.0;  ///< roof overhangs and rounding between producers
inline constexpr double kOverlapShare = 0.5;        ///< of the smaller file's buildings: "heavily"

class OverlapWatch : public SceneSink {
public:
    explicit OverlapWatch(SceneSink& inner) : inner_(inner) {}
    /// The file the next features come from.
    void beginFile(const std::string& path);
    /// Warns (inputs_overlap) once per pair of files that overlap heavily.
    void report(Diagnostics& diagnostics) const;

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
    static bool near(const Building& a, const Building& b);
    SceneSink& inner_;
    std::vector<std::string> files_;
    std::deque<Building> buildings_;    // top-level features only; deques: no doubling while a city's worth grows
    std::deque<uint32_t> building_of_;  // feature index -> index into buildings_
};

}  // namespace cityatlas
