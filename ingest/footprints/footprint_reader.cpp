// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/footprints/footprint_reader.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <functional>
#include <memory>

#include <cpl_error.h>
#include <gdal_priv.h>
#include <ogr_geometry.h>
#include <ogrsf_frmts.h>

#include <fmt/format.h>

#include "ingest/footprints/extrude.h"
#include "ingest/footprints/party_walls.h"
#include "ingest/texture_resolver.h"
#include "ingest/triangulate.h"

namespace cityatlas {
namespace fs = std::filesystem;
using footprints::ExtrudedPolygon;
using footprints::Footprint2d;
using footprints::RoofShape;

namespace {

// Named tolerances.
constexpr double kDuplicatePointTolerance_m = 1e-4;  // consecutive vertices closer than this are one
constexpr double kMinFootprintArea_m2 = 0.01;        // smaller parts are slivers, skipped

// Common attribute names per role, lower case, tried in order.
const std::map<std::string, std::vector<std::string>> kDefaultFieldNames = {
    {"id", {"gml_id", "id", "osm_id", "building_id", "reference", "objectid", "oid", "name", "fid"}},
    {"height", {"height", "measuredheight", "height_ag", "hoehe", "bldg_height", "building_height", "heightroof"}},
    {"eave_height", {"eave_h", "eave_height", "eaves_height", "traufhoehe"}},
    {"base_height", {"base_h", "min_height", "base_height", "ground_height", "gelaendehoehe"}},
    {"storeys", {"levels", "building_levels", "building:levels", "floors_ag", "storeys", "num_floors",
                 "anzahl_geschosse", "geschosse"}},
    {"storey_height", {"storey_h", "storey_height", "floor_height"}},
    {"roof_type", {"roof_shape", "roof:shape", "roof_type", "rooftype", "dachform"}},
    {"roof_height", {"roof_h", "roof:height", "roof_height", "dachhoehe"}},
    {"facade_texture", {"facade_tex", "facade_texture", "texture"}},
    {"projection_width", {"proj_w", "projection_width"}},
    {"roof_texture", {"roof_tex", "roof_texture"}},
};

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}

struct DatasetCloser {
    void operator()(GDALDataset* ds) const { GDALClose(ds); }
};

// A SourceCrs from a layer's SRS: by EPSG code when GDAL can identify one,
// else by its WKT.
Status crsFromOgr(const OGRSpatialReference& layer_srs, SourceCrs* crs) {
    OGRSpatialReference srs(layer_srs);
    srs.AutoIdentifyEPSG();
    const char* auth = srs.GetAuthorityName(nullptr);
    const char* code = srs.GetAuthorityCode(nullptr);
    if (auth && code && std::string(auth) == "EPSG") return parseSrsName(fmt::format("EPSG:{}", code), crs);
    char* wkt = nullptr;
    srs.exportToWkt(&wkt);
    crs->declared = wkt ? wkt : "";
    CPLFree(wkt);
    return sourceCrsFromDefinition(crs->declared, crs);
}

double signedArea(const std::vector<Vec2d>& r) {
    double a = 0;
    for (size_t i = 0; i < r.size(); ++i) {
        const Vec2d& p = r[i];
        const Vec2d& q = r[(i + 1) % r.size()];
        a += (p.x - r[0].x) * (q.y - r[0].y) - (q.x - r[0].x) * (p.y - r[0].y);
    }
    return a / 2;
}

// One building as read, before extrusion.
struct Record {
    Feature feature;
    std::vector<Footprint2d> parts;          // local metres
    std::vector<std::vector<Vec3d>> samples; // source-CRS points per part (terrain sampling)
    double base_z = 0, eave_z = 0, ridge_z = 0;  // local z
    RoofShape roof = RoofShape::Flat;
    int32_t facade_texture = -1, roof_texture = -1;
    double projection_width_m = 0;
    int64_t fid = 0;
    std::vector<std::vector<std::vector<double>>> wall_bottom;  // per part, ring, edge
};

// Samples a DEM under footprints (nearest pixel), in the DEM's own CRS.
class Terrain {
public:
    static Status open(const std::string& path, const LocalFrame& frame, std::unique_ptr<Terrain>* out) {
        auto t = std::make_unique<Terrain>();
        CPLPushErrorHandler(CPLQuietErrorHandler);
        t->ds_.reset(static_cast<GDALDataset*>(GDALOpen(path.c_str(), GA_ReadOnly)));
        CPLPopErrorHandler();
        if (!t->ds_ || t->ds_->GetRasterCount() < 1)
            return Status::Io(fmt::format("io_error: {}: not a raster GDAL can read", path));
        if (t->ds_->GetGeoTransform(t->gt_) != CE_None)
            return Status::Io(fmt::format("io_error: {}: the raster has no geotransform", path));
        t->band_ = t->ds_->GetRasterBand(1);
        int has_nodata = 0;
        t->nodata_ = t->band_->GetNoDataValue(&has_nodata);
        t->has_nodata_ = has_nodata != 0;
        if (const OGRSpatialReference* dem_srs = t->ds_->GetSpatialRef()) {
            OGRSpatialReference from, to(*dem_srs);
            from.SetFromUserInput(frame.crs().definition.c_str(), OGRSpatialReference::SET_FROM_USER_INPUT_LIMITATIONS);
            from.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
            to.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
            t->ct_.reset(OGRCreateCoordinateTransformation(&from, &to));
            if (!t->ct_) return Status::Invalid(fmt::format("crs_unknown: {}: no transformation from {}", path, frame.crs().name));
        }
        *out = std::move(t);
        return Status::Ok();
    }
    // Minimum or mean over the samples that hit valid pixels; false if none.
    bool sample(const std::vector<Vec3d>& points_frame_crs, bool mean, double* value) {
        double sum = 0, lo = 1e300;
        int n = 0;
        for (Vec3d p : points_frame_crs) {
            if (ct_ && !ct_->Transform(1, &p.x, &p.y)) continue;
            const double det = gt_[1] * gt_[5] - gt_[2] * gt_[4];
            if (det == 0) return false;
            const double dx = p.x - gt_[0], dy = p.y - gt_[3];
            const int col = static_cast<int>(std::floor((gt_[5] * dx - gt_[2] * dy) / det));
            const int row = static_cast<int>(std::floor((-gt_[4] * dx + gt_[1] * dy) / det));
            if (col < 0 || row < 0 || col >= band_->GetXSize() || row >= band_->GetYSize()) continue;
            double v = 0;
            if (band_->RasterIO(GF_Read, col, row, 1, 1, &v, 1, 1, GDT_Float64, 0, 0) != CE_None) continue;
            if ((has_nodata_ && v == nodata_) || !std::isfinite(v)) continue;
            sum += v, lo = std::min(lo, v), ++n;
        }
        if (n == 0) return false;
        *value = mean ? sum / n : lo;
        return true;
    }

private:
    std::unique_ptr<GDALDataset, DatasetCloser> ds_;
    GDALRasterBand* band_ = nullptr;
    double gt_[6] = {};
    double nodata_ = 0;
    bool has_nodata_ = false;
    std::unique_ptr<OGRCoordinateTransformation> ct_;
};

class LayerReader {
public:
    LayerReader(const fs::path& dataset, OGRLayer* layer, const FootprintOptions& options, IngestState& state)
        : dataset_(dataset), layer_(layer), options_(options), state_(state),
          textures_(*state.sink, state.diagnostics) {}

