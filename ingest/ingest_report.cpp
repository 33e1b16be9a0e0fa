// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/ingest_report.h"

#include "cityatlas_version.h"

namespace cityatlas {

nlohmann::ordered_json warningsJson(const Diagnostics& diagnostics) {
    nlohmann::ordered_json warnings = nlohmann::ordered_json::object();
    for (const auto& [code, e] : diagnostics.entries()) {
        nlohmann::ordered_json ex = nlohmann::ordered_json::array();
        for (const DiagnosticExample& d : e.examples)
            ex.push_back({{"file", d.file}, {"line", d.line}, {"gml_id", d.gml_id}, {"detail", d.detail}});
        warnings[code] = {{"count", e.count}, {"examples", ex}};
    }
    return warnings;
}

nlohmann::ordered_json makeIngestReport(const IngestState& state, const SceneStats& stats, size_t features,
                                        size_t textures, size_t materials, const std::vector<StepTiming>& steps,
                                        const std::string& glb_path, const GeorefSummary* georef) {
    using json = nlohmann::ordered_json;
    auto xyz = [](const Vec3d& p) { return json::array({p.x, p.y, p.z}); };
    auto box = [&](const Box3d& b) {
        return b.empty() ? json(nullptr) : json{{"min", xyz(b.min)}, {"max", xyz(b.max)}};
    };
    const IngestCounts& c = state.counts;
    json j;
    j["generator"] = std::string("cityatlas ") + kCityAtlasVersion;
    j["command"] = "ingest";
    json inputs = json::array();
    for (const InputFileSummary& f : state.files) {
        json in = {{"path", f.path}, {"bytes", f.bytes}, {"citygml_version", f.citygml_version},
                   {"srs_name", f.srs_name}, {"crs", f.crs}, {"buildings", f.buildings}};
        in["envelope"] = f.has_envelope ? json{{"min", xyz(f.envelope_min)}, {"max", xyz(f.envelope_max)}} : json(nullptr);
        inputs.push_back(std::move(in));
    }
    j["inputs"] = std::move(inputs);
    j["options"] = {{"lod", state.options.lod == 0 ? json("best") : json(state.options.lod)},
                    {"theme", state.options.theme.empty() ? json(nullptr) : json(state.options.theme)},
                    {"fallback_crs", state.options.fallback_crs.empty() ? json(nullptr) : json(state.options.fallback_crs)}};
    if (state.frame) {
        j["georeference"] = {{"crs", state.frame->crs().definition.empty() ? state.frame->crs().declared
                                                                           : state.frame->crs().definition},
                             {"crs_name", state.frame->crs().name},
                             {"origin", xyz(state.frame->originSource())}};
        if (georef) {
            json& g = j["georeference"];
            g["frame"] = georef->earth.grid ? "grid" : "enu";
            g["origin_wgs84"] = {{"lat_deg", georef->earth.origin_lat_deg}, {"lon_deg", georef->earth.origin_lon_deg},
                                 {"h_m", georef->earth.origin_h_m}};
            g["enu_to_ecef"] = georef->earth.enu_to_ecef;
            g["local_to_ecef"] = georef->local_to_ecef;
            g["operation"] = georef->earth.operation;
            g["planar_error"] = {{"horizontal_m", georef->planar_error_horizontal_m},
                                 {"vertical_m", georef->planar_error_vertical_m},
                                 {"extent_m", georef->extent_m}};
        }
    } else {
        j["georeference"] = nullptr;
    }
    j["objects_read"] = c.objects_read;
    j["objects_skipped"] = c.objects_skipped;
    j["geometry_skipped"] = c.geometry_skipped;
    j["features"] = {{"total", features}, {"lod1", c.features_lod1}, {"lod2", c.features_lod2},
                     {"without_geometry", c.features_without_geometry}};
    j["polygons"] = {{"read", c.polygons_read}, {"triangulated", c.polygons_triangulated},
                     {"skipped", c.polygons_skipped}, {"textured", c.polygons_textured},
                     {"coloured", c.polygons_coloured}, {"semantic_inferred", c.polygons_semantic_inferred},
                     {"shared_between_parts", c.polygons_shared},
                     {"max_plane_deviation_m", c.max_plane_deviation_m}};
    j["xlinks"] = {{"resolved", c.xlinks_resolved}, {"cross_object", c.xlinks_cross_object}};
    j["footprints"] = {{"read", c.footprints_read}, {"repaired", c.footprints_repaired},
                       {"skipped", c.footprints_skipped}, {"party_walls", c.party_walls},
                       {"roof_fallbacks", c.roof_fallbacks}, {"roof_shapes", c.roof_shapes}};
    json by_semantic = json::object();
    for (int k = 0; k < kSurfaceSemanticCount; ++k) {
        if (!stats.triangles_by_semantic[k]) continue;
        by_semantic[std::string(semanticName(static_cast<SurfaceSemantic>(k)))] = {
            {"triangles", stats.triangles_by_semantic[k]}, {"area_m2", stats.area_by_semantic_m2[k]}};
    }
    j["triangles"] = {{"total", stats.triangles}, {"textured", stats.textured_triangles}, {"by_semantic", by_semantic}};
    j["textures"] = {{"count", textures}, {"failed", c.textures_failed}};
    j["materials"] = materials;
    j["themes"] = {{"used", c.theme_used.empty() && c.themes.empty() ? json(nullptr) : json(c.theme_used)},
                   {"available", c.themes}};
    j["bbox_local"] = box(stats.bounds_local);
    j["bbox_source"] = box(state.bounds_source);
    j["warnings"] = warningsJson(state.diagnostics);
    j["warnings_total"] = state.diagnostics.total();
    json st = json::array();
    for (const StepTiming& s : steps)
        st.push_back({{"name", s.name}, {"seconds", s.seconds}, {"peak_rss_mb", s.peak_rss_mb}});
    j["steps"] = std::move(st);
    j["output"] = {{"glb", glb_path.empty() ? json(nullptr) : json(glb_path)}};
    return j;
}

}  // namespace cityatlas
