// SPDX-License-Identifier: GPL-3.0-or-later
// scene_areas FILE.gml: per top-level building, the total triangle area that
// cityatlas's own reader produces, and the LOD(s) it used, as JSON. The
// counterpart of citygml_oracle (libcitygml) for the cross-check test.
#include <cstdio>
#include <map>
#include <set>

#include <nlohmann/json.hpp>

#include "ingest/citygml/citygml_reader.h"

int main(int argc, char** argv) {
    using namespace cityatlas;
    if (argc != 2) {
        std::fprintf(stderr, "usage: scene_areas FILE.gml\n");
        return 2;
    }
    SceneCollector collector;
    IngestState state;
    state.sink = &collector;
    if (Status s = readCityGml(argv[1], state); !s.ok()) {
        std::fprintf(stderr, "scene_areas: %s\n", s.error.c_str());
        return 1;
    }
    const Scene& scene = collector.scene;
    auto root = [&](uint32_t f) {
        while (scene.features[f].parent >= 0) f = static_cast<uint32_t>(scene.features[f].parent);
        return f;
    };
    std::map<uint32_t, double> area;
    std::map<uint32_t, size_t> triangles;
    std::map<uint32_t, std::set<int>> lods;
    for (uint32_t f = 0; f < scene.features.size(); ++f) {
        area[root(f)] += 0;
        if (scene.features[f].lod) lods[root(f)].insert(scene.features[f].lod);
    }
    for (const Triangle& t : scene.triangles) {
        area[root(t.feature)] += triangleArea(t.position_local);
        triangles[root(t.feature)]++;
    }
    nlohmann::json out;
    out["file"] = argv[1];
    out["buildings"] = nlohmann::json::array();
    for (const auto& [f, a] : area)
        out["buildings"].push_back({{"gml_id", scene.features[f].gml_id}, {"area_m2", a}, {"triangles", triangles[f]},
                                    {"lods", lods[f]}});
    std::printf("%s\n", out.dump(1).c_str());
    return 0;
}