    Status run() {
        if (Status s = setUpFrame(); !s.ok()) return s;
        resolveFields();
        if (options_.base == FootprintOptions::Base::Terrain)
            if (Status s = Terrain::open(options_.terrain_dem, *state_.frame, &terrain_); !s.ok()) return s;
        // Two passes over the layer, so that no pass holds the footprints:
        // the first finds the party walls (party_walls.h), the second reads
        // each footprint again and extrudes it at once.
        footprints::PartyWallIndex walls;
        quiet_ = true;
        forEachRecord("footprints: shared walls", [&](Record& r) { walls.add(r.parts, r.eave_z); });
        quiet_ = false;
        walls.finish();
        uint32_t record = 0;
        forEachRecord("footprints", [&](Record& r) {
            r.wall_bottom = walls.wallBottoms(record++, r.parts, r.base_z, r.eave_z, &state_.counts.party_walls);
            emit(r);
        });
        state_.counts.textures_ok += textures_.resolved();
        state_.counts.textures_failed += textures_.failed();
        return Status::Ok();
    }

private:
    // Every footprint readFeature keeps, in layer order, handed to `fn`.
    void forEachRecord(const char* step, const std::function<void(Record&)>& fn) {
        layer_->ResetReading();
        const GIntBig total = layer_->GetFeatureCount(FALSE);
        uint64_t n = 0;
        for (auto& feature : *layer_) {
            Record r;
            if (readFeature(*feature, &r)) fn(r);
            if (state_.progress && (++n & 255) == 0)
                state_.progress(step, n, total > 0 ? static_cast<uint64_t>(total) : n);
        }
    }

