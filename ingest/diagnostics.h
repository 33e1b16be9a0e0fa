// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Diagnostics of an ingest: fatal errors end it (one line, exit 1); warnings
/// are counted by code with a few examples each and the work goes on with a
/// repair, a downgrade or a skip. Every code is listed here and documented in
/// schemas/ingest_report.schema.json.

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace cityatlas {

/// Fatal error codes (the first word of the one-line message after "error:").
namespace fatal {
inline constexpr const char* kIoError = "io_error";                // cannot open / read the file
inline constexpr const char* kEmptyFile = "empty_file";            // zero bytes or only whitespace
inline constexpr const char* kNotXml = "not_xml";                  // binary or non-XML text
inline constexpr const char* kXmlMalformed = "xml_malformed";      // includes truncated files
inline constexpr const char* kDoctypeForbidden = "doctype_forbidden";  // DTDs/entities (XXE, entity bombs)
inline constexpr const char* kNotCityGml = "not_citygml";          // XML, but no CityGML root
inline constexpr const char* kCrsMissing = "crs_missing";          // no srsName and no --crs
inline constexpr const char* kCrsUnknown = "crs_unknown";          // srsName PROJ cannot interpret
inline constexpr const char* kThemeUnknown = "theme_unknown";      // --theme names no theme of the file
inline constexpr const char* kNotFootprints = "not_footprints";    // not a polygon dataset GDAL/OGR opens
}  // namespace fatal

/// Warning codes.
namespace warn {
inline constexpr const char* kRingUnclosed = "ring_unclosed";                // closed implicitly
inline constexpr const char* kRingDuplicatePoints = "ring_duplicate_points";  // consecutive repeats removed
inline constexpr const char* kRingTooFewPoints = "ring_too_few_points";      // < 3 distinct: ring dropped
inline constexpr const char* kPolygonDegenerate = "polygon_degenerate";      // zero area / collinear: skipped
inline constexpr const char* kPolygonNonPlanar = "polygon_non_planar";       // > 1 cm off its plane: triangulated
inline constexpr const char* kRingSelfIntersection = "ring_self_intersection";  // triangulated with added points
inline constexpr const char* kRingSelfTouching = "ring_self_touching";       // repeated vertex / hole touching
inline constexpr const char* kCoordinateNotFinite = "coordinate_not_finite";  // NaN/inf: polygon skipped
inline constexpr const char* kCoordinateParse = "coordinate_parse_error";    // not a number: polygon skipped
inline constexpr const char* kCoordinates2d = "coordinates_2d";              // srsDimension 2: z = 0
inline constexpr const char* kXlinkUnresolved = "xlink_unresolved";          // href to an unknown id
inline constexpr const char* kDuplicateGmlId = "duplicate_gml_id";
inline constexpr const char* kTextureMissing = "texture_missing";            // file absent: colour fallback
inline constexpr const char* kTextureUnreadable = "texture_unreadable";      // not an image: colour fallback
inline constexpr const char* kTexcoordsMismatch = "texcoords_mismatch";      // count != ring vertices
inline constexpr const char* kSolidInverted = "solid_inverted";              // inward solid: faces flipped
inline constexpr const char* kNoLodGeometry = "no_lod_geometry";             // building without LOD <= 2
inline constexpr const char* kAppearanceUnsupported = "appearance_unsupported";  // surface data we do not read
inline constexpr const char* kGeoreferenceMissing = "georeference_missing";  // GeoreferencedTexture placed nowhere
inline constexpr const char* kCityGmlNoNamespace = "citygml_no_namespace";    // <CityModel> root in no namespace
inline constexpr const char* kCityGmlMemberMissing = "citygml_member_missing";  // object not in a cityObjectMember
inline constexpr const char* kAdeIgnored = "ade_ignored";                    // ADE element in a city object: ignored
inline constexpr const char* kXmlNamespaceError = "xml_namespace_error";    // e.g. an undeclared prefix: read as in no namespace
inline constexpr const char* kInputsOverlap = "inputs_overlap";              // two inputs share most buildings
inline constexpr const char* kCrsNotGeoreferenced = "crs_not_georeferenced";  // local engineering CRS
inline constexpr const char* kCrsVerticalIgnored = "crs_vertical_ignored";    // unusable height part of a compound CRS
// Atlas stage:
inline constexpr const char* kAtlasResolutionLowered = "atlas_resolution_lowered";  // forced leaf: below d_min's texels
// Footprints:
inline constexpr const char* kFootprintRepaired = "footprint_repaired";        // invalid polygon fixed by MakeValid
inline constexpr const char* kFootprintUnrepairable = "footprint_unrepairable";  // MakeValid gave nothing: skipped
inline constexpr const char* kFootprintDegenerate = "footprint_degenerate";    // no geometry / sliver part: skipped
inline constexpr const char* kFootprintNoHeight = "footprint_no_height";       // height <= 0: skipped
inline constexpr const char* kHeightDefaulted = "height_defaulted";            // no height or storeys: default used
inline constexpr const char* kRoofTypeUnknown = "roof_type_unknown";           // unknown roof type: flat
inline constexpr const char* kRoofHeightDefaulted = "roof_height_defaulted";   // pitched roof without its height
inline constexpr const char* kRoofFallback = "roof_fallback";                  // shape not possible on this footprint
inline constexpr const char* kTerrainMissing = "terrain_missing";              // footprint off the DEM: base 0
}  // namespace warn

struct DiagnosticExample {
    std::string file;
    int64_t line = 0;       ///< 0 when unknown
    std::string gml_id;     ///< empty when unknown
    std::string detail;
};

/// Counts warnings by code and keeps the first few examples of each.
class Diagnostics {
public:
    explicit Diagnostics(size_t examples_per_code = 5) : max_examples_(examples_per_code) {}
    void warn(const char* code, DiagnosticExample example);
    uint64_t count(const std::string& code) const;
    uint64_t total() const;
    struct Entry {
        uint64_t count = 0;
        std::vector<DiagnosticExample> examples;
    };
    const std::map<std::string, Entry>& entries() const { return entries_; }

private:
    size_t max_examples_;
    std::map<std::string, Entry> entries_;
};

}  // namespace cityatlas
