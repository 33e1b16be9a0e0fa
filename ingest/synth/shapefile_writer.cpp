// SPDX-License-Identifier: GPL-3.0-or-later
// Footprints of a synthetic town as an ESRI shapefile, through GDAL/OGR.
#include <memory>

#include <cpl_error.h>
#include <gdal_priv.h>
#include <ogrsf_frmts.h>

#include <fmt/format.h>

#include "ingest/synth/write_town.h"

namespace cityatlas::synth {
namespace {

struct DatasetCloser {
    void operator()(GDALDataset* ds) const { GDALClose(ds); }
};

// Field names are at most 10 characters (dBASE). Heights are metres;
// base_h is absolute (source CRS vertical units), the others relative to it.
struct FieldSpec {
    const char* name;
    OGRFieldType type;
    int width, precision;
};
constexpr FieldSpec kFields[] = {
    {"gml_id", OFTString, 16, 0},     // matches the CityGML building's gml:id
    {"number", OFTInteger, 9, 0},     // the number drawn on the facade
    {"height", OFTReal, 12, 6},       // ridge above base (OSM "height")
    {"eave_h", OFTReal, 12, 6},       // wall top above base
    {"roof_h", OFTReal, 12, 6},       // ridge - eave (OSM "roof:height")
    {"base_h", OFTReal, 14, 6},       // terrain height under the building
    {"levels", OFTInteger, 4, 0},     // storeys (OSM "building:levels")
    {"storey_h", OFTReal, 8, 4},      // storey height
    {"roof_shape", OFTString, 10, 0}, // OSM roof:shape: flat, gabled, hipped, pyramidal
    {"facade_tex", OFTString, 64, 0}, // facade image, relative to the shapefile
    {"proj_w", OFTReal, 12, 6},       // facade texture width on the wall, metres
    {"roof_tex", OFTString, 64, 0},   // roof image or empty (then a colour)
};

}  // namespace

Status writeFootprintShapefile(const Town& town, const std::filesystem::path& shp_file) {
    GDALAllRegister();
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("ESRI Shapefile");
    if (!driver) return Status::Io("GDAL has no ESRI Shapefile driver");

    CPLPushErrorHandler(CPLQuietErrorHandler);
    std::unique_ptr<GDALDataset, DatasetCloser> ds(
        driver->Create(shp_file.string().c_str(), 0, 0, 0, GDT_Unknown, nullptr));
    CPLPopErrorHandler();
    if (!ds) return Status::Io(fmt::format("{}: cannot create shapefile: {}", shp_file.string(), CPLGetLastErrorMsg()));

    OGRSpatialReference srs;
    if (srs.importFromEPSG(town.settings.crs_epsg) != OGRERR_NONE)
        return Status::Io(fmt::format("EPSG:{} is not a CRS known to PROJ's database", town.settings.crs_epsg));
    srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);

    // A fixed DBF date keeps repeated runs byte-identical (GDAL writes today's
    // date otherwise).
    const char* options[] = {"ENCODING=UTF-8", "DBF_DATE_LAST_UPDATE=2000-01-01", nullptr};
    OGRLayer* layer = ds->CreateLayer("footprints", &srs, wkbPolygon, const_cast<char**>(options));
    if (!layer) return Status::Io(fmt::format("{}: cannot create layer: {}", shp_file.string(), CPLGetLastErrorMsg()));
    for (const FieldSpec& f : kFields) {
        OGRFieldDefn defn(f.name, f.type);
        defn.SetWidth(f.width);
        defn.SetPrecision(f.precision);
        if (layer->CreateField(&defn) != OGRERR_NONE)
            return Status::Io(fmt::format("{}: cannot create field {}", shp_file.string(), f.name));
    }

    const Vec3d origin = town.settings.origin_source;
    for (const SynthBuilding& b : town.buildings) {
        OGRFeature feature(layer->GetLayerDefn());
        feature.SetField("gml_id", b.gml_id.c_str());
        feature.SetField("number", static_cast<int>(b.number));
        feature.SetField("height", b.ridge_height_m);
        feature.SetField("eave_h", b.eave_height_m);
        feature.SetField("roof_h", b.ridge_height_m - b.eave_height_m);
        feature.SetField("base_h", origin.z + b.base_height_m);
        feature.SetField("levels", b.storeys);
        feature.SetField("storey_h", b.storey_height_m);
        feature.SetField("roof_shape", std::string(roofTypeOsmName(b.roof)).c_str());
        feature.SetField("facade_tex", town.textures[b.facade_texture].relative_path.c_str());
        feature.SetField("proj_w", b.projection_width_m);
        feature.SetField("roof_tex", b.roof_texture >= 0 ? town.textures[b.roof_texture].relative_path.c_str() : "");

        OGRPolygon polygon;
        auto addRing = [&](const std::vector<Vec2d>& ring) {
            OGRLinearRing r;
            for (const Vec2d& p : ring) r.addPoint(origin.x + p.x, origin.y + p.y);
            r.closeRings();
            polygon.addRing(&r);
        };
        addRing(b.outer);
        for (const auto& hole : b.holes) addRing(hole);
        feature.SetGeometry(&polygon);
        if (layer->CreateFeature(&feature) != OGRERR_NONE)
            return Status::Io(fmt::format("{}: cannot write feature {}: {}", shp_file.string(), b.gml_id,
                                            CPLGetLastErrorMsg()));
    }
    // GDAL 3.6's FlushCache returns nothing; errors surface through CPLGetLastErrorType.
    CPLErrorReset();
    ds.reset();  // closes and flushes all five files
    if (CPLGetLastErrorType() >= CE_Failure)
        return Status::Io(fmt::format("{}: write failed: {}", shp_file.string(), CPLGetLastErrorMsg()));
    return Status::Ok();
}

}  // namespace cityatlas::synth