    const fs::path dataset_;
    OGRLayer* layer_;
    const FootprintOptions& options_;
    IngestState& state_;
    TextureResolver textures_;
    SourceCrs crs_;
    std::unique_ptr<LocalFrame::Mapper> mapper_;
    std::unique_ptr<Terrain> terrain_;
    std::map<std::string, int> field_;  // role -> field index
    // The party-wall pass: readFeature gives the same record (its geometry
    // and heights), without warnings, counts, textures or attributes.
    bool quiet_ = false;

    std::string where() const { return fmt::format("{} (layer {})", dataset_.string(), layer_->GetName()); }

    void warn(const char* code, int64_t fid, const std::string& id, std::string detail) {
        if (quiet_) return;
        state_.diagnostics.warn(code, {where(), fid, id, std::move(detail)});
    }

    Status setUpFrame() {
        const OGRSpatialReference* srs = layer_->GetSpatialRef();
        if (srs) {
            if (Status s = crsFromOgr(*srs, &crs_); !s.ok())
                return Status::Invalid(fmt::format("{}: {}: {}", fatal::kCrsUnknown, where(), s.error));
        } else if (!state_.options.fallback_crs.empty()) {
            if (Status s = parseSrsName(state_.options.fallback_crs, &crs_); !s.ok())
                return Status::Invalid(fmt::format("{}: {}: {}", fatal::kCrsUnknown, where(), s.error));
        } else {
            return Status::Invalid(fmt::format("{}: {}: the layer has no CRS (.prj); give --crs", fatal::kCrsMissing, where()));
        }
        InputFileSummary summary;
        summary.path = dataset_.string();
        std::error_code ec;
        summary.bytes = fs::is_regular_file(dataset_, ec) ? fs::file_size(dataset_, ec) : 0;
        summary.srs_name = crs_.definition.size() < 64 ? crs_.definition : crs_.name;
        summary.crs = crs_.name;
        OGREnvelope env;
        if (layer_->GetExtent(&env, TRUE) == OGRERR_NONE) {
            summary.has_envelope = true;
            summary.envelope_min = {env.MinX, env.MinY, 0};
            summary.envelope_max = {env.MaxX, env.MaxY, 0};
        }
        if (!state_.frame) {
            Vec3d origin = summary.has_envelope ? 0.5 * (summary.envelope_min + summary.envelope_max) : Vec3d{};
            if (crs_.kind != SourceCrs::Kind::Geographic) origin = {std::round(origin.x), std::round(origin.y), 0};
            if (Status s = LocalFrame::create(crs_, origin, &state_.frame); !s.ok())
                return Status::Invalid(fmt::format("{}: {}: {}", fatal::kCrsUnknown, where(), s.error));
            Georeference g;
            g.source_crs = crs_.definition.size() < 64 ? crs_.definition : crs_.name;
            g.origin_source = origin;
            state_.sink->setGeoreference(g);
        }
        if (Status s = state_.frame->mapperFor(crs_, &mapper_); !s.ok())
            return Status::Invalid(fmt::format("{}: {}: {}", fatal::kCrsUnknown, where(), s.error));
        summary_index_ = state_.files.size();
        state_.files.push_back(summary);
        return Status::Ok();
    }
    size_t summary_index_ = 0;

    void resolveFields() {
        OGRFeatureDefn* defn = layer_->GetLayerDefn();
        std::map<std::string, int> by_lower;
        for (int i = 0; i < defn->GetFieldCount(); ++i) by_lower.emplace(lower(defn->GetFieldDefn(i)->GetNameRef()), i);
        for (const auto& [role, names] : kDefaultFieldNames) {
            auto explicit_field = options_.fields.find(role);
            if (explicit_field != options_.fields.end()) {
                if (auto it = by_lower.find(lower(explicit_field->second)); it != by_lower.end()) field_[role] = it->second;
                continue;  // named but absent: checked by the caller before reading
            }
            for (const std::string& n : names)
                if (auto it = by_lower.find(n); it != by_lower.end()) {
                    field_[role] = it->second;
                    break;
                }
        }
    }

