// SPDX-License-Identifier: GPL-3.0-or-later
// `cityatlas ingest`: CityGML files -> Scene, with a debug glTF view and a
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
#include "cli/progress.h"
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
    std::vector<std::string> inputs;
    std::string glb;
    std::string report;
    std::string lod = "best";
    std::string theme;
    std::string crs;
    bool quiet = false;
    // Footprints:
    std::vector<std::string> maps;     // ROLE=FIELD
    std::string height_unit = "m";
    double default_height_m = 10, storey_height_m = 3;
    std::string base = "auto";
};

std::string extension(const fs::path& p) {
    std::string ext = p.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    return ext;
}

bool isCityGmlName(const fs::path& p) {
    const std::string ext = extension(p);
    return ext == ".gml" || ext == ".xml" || ext == ".citygml";
}

// Footprint datasets found when scanning folders (any other file OGR opens
// can still be named directly).
bool isFootprintName(const fs::path& p) {
    const std::string ext = extension(p);
    return ext == ".shp" || ext == ".gpkg" || ext == ".geojson" || ext == ".fgb";
}

Status parseFootprintOptions(const IngestCliOptions& opt, FootprintOptions* out) {
    for (const std::string& m : opt.maps) {
        const size_t eq = m.find('=');
        if (eq == std::string::npos || eq == 0 || eq + 1 == m.size())
            return Status::Fail(fmt::format("--map {}: expected ROLE=FIELD", m));
        const std::string role = m.substr(0, eq);
        if (std::find(footprintRoles().begin(), footprintRoles().end(), role) == footprintRoles().end()) {
            std::string roles;
            for (const auto& r : footprintRoles()) roles += (roles.empty() ? "" : ", ") + r;
            return Status::Fail(fmt::format("--map {}: unknown role \"{}\" (roles: {})", m, role, roles));
        }
        out->fields[role] = m.substr(eq + 1);
    }
    if (opt.height_unit == "m") out->height_unit_m = 1;
    else if (opt.height_unit == "ft") out->height_unit_m = 0.3048;
    else {
        char* end = nullptr;
        out->height_unit_m = std::strtod(opt.height_unit.c_str(), &end);
        if (*end || !(out->height_unit_m > 0))
            return Status::Fail(fmt::format("--height-unit {}: expected m, ft or metres per unit", opt.height_unit));
    }
    out->default_height_m = opt.default_height_m;
    out->storey_height_m = opt.storey_height_m;
    const std::string& b = opt.base;
    if (b == "auto") out->base = FootprintOptions::Base::Auto;
    else if (b == "field") out->base = FootprintOptions::Base::Field;
    else if (b.rfind("constant:", 0) == 0) {
        out->base = FootprintOptions::Base::Constant;
        char* end = nullptr;
        out->base_constant_m = std::strtod(b.c_str() + 9, &end);
        if (*end || end == b.c_str() + 9) return Status::Fail(fmt::format("--base {}: expected constant:METRES", b));
    } else if (b.rfind("terrain:", 0) == 0) {
        out->base = FootprintOptions::Base::Terrain;
        std::string dem = b.substr(8);
        for (const char* mode : {":mean", ":min"})
            if (dem.size() > std::strlen(mode) && dem.compare(dem.size() - std::strlen(mode), std::string::npos, mode) == 0) {
                out->terrain_mean = std::string(mode) == ":mean";
                dem.resize(dem.size() - std::strlen(mode));
            }
        out->terrain_dem = dem;
        std::error_code ec;
        if (!fs::is_regular_file(dem, ec)) return Status::Fail(fmt::format("--base {}: no such file {}", b, dem));
    } else {
        return Status::Fail(fmt::format("--base {}: expected auto, field, constant:METRES or terrain:DEM.tif[:min|:mean]", b));
    }
    return Status::Ok();
}

