// SPDX-License-Identifier: GPL-3.0-or-later
#include "cli/scene_input.h"

#include <glob.h>

#include <algorithm>
#include <cstring>
#include <fstream>

#include <fmt/format.h>

#include "ingest/footprints/footprint_reader.h"
#include "ingest/input_overlap.h"

namespace cityatlas::cli {
namespace fs = std::filesystem;
namespace {

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

Status parseFootprintOptions(const SceneInputOptions& opt, FootprintOptions* out) {
    for (const std::string& m : opt.maps) {
        const size_t eq = m.find('=');
        if (eq == std::string::npos || eq == 0 || eq + 1 == m.size())
            return Status::Usage(fmt::format("--map {}: expected ROLE=FIELD", m));
        const std::string role = m.substr(0, eq);
        if (std::find(footprintRoles().begin(), footprintRoles().end(), role) == footprintRoles().end()) {
            std::string roles;
            for (const auto& r : footprintRoles()) roles += (roles.empty() ? "" : ", ") + r;
            return Status::Usage(fmt::format("--map {}: unknown role \"{}\" (roles: {})", m, role, roles));
        }
        out->fields[role] = m.substr(eq + 1);
    }
    if (opt.height_unit == "m") out->height_unit_m = 1;
    else if (opt.height_unit == "ft") out->height_unit_m = 0.3048;
    else {
        char* end = nullptr;
        out->height_unit_m = std::strtod(opt.height_unit.c_str(), &end);
        if (*end || !(out->height_unit_m > 0))
            return Status::Usage(fmt::format("--height-unit {}: expected m, ft or metres per unit", opt.height_unit));
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
        if (*end || end == b.c_str() + 9) return Status::Usage(fmt::format("--base {}: expected constant:METRES", b));
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
        if (!fs::is_regular_file(dem, ec)) return Status::Io(fmt::format("--base {}: no such file {}", b, dem));
    } else {
        return Status::Usage(fmt::format("--base {}: expected auto, field, constant:METRES or terrain:DEM.tif[:min|:mean]", b));
    }
    return Status::Ok();
}


}  // namespace

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
            if (ec) return Status::Io(fmt::format("io_error: {}: {}", arg, ec.message()));
            if (found.empty())
                return Status::Io(fmt::format("io_error: {}: no CityGML (.gml/.xml/.citygml) or footprint "
                                                "(.shp/.gpkg/.geojson/.fgb) files in this folder", arg));
            std::sort(found.begin(), found.end());
            files->insert(files->end(), found.begin(), found.end());
        } else if (fs::exists(arg, ec)) {
            files->push_back(arg);
        } else if (arg.find_first_of("*?[") != std::string::npos) {
            glob_t g{};
            if (glob(arg.c_str(), 0, nullptr, &g) != 0 || g.gl_pathc == 0) {
                globfree(&g);
                return Status::Io(fmt::format("io_error: {}: no file matches this pattern", arg));
            }
            for (size_t i = 0; i < g.gl_pathc; ++i) files->push_back(g.gl_pathv[i]);
            globfree(&g);
        } else {
            return Status::Io(fmt::format("io_error: {}: no such file or folder", arg));
        }
    }
    return Status::Ok();
}


void addSceneInputOptions(CLI::App* cmd, SceneInputOptions* opt) {
    cmd->add_option("inputs", opt->inputs,
                    "CityGML files, footprint datasets, folders (searched for .gml/.xml/.citygml/.shp/.gpkg/.geojson/"
                    ".fgb) or glob patterns")
        ->required();
    cmd->add_option("--lod", opt->lod, "Level of detail per building: best (highest <= 2 present), 1 or 2")
        ->default_val("best")
        ->check(CLI::IsMember({"best", "1", "2"}));
    cmd->add_option("--theme", opt->theme, "Appearance theme to use (default: the first theme with a texture)");
    cmd->add_option("--crs", opt->crs, "CRS for files that declare none, e.g. EPSG:25832 or urn:ogc:def:crs:EPSG::25832");
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
}