    std::optional<double> number(const OGRFeature& f, const char* role) const {
        auto it = field_.find(role);
        if (it == field_.end() || !f.IsFieldSetAndNotNull(it->second)) return std::nullopt;
        const OGRFieldType type = f.GetFieldDefnRef(it->second)->GetType();
        double v = 0;
        if (type == OFTString) {
            const char* s = f.GetFieldAsString(it->second);
            char* end = nullptr;
            v = std::strtod(s, &end);
            if (end == s) return std::nullopt;
        } else {
            v = f.GetFieldAsDouble(it->second);
        }
        if (!std::isfinite(v)) return std::nullopt;
        return v;
    }

    std::string text(const OGRFeature& f, const char* role) const {
        auto it = field_.find(role);
        if (it == field_.end() || !f.IsFieldSetAndNotNull(it->second)) return {};
        return f.GetFieldAsString(it->second);
    }

    // Polygons of a (repaired) geometry, in order.
    static void collectPolygons(const OGRGeometry* g, std::vector<const OGRPolygon*>* out) {
        if (!g) return;
        switch (wkbFlatten(g->getGeometryType())) {
            case wkbPolygon: out->push_back(g->toPolygon()); break;
            case wkbMultiPolygon:
            case wkbGeometryCollection:
                for (const OGRGeometry* part : *g->toGeometryCollection()) collectPolygons(part, out);
                break;
            default: break;  // lines and points from MakeValid: nothing to extrude
        }
    }

    // Ring in local metres, consecutive duplicates removed; source points kept for terrain.
    std::vector<Vec2d> ringToLocal(const OGRLinearRing& ring, bool has_z, std::vector<Vec3d>* samples, double* z_min) {
        std::vector<Vec2d> out;
        std::vector<Vec3d> source;  // kept in step with `out`
        for (int i = 0; i < ring.getNumPoints(); ++i) {
            const Vec3d src{ring.getX(i), ring.getY(i), has_z ? ring.getZ(i) : 0.0};
            Vec3d local;
            if (!mapper_->toLocal(src, &local)) continue;
            const Vec2d p{local.x, local.y};
            if (!out.empty() && std::hypot(p.x - out.back().x, p.y - out.back().y) <= kDuplicatePointTolerance_m) continue;
            out.push_back(p);
            source.push_back(src);
            if (has_z) *z_min = std::min(*z_min, src.z);
        }
        while (out.size() > 1 && std::hypot(out.back().x - out.front().x, out.back().y - out.front().y) <= kDuplicatePointTolerance_m) {
            out.pop_back();
            source.pop_back();  // the closing point is not a second sample
        }
        samples->insert(samples->end(), source.begin(), source.end());
        return out;
    }