// Files, folders (searched recursively for .gml/.xml/.citygml) and glob
// patterns (for shells that pass them through), in a stable order.
Status expandInputs(const std::vector<std::string>& args, std::vector<fs::path>* files) {
    for (const std::string& arg : args) {
        std::error_code ec;
        if (fs::is_directory(arg, ec)) {
            std::vector<fs::path> found;
            for (auto it = fs::recursive_directory_iterator(arg, ec); !ec && it != fs::recursive_directory_iterator();
                 it.increment(ec))
                if (it->is_regular_file() && (isCityGmlName(it->path()) || isFootprintName(it->path())))
                    found.push_back(it->path());
            if (ec) return Status::Fail(fmt::format("io_error: {}: {}", arg, ec.message()));
            if (found.empty())
                return Status::Fail(fmt::format("io_error: {}: no CityGML (.gml/.xml/.citygml) or footprint "
                                                "(.shp/.gpkg/.geojson/.fgb) files in this folder", arg));
            std::sort(found.begin(), found.end());
            files->insert(files->end(), found.begin(), found.end());
        } else if (fs::exists(arg, ec)) {
            files->push_back(arg);
        } else if (arg.find_first_of("*?[") != std::string::npos) {
            glob_t g{};
            if (glob(arg.c_str(), 0, nullptr, &g) != 0 || g.gl_pathc == 0) {
                globfree(&g);
                return Status::Fail(fmt::format("io_error: {}: no file matches this pattern", arg));
            }
            for (size_t i = 0; i < g.gl_pathc; ++i) files->push_back(g.gl_pathv[i]);
            globfree(&g);
        } else {
            return Status::Fail(fmt::format("io_error: {}: no such file or folder", arg));
        }
    }
    return Status::Ok();
}

Status writeTextAtomically(const fs::path& path, const std::string& text) {
    const fs::path tmp = path.string() + ".partial";
    {
        std::ofstream os(tmp, std::ios::binary);
        os << text;
        if (!os) {
            std::error_code ec;
            fs::remove(tmp, ec);
            return Status::Fail(fmt::format("io_error: {}: cannot write", path.string()));
        }
    }
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec) return Status::Fail(fmt::format("io_error: {}: {}", path.string(), ec.message()));
    return Status::Ok();
}

int fail(Progress& progress, const Status& s) {
    progress.finish();
    std::fprintf(stderr, "cityatlas ingest: error: %s\n", s.error.c_str());
    return kExitFailure;
}