Status readInputs(const SceneInputOptions& opt, Progress& progress, IngestState& state, std::vector<fs::path>* files) {
    FootprintOptions footprint_options;
    if (Status s = parseFootprintOptions(opt, &footprint_options); !s.ok()) return s;
    if (Status s = expandInputs(opt.inputs, files); !s.ok()) return s;
    state.options.lod = opt.lod == "best" ? 0 : std::stoi(opt.lod);
    state.options.theme = opt.theme;
    state.options.fallback_crs = opt.crs;
    size_t file_index = 0;
    state.progress = [&](const char* pass, uint64_t done, uint64_t total) {
        const std::string step =
            files->size() > 1 ? fmt::format("{} file {}/{}", pass, file_index + 1, files->size()) : std::string(pass);
        progress.update(step.c_str(), done, total, true);
    };
    // With several inputs, every building passes the overlap watch on its way
    // to the caller's sink (one input cannot overlap another: nothing held).
    SceneSink* sink = state.sink;
    OverlapWatch overlap(*sink, state.options.scratch_dir);
    if (files->size() > 1) state.sink = &overlap;
    for (file_index = 0; file_index < files->size(); ++file_index) {
        const fs::path& f = (*files)[file_index];
        overlap.beginFile(f.string());
        Status s = isCityGmlName(f) ? readCityGml(f, state) : readFootprints(f, footprint_options, state);
        if (!s.ok()) {
            state.progress = nullptr;
            state.sink = sink;
            return s;
        }
    }
    state.progress = nullptr;
    state.sink = sink;
    return overlap.report(state.diagnostics);
}

std::optional<GeorefSummary> attachGeoreference(IngestState& state, const Box3d& bounds_local, Georeference current,
                                                const fs::path& first_file) {
    if (!state.frame || state.frame->crs().kind == SourceCrs::Kind::LocalEngineering) return std::nullopt;
    GeorefSummary g;
    if (Status s = summarizeGeoreference(*state.frame, bounds_local, &g); !s.ok()) {
        state.diagnostics.warn(warn::kCrsNotGeoreferenced, {first_file.string(), 0, "", s.error});
        return std::nullopt;
    }
    current.local_to_ecef = g.local_to_ecef;
    current.enu_to_ecef = g.earth.enu_to_ecef;
    current.grid_frame = g.earth.grid;
    state.sink->setGeoreference(current);
    return g;
}

Status writeTextAtomically(const fs::path& path, const std::string& text) {
    return writeAtomically(path, [&](std::ostream& os) { os << text; });
}

Status writeAtomically(const fs::path& path, const std::function<void(std::ostream&)>& write) {
    const fs::path tmp = path.string() + ".partial";
    {
        std::ofstream os(tmp, std::ios::binary);
        write(os);
        os.close();  // a full disk may show only here
        if (!os) {
            const int err = errno;
            std::error_code ec;
            fs::remove(tmp, ec);
            return Status::Io(fmt::format("io_error: {}: cannot write: {}", path.string(), std::strerror(err)));
        }
    }
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec) return Status::Io(fmt::format("io_error: {}: {}", path.string(), ec.message()));
    return Status::Ok();
}



void printWarnings(const Diagnostics& diagnostics) {
    if (!diagnostics.total()) return;
    std::printf("Warnings: %llu\n", static_cast<unsigned long long>(diagnostics.total()));
    for (const auto& [code, e] : diagnostics.entries()) {
        const DiagnosticExample& ex = e.examples.front();
        std::printf("  %-24s %6llu  e.g. %s%s%s%s: %s\n", code.c_str(), static_cast<unsigned long long>(e.count),
                    ex.file.c_str(), ex.line ? fmt::format(":{}", ex.line).c_str() : "", ex.gml_id.empty() ? "" : " ",
                    ex.gml_id.c_str(), ex.detail.c_str());
    }
}

}  // namespace cityatlas::cli
