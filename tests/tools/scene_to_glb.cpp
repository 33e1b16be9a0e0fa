// SPDX-License-Identifier: GPL-3.0-or-later
// Test helper: the debug glb of a synthetic town folder written by `cityatlas synth`.
//
//   scene_to_glb TOWN_DIR OUT.glb
//
// Regenerates the town in memory from TOWN_DIR/truth.json's "settings" (the
// generator is deterministic), makes its Scene with texture paths under
// TOWN_DIR (synth::townToScene) and writes it with writeDebugGlb. Prints one
// line with the counts, the size and the write time. Exit 0 on success, 1 when
// writing fails, 2 on usage or unreadable input.

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "ingest/gltf_debug.h"
#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"

namespace fs = std::filesystem;
using namespace cityatlas;

namespace {

bool readSettings(const fs::path& truth_file, synth::TownSettings* s, std::string* error) {
    std::ifstream in(truth_file, std::ios::binary);
    if (!in) {
        *error = truth_file.string() + ": cannot open";
        return false;
    }
    try {
        const nlohmann::json j = nlohmann::json::parse(in);
        const nlohmann::json& st = j.at("settings");
        s->seed = st.at("seed").get<uint64_t>();
        s->buildings = st.at("buildings").get<uint32_t>();
        s->lod = st.at("lod").get<int>();
        s->texture_size_px = st.at("texture_size_px").get<int>();
        const std::string crs = st.at("crs").get<std::string>();
        if (crs.rfind("EPSG:", 0) != 0) throw std::runtime_error("settings.crs is not EPSG:<code>: " + crs);
        s->crs_epsg = std::stoi(crs.substr(5));
        const nlohmann::json& o = st.at("origin");
        s->origin_source = {o.at(0).get<double>(), o.at(1).get<double>(), o.at(2).get<double>()};
    } catch (const std::exception& e) {
        *error = truth_file.string() + ": " + e.what();
        return false;
    }
    return true;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 3) {
        std::fprintf(stderr, "usage: scene_to_glb TOWN_DIR OUT.glb\n");
        return 2;
    }
    const fs::path town_dir = argv[1];
    const fs::path out = argv[2];
    synth::TownSettings settings;
    std::string error;
    if (!readSettings(town_dir / synth::kTruthName, &settings, &error)) {
        std::fprintf(stderr, "scene_to_glb: %s\n", error.c_str());
        return 2;
    }
    const synth::Town town = synth::generateTown(settings);
    const Scene scene = synth::townToScene(town, town_dir);

    const auto t0 = std::chrono::steady_clock::now();
    const Status st = writeDebugGlb(scene, out);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!st.ok()) {
        std::fprintf(stderr, "scene_to_glb: %s\n", st.error.c_str());
        return 1;
    }
    std::error_code ec;
    const auto bytes = fs::file_size(out, ec);
    std::printf("%s: %zu triangles, %zu textures, %zu materials, %zu features; %llu bytes in %.3f s\n",
                out.string().c_str(), scene.triangles.size(), scene.textures.size(), scene.materials.size(),
                scene.features.size(), static_cast<unsigned long long>(ec ? 0 : bytes), seconds);
    return 0;
}