int runIngest(const IngestCliOptions& opt) {
    Progress progress(!opt.quiet);
    FootprintOptions footprint_options;
    if (Status s = parseFootprintOptions(opt, &footprint_options); !s.ok()) {
        std::fprintf(stderr, "cityatlas ingest: %s\n", s.error.c_str());
        return kExitUsage;
    }
    std::vector<fs::path> files;
    if (Status s = expandInputs(opt.inputs, &files); !s.ok()) return fail(progress, s);

    IngestState state;
    state.options.lod = opt.lod == "best" ? 0 : std::stoi(opt.lod);
    state.options.theme = opt.theme;
    state.options.fallback_crs = opt.crs;
    // The debug view needs every triangle; a report alone needs only counts,
    // so memory stays bounded for inputs of any size.
    SceneCollector collector;
    SceneStatsSink stats_sink;
    state.sink = opt.glb.empty() ? static_cast<SceneSink*>(&stats_sink) : &collector;
    size_t file_index = 0;
    state.progress = [&](const char* pass, uint64_t done, uint64_t total) {
        const std::string step =
            files.size() > 1 ? fmt::format("{} file {}/{}", pass, file_index + 1, files.size()) : std::string(pass);
        progress.update(step.c_str(), done, total, true);
    };

    std::vector<StepTiming> steps;
    auto t0 = std::chrono::steady_clock::now();
    // All inputs share the frame the first one defines.
    for (file_index = 0; file_index < files.size(); ++file_index) {
        const fs::path& f = files[file_index];
        const Status s = isCityGmlName(f) ? readCityGml(f, state) : readFootprints(f, footprint_options, state);
        if (!s.ok()) {
            if (s.error.rfind("usage: ", 0) == 0) {
                progress.finish();
                std::fprintf(stderr, "cityatlas ingest: %s\n", s.error.c_str() + 7);
                return kExitUsage;
            }
            return fail(progress, s);
        }
    }
    steps.push_back({"read", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                     static_cast<double>(peakRssBytes()) / 1e6});

    SceneStats stats;
    size_t features = 0, textures = 0, materials = 0;
    if (opt.glb.empty()) {
        stats = stats_sink.stats.finish();
        features = stats_sink.features, textures = stats_sink.textures.size(), materials = stats_sink.materials.size();
    } else {
        stats = computeStats(collector.scene);
        features = collector.scene.features.size(), textures = collector.scene.textures.size();
        materials = collector.scene.materials.size();
    }

    // The link to the Earth, and how far one matrix is from the real transformation over this scene.
    std::optional<GeorefSummary> georef;
    if (state.frame && state.frame->crs().kind != SourceCrs::Kind::LocalEngineering) {
        GeorefSummary g;
        if (Status s = summarizeGeoreference(*state.frame, stats.bounds_local, &g); s.ok()) {
            georef = g;
            Georeference ref = opt.glb.empty() ? stats_sink.georef : collector.scene.georef;
            ref.local_to_ecef = g.local_to_ecef;
            ref.enu_to_ecef = g.earth.enu_to_ecef;
            ref.grid_frame = g.earth.grid;
            state.sink->setGeoreference(ref);
        } else {
            state.diagnostics.warn(warn::kCrsNotGeoreferenced, {files.front().string(), 0, "", s.error});
        }
    }
    if (!opt.glb.empty()) {
        if (!opt.quiet) progress.update("writing glb", 0, 1);
        t0 = std::chrono::steady_clock::now();
        if (Status s = writeDebugGlb(collector.scene, opt.glb); !s.ok())
            return fail(progress, Status::Fail("io_error: " + s.error));
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
    if (state.diagnostics.total()) {
        std::printf("Warnings: %llu\n", static_cast<unsigned long long>(state.diagnostics.total()));
        for (const auto& [code, e] : state.diagnostics.entries()) {
            const auto& ex = e.examples.front();
            std::printf("  %-24s %6llu  e.g. %s%s%s%s: %s\n", code.c_str(), static_cast<unsigned long long>(e.count),
                        ex.file.c_str(), ex.line ? fmt::format(":{}", ex.line).c_str() : "",
                        ex.gml_id.empty() ? "" : " ", ex.gml_id.c_str(), ex.detail.c_str());
        }
    }
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
        "CityGML streams: with --report only, its memory stays at about one city object whatever the file size\n"
        "(footprint layers are held while read: party walls need the neighbours).");
    cmd->add_option("inputs", opt->inputs,
                    "CityGML files, footprint datasets, folders (searched for .gml/.xml/.citygml/.shp/.gpkg/.geojson/"
                    ".fgb) or glob patterns")
        ->required();
    cmd->add_option("-o,--output", opt->glb, "Debug view as glTF binary (.glb), textures referenced by relative URI");
    cmd->add_option("--report", opt->report, "Write a JSON report (schema: schemas/ingest_report.schema.json)");
    cmd->add_option("--lod", opt->lod, "Level of detail per building: best (highest <= 2 present), 1 or 2")
        ->default_val("best")
        ->check(CLI::IsMember({"best", "1", "2"}));
    cmd->add_option("--theme", opt->theme, "Appearance theme to use (default: the first theme with a texture)");
    cmd->add_option("--crs", opt->crs, "CRS for files that declare none, e.g. EPSG:25832 or urn:ogc:def:crs:EPSG::25832");
    cmd->add_flag("-q,--quiet", opt->quiet, "No progress on stderr");
    auto* fp = "Footprints (shapefile, GeoPackage, GeoJSON, FlatGeobuf, ...)";
    cmd->add_option("--map", opt->maps,
                    "Attribute for a role, ROLE=FIELD (repeatable). Roles: id, height (top above base), eave_height, "
                    "base_height, storeys, storey_height, roof_type, roof_height, facade_texture, projection_width, "
                    "roof_texture. Unmapped roles are looked up among common names (OSM height, building:levels, "
                    "roof:shape, ...)")
        ->group(fp);
    cmd->add_option("--height-unit", opt->height_unit, "Unit of height attributes: m, ft or metres per unit")
        ->default_val("m")
        ->group(fp);
    cmd->add_option("--default-height", opt->default_height_m, "Height (m) of footprints without height or storeys")
        ->default_val(10)
        ->check(CLI::PositiveNumber)
        ->group(fp);
    cmd->add_option("--storey-height", opt->storey_height_m, "Storey height (m) when only storeys are known")
        ->default_val(3)
        ->check(CLI::PositiveNumber)
        ->group(fp);
    cmd->add_option("--base", opt->base,
                    "Base height: auto (field base_height, else the geometry's z, else 0), field, constant:METRES, "
                    "or terrain:DEM.tif[:min|:mean] (a GDAL raster sampled under each footprint; min by default)")
        ->default_val("auto")
        ->group(fp);
    return [opt]() { return runIngest(*opt); };
}

}  // namespace cityatlas::cli
