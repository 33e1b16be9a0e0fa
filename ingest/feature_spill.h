// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Features on disk while a city is read (issue 17): a city's feature records
/// (ids, names, attribute maps: about a kilobyte each in memory) go to a
/// spill file as readers hand them over, and come back one at a time, in id
/// order, when the feature tables are written. What a reader learns of a
/// feature later (its LOD, SceneSink::setFeatureLod) is kept beside it in
/// memory, one byte a feature, and applied on the way back.
///
/// The file is private to one build: native byte order, no versioning;
/// strings as a 32-bit length and their bytes.

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <vector>

#include "core/status.h"
#include "ingest/scene.h"

namespace cityatlas {

class FeatureSpill {
public:
    explicit FeatureSpill(std::filesystem::path path);
    /// Appends `f`; returns its id (0, 1, ... in call order).
    uint32_t add(const Feature& f);
    void setLod(uint32_t feature, int8_t lod);
    uint64_t size() const { return lod_.size(); }
    /// Closes the file; an error when a write failed (disk full).
    Status finish();
    /// Every feature in id order, with the LODs set since; the file must be finished.
    Status forEach(const std::function<Status(uint32_t id, Feature&& f)>& fn) const;
    /// Every feature in memory (a build small enough for one process).
    Status readAll(std::vector<Feature>* out) const;
    const std::filesystem::path& path() const { return path_; }

private:
    std::filesystem::path path_;
    std::ofstream file_;
    std::vector<int8_t> lod_;
};

}  // namespace cityatlas