    bool readFeature(OGRFeature& f, Record* r) {
        if (!quiet_) state_.counts.footprints_read++;
        r->fid = f.GetFID();
        const std::string id_value = text(f, "id");
        r->feature.gml_id = id_value.empty() ? fmt::format("{}.{}", layer_->GetName(), r->fid) : id_value;
        const std::string& id = r->feature.gml_id;
        auto skip = [&](const char* code, std::string detail) {
            if (!quiet_) state_.counts.footprints_skipped++;
            warn(code, r->fid, id, std::move(detail));
            return false;
        };

        const OGRGeometry* geometry = f.GetGeometryRef();
        if (!geometry || geometry->IsEmpty()) return skip(warn::kFootprintDegenerate, "no geometry");
        std::unique_ptr<OGRGeometry> repaired;
        CPLPushErrorHandler(CPLQuietErrorHandler);
        const bool valid = geometry->IsValid();
        if (!valid) repaired.reset(geometry->MakeValid());
        CPLPopErrorHandler();
        if (!valid) {
            if (!repaired || repaired->IsEmpty()) return skip(warn::kFootprintUnrepairable, "invalid and MakeValid gave nothing");
            if (!quiet_) state_.counts.footprints_repaired++;
            warn(warn::kFootprintRepaired, r->fid, id, "invalid polygon repaired with MakeValid");
            geometry = repaired.get();
        }
        std::vector<const OGRPolygon*> polygons;
        collectPolygons(geometry, &polygons);
        const bool has_z = geometry->Is3D();
        double z_min = 1e300;
        for (const OGRPolygon* poly : polygons) {
            Footprint2d part;
            std::vector<Vec3d> source;
            if (!poly->getExteriorRing()) continue;
            part.outer = ringToLocal(*poly->getExteriorRing(), has_z, &source, &z_min);
            if (part.outer.size() < 3) continue;
            if (signedArea(part.outer) < 0) std::reverse(part.outer.begin(), part.outer.end());
            double area = signedArea(part.outer);
            for (int h = 0; h < poly->getNumInteriorRings(); ++h) {
                auto hole = ringToLocal(*poly->getInteriorRing(h), has_z, &source, &z_min);
                if (hole.size() < 3 || std::abs(signedArea(hole)) < kMinFootprintArea_m2) continue;
                if (signedArea(hole) > 0) std::reverse(hole.begin(), hole.end());
                area += signedArea(hole);
                part.holes.push_back(std::move(hole));
            }
            if (area < kMinFootprintArea_m2) {
                warn(warn::kFootprintDegenerate, r->fid, id, fmt::format("part of {:.3g} m2 skipped", area));
                continue;
            }
            r->parts.push_back(std::move(part));
            r->samples.push_back(std::move(source));
        }
        if (r->parts.empty()) return skip(warn::kFootprintDegenerate, "no part with area");

        // Heights, all in metres above the base unless named absolute.
        const double u = options_.height_unit_m;
        std::optional<double> height = number(f, "height"), eave = number(f, "eave_height"),
                              roof_h = number(f, "roof_height"), storeys = number(f, "storeys"),
                              storey_h = number(f, "storey_height");
        if (height) *height *= u;
        if (eave) *eave *= u;
        if (roof_h) *roof_h *= u;
        const std::string roof_text = text(f, "roof_type");
        std::optional<RoofShape> roof = roof_text.empty() ? std::optional<RoofShape>(RoofShape::Flat)
                                                          : footprints::parseRoofShape(roof_text);
        if (!roof) {
            warn(warn::kRoofTypeUnknown, r->fid, id, fmt::format("roof type \"{}\"; flat roof", roof_text));
            roof = RoofShape::Flat;
        }
        r->roof = *roof;
        if (!height && !eave) {
            if (storeys && *storeys > 0) {
                eave = *storeys * (storey_h ? *storey_h * u : options_.storey_height_m);
            } else {
                height = options_.default_height_m;
                warn(warn::kHeightDefaulted, r->fid, id, fmt::format("no height or storeys; {} m", options_.default_height_m));
            }
        }
        if (r->roof != RoofShape::Flat && !roof_h) {
            double perimeter = 0, area = 0;
            for (const Footprint2d& p : r->parts) {
                area += signedArea(p.outer);
                for (size_t i = 0; i < p.outer.size(); ++i) {
                    const Vec2d& a = p.outer[i];
                    const Vec2d& b = p.outer[(i + 1) % p.outer.size()];
                    perimeter += std::hypot(b.x - a.x, b.y - a.y);
                }
            }
            // 2A/P is half the depth of a long rectangle: the rise of a roof at the default pitch.
            const double pitch = options_.default_roof_pitch_deg * M_PI / 180;
            roof_h = std::min(options_.max_default_roof_height_m, std::tan(pitch) * 2 * area / perimeter);
            if (height) roof_h = std::min(*roof_h, 0.5 * *height);
            warn(warn::kRoofHeightDefaulted, r->fid, id, fmt::format("no roof height; {:.2f} m", *roof_h));
        }
        const double rise = r->roof == RoofShape::Flat ? 0.0 : roof_h.value_or(0.0);
        double eave_m = eave ? *eave : *height - rise;
        double ridge_m = eave ? (height ? std::max(*height, *eave) : *eave + rise) : *height;
        if (r->roof == RoofShape::Flat) ridge_m = eave_m = eave ? *eave : *height;
        if (!(eave_m > 0)) return skip(warn::kFootprintNoHeight, fmt::format("height {} m: nothing to extrude", eave_m));

        // Base: absolute height in the source's vertical units (metres).
        double base = 0;
        const std::optional<double> base_field = number(f, "base_height");
        switch (options_.base) {
            case FootprintOptions::Base::Constant: base = options_.base_constant_m; break;
            case FootprintOptions::Base::Field: base = base_field.value_or(0.0) * u; break;
            case FootprintOptions::Base::Auto: base = base_field ? *base_field * u : (has_z && z_min < 1e300 ? z_min : 0.0); break;
            case FootprintOptions::Base::Terrain: {
                std::vector<Vec3d> pts;
                for (const auto& s : r->samples)
                    for (const Vec3d& p : s) {
                        Vec3d q;
                        if (mapper_->toFrameCrs(p, &q)) pts.push_back(q);
                    }
                if (!terrain_->sample(pts, options_.terrain_mean, &base))
                    warn(warn::kTerrainMissing, r->fid, id, "footprint outside the DEM or on nodata; base 0");
                break;
            }
        }
        // Local z of the base at the footprint (for ENU frames it varies with position; take the first part's centre).
        Vec3d c{};
        for (const Vec2d& p : r->parts.front().outer) c = c + Vec3d{p.x, p.y, 0};
        c = (1.0 / static_cast<double>(r->parts.front().outer.size())) * c;
        Vec3d base_local;
        Vec3d probe_src = r->samples.front().front();
        probe_src.z = base;
        mapper_->toLocal(probe_src, &base_local);
        r->base_z = base_local.z;
        r->eave_z = r->base_z + eave_m;
        r->ridge_z = r->base_z + std::max(ridge_m, eave_m);

        if (quiet_) return true;  // what the party walls need is known

        // Textures, relative to the dataset's folder.
        const fs::path dir = dataset_.parent_path();
        if (std::string t = text(f, "facade_texture"); !t.empty())
            r->facade_texture = textures_.resolve(dir, t, WrapMode::Wrap, {where(), r->fid, id, ""});
        if (std::string t = text(f, "roof_texture"); !t.empty())
            r->roof_texture = textures_.resolve(dir, t, WrapMode::Wrap, {where(), r->fid, id, ""});
        r->projection_width_m = number(f, "projection_width").value_or(eave_m);

        // Feature table: all attributes carried through.
        r->feature.source_file = dataset_.string();
        r->feature.measured_height_m = r->ridge_z - r->base_z;
        r->feature.roof_type = std::string(footprints::roofShapeName(r->roof));
        r->feature.lod = r->roof == RoofShape::Flat ? 1 : 2;
        for (int i = 0; i < f.GetFieldCount(); ++i)
            if (f.IsFieldSetAndNotNull(i)) r->feature.attributes[f.GetFieldDefnRef(i)->GetNameRef()] = f.GetFieldAsString(i);
        return true;
    }

