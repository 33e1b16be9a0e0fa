// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/synth/write_town.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <fstream>
#include <map>
#include <mutex>
#include <system_error>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include "cityatlas_version.h"
#include "ingest/output_folder.h"
#include "ingest/synth/facade_texture.h"
#include "ingest/triangulate.h"

namespace cityatlas::synth {

namespace fs = std::filesystem;

Status writeTextures(const Town& town, const fs::path& dir, const ProgressFn& progress) {
    std::error_code ec;
    fs::create_directories(dir / "textures", ec);
    if (ec) return Status::Io(fmt::format("{}: cannot create folder: {}", (dir / "textures").string(), ec.message()));

    std::atomic<uint64_t> done{0};
    std::mutex error_mutex, progress_mutex;
    std::string first_error;
    const uint64_t total = town.textures.size();
    tbb::parallel_for(size_t{0}, town.textures.size(), [&](size_t i) {
        const SynthTexture& t = town.textures[i];
        Image8 image;
        if (t.kind == SynthTexture::Kind::Paving) {
            image = drawPaving(t.size_px, t.seed);
        } else if (t.kind == SynthTexture::Kind::Orthophoto) {
            image = drawOrthophoto(town);
        } else {
            FacadeStyle style;
            style.building_number = t.building_number;
            style.storeys = t.storeys;
            style.window_columns = t.window_columns;
            style.transparent_glass = t.channels == 4;
            style.seed = t.seed;
            image = drawFacade(style, t.size_px, t.size_px);
        }
        std::string error;
        if (!writePng((dir / t.relative_path).string(), image, &error)) {
            std::lock_guard lock(error_mutex);
            if (first_error.empty()) first_error = error;
        }
        const uint64_t n = ++done;
        if (progress) {
            // try_lock: a worker never waits for the progress printer.
            std::unique_lock lock(progress_mutex, std::try_to_lock);
            if (lock.owns_lock()) progress("textures", n, total);
        }
    });
    if (progress) progress("textures", total, total);
    if (!first_error.empty()) return Status::Io(first_error);
    if (town.orthophoto_texture >= 0 && town.settings.orthophoto == OrthophotoMode::WorldFile) {
        const fs::path png = dir / town.textures[town.orthophoto_texture].relative_path;
        const fs::path world = fs::path(png).replace_extension(".pgw");
        std::ofstream os(world, std::ios::binary);
        os << worldFileText(town.orthophoto);
        os.close();
        if (!os) return Status::Io(fmt::format("{}: write failed (disk full?)", world.string()));
    }
    return Status::Ok();
}

nlohmann::ordered_json makeTruth(const Town& town) {
    using json = nlohmann::ordered_json;
    const TownSettings& s = town.settings;

    struct Tally {
        uint64_t polygons = 0, interior_rings = 0, vertices = 0, triangles = 0, textured = 0, coloured = 0;
        double area_m2 = 0;
    };
    std::array<Tally, kSurfaceSemanticCount> by_semantic{};
    std::map<std::string, uint64_t> roofs, shapes;
    Box3d box;
    double max_abs_uv = 0;
    json buildings = json::array();

    for (const SynthBuilding& b : town.buildings) {
        roofs[std::string(roofTypeName(b.roof))]++;
        shapes[std::string(shapeName(b.shape))]++;
        for (const SynthSurface& sf : b.surfaces) {
            Tally& t = by_semantic[static_cast<size_t>(sf.semantic)];
            PolygonRings rings;
            uint64_t vertices = 0;
            for (const auto& r : sf.rings) {
                rings.rings.emplace_back(r);
                vertices += r.size();
                for (const Vec3d& p : r) box.extend(p);
            }
            for (const auto& r : sf.uv)
                for (const Vec2d& uv : r) max_abs_uv = std::max({max_abs_uv, std::abs(uv.x), std::abs(uv.y)});
            const uint64_t holes = sf.rings.size() - 1;
            t.polygons++;
            t.interior_rings += holes;
            t.vertices += vertices;
            // Any triangulation of a polygon with V vertices and H holes that
            // adds no points has V + 2H - 2 triangles (Euler).
            t.triangles += vertices + 2 * holes - 2;
            t.area_m2 += polygonArea(rings);
            (sf.texture >= 0 ? t.textured : t.coloured)++;
        }
        json jb = json::object();
        jb["gml_id"] = b.gml_id;
        jb["number"] = b.number;
        jb["shape"] = shapeName(b.shape);
        jb["roof"] = roofTypeName(b.roof);
        jb["storeys"] = b.storeys;
        jb["storey_height_m"] = b.storey_height_m;
        jb["base_height_m"] = s.origin_source.z + b.base_height_m;
        jb["eave_height_m"] = b.eave_height_m;
        jb["ridge_height_m"] = b.ridge_height_m;
        jb["footprint_area_m2"] = b.footprint_area_m2;
        jb["projection_width_m"] = b.projection_width_m;
        jb["facade_texture"] = town.textures[b.facade_texture].relative_path;
        jb["polygons"] = b.surfaces.size();
        buildings.push_back(std::move(jb));
    }

    json j;
    j["generator"] = fmt::format("cityatlas {}", kCityAtlasVersion);
    j["settings"] = {{"seed", s.seed},
                     {"buildings", s.buildings},
                     {"lod", s.lod},
                     {"texture_size_px", s.texture_size_px},
                     {"crs", fmt::format("EPSG:{}", s.crs_epsg)},
                     {"origin", {s.origin_source.x, s.origin_source.y, s.origin_source.z}}};
    j["files"] = {{"citygml", kCityGmlName}, {"shapefile", kShapefileName}};
    j["buildings"] = town.buildings.size();
    j["roof_types"] = roofs;
    j["footprint_shapes"] = shapes;
    // LOD1 files carry no thematic surfaces: there the kind is what the
    // geometry implies (vertical = wall, facing up = roof, facing down = ground).
    j["semantics_in_file"] = s.lod == 2;
    Tally total;
    json surfaces = json::object();
    for (int k = 0; k < kSurfaceSemanticCount; ++k) {
        const Tally& t = by_semantic[k];
        if (t.polygons == 0) continue;
        surfaces[std::string(semanticName(static_cast<SurfaceSemantic>(k)))] = {
            {"polygons", t.polygons}, {"interior_rings", t.interior_rings}, {"vertices", t.vertices},
            {"triangles", t.triangles}, {"area_m2", t.area_m2}, {"textured_polygons", t.textured},
            {"coloured_polygons", t.coloured}};
        total.polygons += t.polygons, total.interior_rings += t.interior_rings, total.vertices += t.vertices;
        total.triangles += t.triangles, total.area_m2 += t.area_m2;
        total.textured += t.textured, total.coloured += t.coloured;
    }
    j["polygons"] = total.polygons;
    j["interior_rings"] = total.interior_rings;
    j["triangles"] = total.triangles;
    j["textured_polygons"] = total.textured;
    j["coloured_polygons"] = total.coloured;
    j["surfaces"] = surfaces;

    // Textures a surface uses (a reader sees only those); files: all written.
    std::vector<bool> used(town.textures.size(), false);
    for (const SynthBuilding& b : town.buildings)
        for (const SynthSurface& sf : b.surfaces)
            if (sf.texture >= 0) used[static_cast<size_t>(sf.texture)] = true;
    uint64_t count = 0, rgba = 0, facades = 0, paving = 0, orthophotos = 0;
    json files = json::array();
    for (size_t i = 0; i < town.textures.size(); ++i) {
        const SynthTexture& t = town.textures[i];
        files.push_back(t.relative_path);
        if (!used[i]) continue;
        count++;
        rgba += t.channels == 4;
        facades += t.kind == SynthTexture::Kind::Facade;
        paving += t.kind == SynthTexture::Kind::Paving;
        orthophotos += t.kind == SynthTexture::Kind::Orthophoto;
    }
    j["textures"] = {{"count", count}, {"facade", facades}, {"paving", paving}, {"rgb", count - rgba},
                     {"rgba", rgba}, {"size_px", s.texture_size_px}, {"files", files}};
    if (town.orthophoto_texture >= 0) {
        const OrthophotoGrid& g = town.orthophoto;
        j["textures"]["orthophoto"] = {{"file", town.textures[town.orthophoto_texture].relative_path},
                                       {"width_px", g.width_px}, {"height_px", g.height_px},
                                       {"pixel_m", g.pixel_m}, {"west_m", g.west_m}, {"north_m", g.north_m},
                                       {"mode", s.orthophoto == OrthophotoMode::WorldFile ? "world_file" : "reference_point"}};
    }
    j["materials"] = town.materials.size();
    j["paving_repeat_m"] = town.paving_repeat_m;
    j["max_abs_uv"] = max_abs_uv;
    const Vec3d o = s.origin_source;
    j["bbox_local"] = {{"min", {box.min.x, box.min.y, box.min.z}}, {"max", {box.max.x, box.max.y, box.max.z}}};
    j["bbox_source"] = {{"min", {o.x + box.min.x, o.y + box.min.y, o.z + box.min.z}},
                        {"max", {o.x + box.max.x, o.y + box.max.y, o.z + box.max.z}}};
    j["building_list"] = std::move(buildings);
    return j;
}

Status writeTown(const Town& town, const fs::path& out_dir, bool overwrite, const ProgressFn& progress) {
    std::error_code ec;
    const fs::path target = out_dir.lexically_normal();
    if (target.empty() || target == "." || target == "/")
        return Status::Io(fmt::format("{}: refusing to use this as the output folder", out_dir.string()));
    if (Status st = recoverInterruptedOutput(target); !st.ok()) return st;
    if (fs::exists(target, ec) && !overwrite)
        return Status::Io(fmt::format("{}: already exists (use --overwrite to replace it)", target.string()));
    if (target.has_parent_path()) {
        fs::create_directories(target.parent_path(), ec);
        if (ec) return Status::Io(fmt::format("{}: cannot create folder: {}", target.parent_path().string(), ec.message()));
    }
    // Work in a sibling folder swapped into place at the end (ingest/output_folder.h).
    fs::path tmp;
    if (Status st = startWorkingFolder(target, {}, &tmp); !st.ok()) return st;

    auto fail = [&](Status s) {
        std::error_code ignored;
        fs::remove_all(tmp, ignored);
        return s;
    };
    if (Status st = writeTextures(town, tmp, progress); !st.ok()) return fail(st);
    if (progress) progress("citygml", 0, 1);
    if (Status st = writeCityGml(town, tmp / kCityGmlName); !st.ok()) return fail(st);
    if (progress) progress("shapefile", 0, 1);
    if (Status st = writeFootprintShapefile(town, tmp / kShapefileName); !st.ok()) return fail(st);
    {
        std::ofstream os(tmp / kTruthName, std::ios::binary);
        os << makeTruth(town).dump(2) << '\n';
        if (!os) return fail(Status::Io(fmt::format("{}: write failed", (tmp / kTruthName).string())));
    }
    if (Status st = replaceFolder(tmp, target); !st.ok()) return fail(st);
    return Status::Ok();
}

}  // namespace cityatlas::synth
