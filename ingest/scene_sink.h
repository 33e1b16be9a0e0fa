// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Where readers put what they read. Readers stream: they hand over one
/// building's triangles at a time, so a sink decides what memory an ingest
/// needs — all of it (SceneCollector) or next to none (SceneStatsSink).

#include <vector>

#include "ingest/scene.h"

namespace cityatlas {

class SceneSink {
public:
    virtual ~SceneSink() = default;
    virtual void setGeoreference(const Georeference& georef) = 0;
    virtual int32_t addTexture(const TextureRef& texture) = 0;   ///< returns its index
    /// The textures added so far (indices from addTexture).
    virtual const TextureTable& textures() const = 0;
    virtual int32_t addMaterial(const Material& material) = 0;   ///< interned; returns its index
    virtual uint32_t addFeature(Feature feature) = 0;            ///< returns its index
    /// Records which LOD a feature's geometry came from (known after its parts are read).
    virtual void setFeatureLod(uint32_t feature, int8_t lod) { (void)feature, (void)lod; }
    /// Takes the triangles (the vector is left empty).
    virtual void addTriangles(std::vector<Triangle>& triangles) = 0;
};

/// Keeps everything: the Scene in memory.
class SceneCollector : public SceneSink {
public:
    Scene scene;
    void setGeoreference(const Georeference& g) override { scene.georef = g; }
    int32_t addTexture(const TextureRef& t) override {
        scene.textures.push_back(t);
        return static_cast<int32_t>(scene.textures.size() - 1);
    }
    const TextureTable& textures() const override { return scene.textures; }
    int32_t addMaterial(const Material& m) override { return scene.internMaterial(m); }
    uint32_t addFeature(Feature f) override {
        scene.features.push_back(std::move(f));
        return static_cast<uint32_t>(scene.features.size() - 1);
    }
    void setFeatureLod(uint32_t feature, int8_t lod) override { scene.features[feature].lod = lod; }
    void addTriangles(std::vector<Triangle>& t) override {
        scene.triangles.insert(scene.triangles.end(), t.begin(), t.end());
        t.clear();
    }
};

/// Keeps only the statistics (and the small tables), for report-only runs
/// whose memory must not grow with the input.
class SceneStatsSink : public SceneSink {
public:
    Georeference georef;
    TextureTable textures_;
    std::vector<Material> materials;
    size_t features = 0;
    SceneStatsAccumulator stats;
    void setGeoreference(const Georeference& g) override { georef = g; }
    int32_t addTexture(const TextureRef& t) override {
        textures_.push_back(t);
        return static_cast<int32_t>(textures_.size() - 1);
    }
    const TextureTable& textures() const override { return textures_; }
    int32_t addMaterial(const Material& m) override {
        for (size_t i = 0; i < materials.size(); ++i)
            if (materials[i] == m) return static_cast<int32_t>(i);
        materials.push_back(m);
        return static_cast<int32_t>(materials.size() - 1);
    }
    uint32_t addFeature(Feature) override { return static_cast<uint32_t>(features++); }
    void addTriangles(std::vector<Triangle>& t) override {
        for (const Triangle& tri : t) stats.add(tri);
        t.clear();
    }
};

}  // namespace cityatlas
