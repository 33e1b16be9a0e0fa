// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Attributed building footprints (papers/000 §3.1.2) to textured LOD1/LOD2
/// buildings: any polygon layer GDAL/OGR opens (shapefile with .prj/.cpg,
/// GeoPackage, GeoJSON, FlatGeobuf, ...). Footprints are repaired with OGR's
/// MakeValid where needed, extruded between a base and an eave height, and
/// roofed by their roof type (footprints/extrude.h). Walls shared by two
/// touching footprints of the same layer are not generated below the lower
/// building's eave ("party walls": nobody can see them).
///
/// A layer is read twice (footprints/party_walls.h): the first pass finds
/// the party walls, keeping only a table of edges (20 bytes an edge), the
/// second reads each footprint again and hands its triangles to the sink at
/// once. No footprint is held beyond its own turn.

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "ingest/citygml/citygml_reader.h"

namespace cityatlas {

/// Which attribute holds what. Roles: id, height (top above base; OSM
/// "height"), eave_height, base_height, storeys, storey_height, roof_type,
/// roof_height, facade_texture, projection_width, roof_texture. A role left
/// empty is looked up among common names (OSM, ALKIS-like, this project's
/// synthetic towns; see kDefaultFieldNames in the .cpp), case-insensitively.
struct FootprintOptions {
    std::map<std::string, std::string> fields;   ///< role -> field name
    double height_unit_m = 1.0;                  ///< metres per height unit (0.3048 for feet)
    double default_height_m = 10.0;              ///< when neither height nor storeys are known
    double storey_height_m = 3.0;                ///< when storeys are known but no storey height
    double default_roof_pitch_deg = 30.0;        ///< pitched roof without a roof height
    double max_default_roof_height_m = 4.0;      ///< ... capped at this
    double roof_texture_size_m = 10.0;           ///< one roof texture repeat covers this many metres
    enum class Base { Auto, Constant, Field, Terrain } base = Base::Auto;  ///< Auto: field if present, else geometry z, else 0
    double base_constant_m = 0;
    std::string terrain_dem;                     ///< GeoTIFF (any GDAL raster) for Base::Terrain
    bool terrain_mean = false;                   ///< sample the DEM's mean under the footprint instead of its minimum
};

/// Roles that footprint options may name.
const std::vector<std::string>& footprintRoles();

/// Reads every polygon layer of a dataset into the state's sink (sharing its
/// frame with other inputs). Fatal problems return a failed Status.
Status readFootprints(const std::filesystem::path& dataset, const FootprintOptions& options, IngestState& state);

}  // namespace cityatlas
