// SPDX-License-Identifier: GPL-3.0-or-later
// `cityatlas ingest`: CityGML files and footprint layers -> Scene, with a debug glTF view and a
// JSON report.
#include <glob.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "cli/commands.h"
#include "cli/outcome.h"
#include "cli/progress.h"
#include "cli/scene_input.h"
#include "ingest/citygml/citygml_reader.h"
#include "ingest/footprints/footprint_reader.h"
#include "ingest/georef.h"
#include "ingest/ingest_report.h"
#include "ingest/scene_sink.h"
#include "ingest/gltf_debug.h"

namespace cityatlas::cli {
namespace fs = std::filesystem;
namespace {

struct IngestCliOptions {
    SceneInputOptions input;
    std::string glb;
    std::string report;
    bool quiet = false;
};

int fail(Progress& progress, const Status& s) { return cli::fail("ingest", s, &progress); }

int runIngest(const IngestCliOptions& opt) {
    Progress progress(!opt.quiet);
    IngestState state;
    // The debug view needs every triangle; a report alone needs only counts,
    // so memory stays bounded for inputs of any size.
    SceneCollector collector;
    SceneStatsSink stats_sink;
    state.sink = opt.glb.empty() ? static_cast<SceneSink*>(&stats_sink) : &collector;

    std::vector<StepTiming> steps;
    auto t0 = std::chrono::steady_clock::now();
    std::vector<fs::path> files;
    if (Status s = readInputs(opt.input, progress, state, &files); !s.ok()) return fail(progress, s);
    steps.push_back({"read", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                     static_cast<double>(peakRssBytes()) / 1e6});

    SceneStats stats;
    size_t features = 0, textures = 0, materials = 0;
    if (opt.glb.empty()) {
        stats = stats_sink.stats.finish();
        features = stats_sink.features, textures = stats_sink.textures().size(), materials = stats_sink.materials.size();
    } else {
        stats = computeStats(collector.scene);
        features = collector.scene.features.size(), textures = collector.scene.textures.size();
        materials = collector.scene.materials.size();
    }

    // The link to the Earth, and how far one matrix is from the real transformation over this scene.
    const std::optional<GeorefSummary> georef = attachGeoreference(
        state, stats.bounds_local, opt.glb.empty() ? stats_sink.georef : collector.scene.georef, files.front());
    if (!opt.glb.empty()) {
        if (!opt.quiet) progress.update("writing glb", 0, 1);
        t0 = std::chrono::steady_clock::now();
        if (Status s = writeDebugGlb(collector.scene, opt.glb); !s.ok())
            return fail(progress, Status::Io("io_error: " + s.error));
        steps.push_back({"write_glb", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                         static_cast<double>(peakRssBytes()) / 1e6});
    }
    progress.finish();
    if (!opt.report.empty()) {
        const auto report =
            makeIngestReport(state, stats, features, textures, materials, steps, opt.glb, georef ? &*georef : nullptr);
        if (Status s = writeTextAtomically(opt.report, report.dump(2) + "\n"); !s.ok()) return fail(progress, s);
    }

    uint64_t buildings = 0;
    for (const auto& f : state.files) buildings += f.buildings;
    std::printf("Read %zu file(s): %llu buildings, %zu features, %zu triangles (%zu textured), %zu textures, %zu materials\n",
                files.size(), static_cast<unsigned long long>(buildings), features, stats.triangles,
                stats.textured_triangles, textures, materials);
    for (int k = 0; k < kSurfaceSemanticCount; ++k)
        if (stats.triangles_by_semantic[k])
            std::printf("  %-12s %9zu triangles %14.2f m2\n",
                        std::string(semanticName(static_cast<SurfaceSemantic>(k))).c_str(),
                        stats.triangles_by_semantic[k], stats.area_by_semantic_m2[k]);
    for (const auto& [kind, n] : state.counts.objects_skipped)
        std::printf("  skipped %llu %s\n", static_cast<unsigned long long>(n), kind.c_str());
    printWarnings(state.diagnostics);
    if (!opt.glb.empty()) std::printf("Debug view: %s\n", opt.glb.c_str());
    if (!opt.report.empty()) std::printf("Report: %s\n", opt.report.c_str());
    std::printf("Time %.2f s, peak memory %s\n", steps.front().seconds, humanBytes(peakRssBytes()).c_str());
    return kExitOk;
}

}  // namespace

RunFn addIngestCommand(CLI::App& app) {
    auto opt = std::make_shared<IngestCliOptions>();
    CLI::App* cmd = app.add_subcommand(
        "ingest",
        "Read CityGML 1.0/2.0/3.0 buildings (LOD1/LOD2, with appearances) and attributed building footprints\n"
        "(any polygon layer GDAL/OGR opens; extruded, with roofs from a roof-type attribute) into one Scene: a\n"
        "textured triangle soup in local metres; all inputs share the first one's frame. Writes a plain glTF view\n"
        "and a JSON report of what was read, skipped and repaired.\n"
        "CityGML streams: with --report only, its memory holds one city object's geometry at a time; what grows\n"
        "with the file is its texture table, the ids of its geometry (for xlinks between city objects) and the\n"
        "texture coordinates of global appearances (about 0.3 kB a building on a synthetic town). Footprint\n"
        "layers are read twice, the first time for the walls touching footprints share: what grows with a\n"
        "layer is a table of its edges (20 bytes an edge) and its texture table.");
    addSceneInputOptions(cmd, &opt->input);
    cmd->add_option("-o,--output", opt->glb, "Debug view as glTF binary (.glb), textures referenced by relative URI");
    cmd->add_option("--report", opt->report, "Write a JSON report (schema: schemas/ingest_report.schema.json)");
    cmd->add_flag("-q,--quiet", opt->quiet, "No progress on stderr");
    return [opt]() { return runIngest(*opt); };
}

}  // namespace cityatlas::cli