    void emit(Record& r) {
        const uint32_t feature = state_.sink->addFeature(r.feature);
        state_.sink->setFeatureLod(feature, r.feature.lod);
        state_.counts.roof_shapes[std::string(footprints::roofShapeName(r.roof))]++;
        std::vector<Triangle> tris;
        const int32_t wall_colour = state_.sink->addMaterial(Material{{0.85f, 0.82f, 0.75f}, 0.0f});
        const int32_t roof_colour = state_.sink->addMaterial(
            r.roof == RoofShape::Flat ? Material{{0.55f, 0.55f, 0.52f}, 0.0f} : Material{{0.60f, 0.25f, 0.18f}, 0.0f});
        for (size_t p = 0; p < r.parts.size(); ++p) {
            footprints::ExtrusionParams params;
            params.base_z = r.base_z;
            params.eave_z = r.eave_z;
            params.ridge_z = r.ridge_z;
            params.roof = r.roof;
            params.projection_width_m = r.facade_texture >= 0 ? r.projection_width_m : 0.0;
            params.roof_texture_size_m = r.roof_texture >= 0 ? options_.roof_texture_size_m : 0.0;
            params.wall_bottom_z = r.wall_bottom[p];
            const footprints::ExtrusionResult ex = footprints::extrudeFootprint(r.parts[p], params);
            // `fallback` explains any change: nothing built, another roof shape, ignored holes.
            if (ex.polygons.empty()) {
                warn(warn::kFootprintDegenerate, r.fid, r.feature.gml_id, ex.fallback);
            } else if (!ex.fallback.empty()) {
                if (ex.built != r.roof) state_.counts.roof_fallbacks++;
                warn(warn::kRoofFallback, r.fid, r.feature.gml_id, ex.fallback);
            }
            for (const ExtrudedPolygon& poly : ex.polygons) {
                const bool wall = poly.semantic == SurfaceSemantic::Wall;
                const int32_t texture = wall ? r.facade_texture : r.roof_texture;
                const bool textured = texture >= 0 && !poly.uv.empty();
                PolygonRings rings;
                std::vector<Vec3d> pos;
                std::vector<Vec2d> uv;
                for (size_t k = 0; k < poly.rings.size(); ++k) {
                    rings.rings.emplace_back(poly.rings[k]);
                    pos.insert(pos.end(), poly.rings[k].begin(), poly.rings[k].end());
                    if (textured) {
                        rings.uv.emplace_back(poly.uv[k]);
                        uv.insert(uv.end(), poly.uv[k].begin(), poly.uv[k].end());
                    }
                }
                const PolygonTriangulation t = triangulatePolygon(rings);
                pos.insert(pos.end(), t.added_points.begin(), t.added_points.end());
                if (textured) uv.insert(uv.end(), t.added_uv.begin(), t.added_uv.end());
                for (const auto& idx : t.triangles) {
                    Triangle tri;
                    for (int k = 0; k < 3; ++k) {
                        tri.position_local[k] = pos[idx[k]];
                        if (textured) tri.uv[k] = uv[idx[k]];
                    }
                    tri.texture = textured ? texture : -1;
                    tri.material = textured ? -1 : (wall ? wall_colour : roof_colour);
                    tri.feature = feature;
                    tri.semantic = poly.semantic;
                    tris.push_back(tri);
                }
            }
        }
        state_.files[summary_index_].buildings++;
        state_.sink->addTriangles(tris);
    }
};

}  // namespace

