// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Synthetic towns: the fixture factory every stage is tested and measured with.
///
/// A town is a grid of city blocks separated by streets; each block holds
/// 3 x 2 lots; each lot one building. Everything is deterministic for a seed.
///
/// Exactness by construction: footprint vertices lie on a 0.625 m grid around
/// the lot centre, buildings are rotated only by angles with rational sine
/// and cosine (0, 90 degrees, and the 3-4-5 angles), heights are multiples of
/// 1/8 m and roof heights are products of such values with k/4. Every
/// coordinate is therefore an exact binary double, in the local frame AND
/// after adding an integer origin of up to 2^26 m, and is printed exactly by
/// a shortest round-trip formatter. Areas and counts in truth.json are exact
/// facts about the written files, not approximations of them.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "ingest/scene.h"
#include "ingest/synth/orthophoto.h"

namespace cityatlas::synth {

enum class FootprintShape : uint8_t { Rectangle, LShape, UShape, Courtyard };
enum class RoofType : uint8_t { Flat, Gable, Hip, Pyramid };
std::string_view shapeName(FootprintShape s);     ///< "rectangle", "l_shape", ...
std::string_view roofTypeName(RoofType r);        ///< "flat", "gable", "hip", "pyramid"
std::string_view roofTypeCityGmlCode(RoofType r); ///< AdV/SIG3D codes: 1000, 1030, 1040, 1070
std::string_view roofTypeOsmName(RoofType r);     ///< OSM roof:shape: flat, gabled, hipped, pyramidal

/// How roofs get the town's orthophoto (see orthophoto.h): not at all (paving
/// and colours, the default), as a GeoreferencedTexture placed by a world file
/// beside the image, or by referencePoint + orientation in the CityGML.
enum class OrthophotoMode : uint8_t { None, WorldFile, ReferencePoint };

struct TownSettings {
    uint32_t buildings = 100;
    int lod = 2;                  ///< 1: flat blocks (lod1Solid); 2: roofs and thematic surfaces
    uint64_t seed = 1;
    int texture_size_px = 512;    ///< facade and paving textures are square
    int crs_epsg = 25832;         ///< a projected CRS in metres
    Vec3d origin_source{690000, 5336000, 0};  ///< centre of the town, source CRS
    OrthophotoMode orthophoto = OrthophotoMode::None;
};

/// One textured or coloured polygon. Rings are open (no closing duplicate);
/// ring 0 is the exterior, counter-clockwise seen from outside the building.
struct SynthSurface {
    std::string gml_id;                        ///< of the gml:Polygon
    SurfaceSemantic semantic = SurfaceSemantic::Unclassified;
    std::vector<std::vector<Vec3d>> rings;     ///< local frame, metres
    std::vector<std::vector<Vec2d>> uv;        ///< per ring, per vertex; empty if untextured
    int32_t texture = -1;                      ///< index into Town::textures, or -1
    int32_t material = -1;                     ///< index into Town::materials, or -1
};

struct SynthBuilding {
    uint32_t number = 0;          ///< 1-based, drawn on the facade texture
    std::string gml_id;           ///< "bldg_000001"
    FootprintShape shape = FootprintShape::Rectangle;
    RoofType roof = RoofType::Flat;
    int storeys = 1;
    double storey_height_m = 3;
    double base_height_m = 0;     ///< terrain height under the building, local z
    double eave_height_m = 0;     ///< wall height above base
    double ridge_height_m = 0;    ///< highest point above base (== eave for flat roofs)
    double projection_width_m = 0;///< facade texture width on the wall
    double footprint_area_m2 = 0;
    std::vector<Vec2d> outer;     ///< footprint, counter-clockwise, local frame
    std::vector<std::vector<Vec2d>> holes;  ///< courtyards, clockwise
    std::vector<SynthSurface> surfaces;
    int32_t facade_texture = -1;
    int32_t roof_texture = -1;    ///< paving on flat roofs, or -1 (material colour)
};

struct SynthTexture {
    enum class Kind : uint8_t { Facade, Paving, Orthophoto } kind = Kind::Facade;
    std::string relative_path;    ///< relative to the output folder, '/' separated
    int size_px = 0;              ///< square side; the orthophoto's size is the Town's orthophoto grid
    int channels = 3;
    uint32_t building_number = 0; ///< facades only
    int storeys = 1, window_columns = 1;
    uint64_t seed = 0;
};

struct Town {
    TownSettings settings;
    std::vector<SynthBuilding> buildings;
    std::vector<SynthTexture> textures;
    std::vector<Material> materials;
    double paving_repeat_m = 0;   ///< one paving texture tile covers this many metres
    OrthophotoGrid orthophoto;    ///< when settings.orthophoto is not None
    int32_t orthophoto_texture = -1;
};

/// Builds the town's geometry, texture list and materials in memory (no I/O).
Town generateTown(const TownSettings& settings);

/// The town as a Scene (every polygon triangulated; texture paths made
/// absolute under `output_dir`). This is the "ingest" of a synthetic town that
/// needs no parsing; the CityGML reader must reproduce it from the files.
Scene townToScene(const Town& town, const std::filesystem::path& output_dir);

}  // namespace cityatlas::synth