const std::vector<std::string>& footprintRoles() {
    static const std::vector<std::string> roles = [] {
        std::vector<std::string> v;
        for (const auto& [role, names] : kDefaultFieldNames) v.push_back(role);
        return v;
    }();
    return roles;
}

Status readFootprints(const fs::path& dataset, const FootprintOptions& options, IngestState& state) {
    GDALAllRegister();
    for (const auto& [role, field] : options.fields)
        if (!kDefaultFieldNames.count(role))
            return Status::Usage(fmt::format("unknown footprint role \"{}\"", role));
    CPLPushErrorHandler(CPLQuietErrorHandler);
    std::unique_ptr<GDALDataset, DatasetCloser> ds(static_cast<GDALDataset*>(
        GDALOpenEx(dataset.string().c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY, nullptr, nullptr, nullptr)));
    CPLPopErrorHandler();
    if (!ds) {
        std::error_code ec;
        if (!fs::exists(dataset, ec)) return Status::Io(fmt::format("{}: {}: no such file", fatal::kIoError, dataset.string()));
        return Status::Invalid(fmt::format("{}: {}: not a vector dataset GDAL/OGR can open", fatal::kNotFootprints, dataset.string()));
    }
    int polygon_layers = 0;
    for (OGRLayer* layer : ds->GetLayers()) {
        const OGRwkbGeometryType type = wkbFlatten(layer->GetGeomType());
        if (type != wkbPolygon && type != wkbMultiPolygon && type != wkbUnknown) continue;
        for (const auto& [role, field] : options.fields)
            if (layer->GetLayerDefn()->GetFieldIndex(field.c_str()) < 0)
                return Status::Usage(fmt::format("{}: layer {} has no field \"{}\" (for {})", dataset.string(),
                                                layer->GetName(), field, role));
        ++polygon_layers;
        LayerReader reader(dataset, layer, options, state);
        if (Status s = reader.run(); !s.ok()) return s;
    }
    if (polygon_layers == 0)
        return Status::Invalid(fmt::format("{}: {}: no polygon layer", fatal::kNotFootprints, dataset.string()));
    return Status::Ok();
}

}  // namespace cityatlas
