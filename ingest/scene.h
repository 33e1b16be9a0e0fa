// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The Scene: what every reader (CityGML, attributed footprints, synthetic towns)
/// produces and what the atlas stage consumes. A textured triangle soup.
///
/// Frame and units
/// ---------------
/// * Positions are double-precision metres in a LOCAL frame centred on
///   `Georeference::origin_source`: x = east, y = north, z = up, and the
///   point (0,0,0) is the origin. Keeping coordinates small and in double
///   until a tile writes them relative to its own centre as float32 is what
///   keeps millimetre precision at northings of 1e7 m and at ECEF magnitudes.
/// * For a projected source CRS (UTM, Gauss-Krueger, ...), a local position is
///   the source coordinate minus the origin: "grid east/north/up". The
///   rotation and scale from that grid frame to the true tangent (ENU) frame
///   at the origin and on to Earth-centred coordinates is carried by
///   `Georeference::local_to_ecef` (a 4x4 column-major matrix, metres), filled
///   by the georeferencing step when it runs; until then it is empty and the
///   scene is only locally metric.
/// * Texture coordinates are (u, v) with v = 0 at the BOTTOM of the image, as
///   CityGML and OpenGL define them. They may lie far outside [0,1]: repeated
///   textures (wrap mode) at repeat counts of 1000 and more are legal.
/// * Areas are square metres, lengths metres, angles radians, unless a name
///   says otherwise (`_px`, `_deg`).
///
/// Textures are REFERENCED here (path, size, channels, wrap), never decoded: the
/// atlas stage reads pixels on demand through a bounded cache.

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/geometry.h"
#include "ingest/texture_table.h"

namespace cityatlas {

/// What a surface is, as CityGML's thematic boundary surfaces say it (or as a
/// reader infers it from the normal for LOD1 solids, which carry no semantics).
enum class SurfaceSemantic : uint8_t {
    Unclassified,
    Wall,
    Roof,
    Ground,
    Closure,
    OuterFloor,
    OuterCeiling,
    Installation,
};
inline constexpr int kSurfaceSemanticCount = 8;
std::string_view semanticName(SurfaceSemantic s);  ///< "wall", "roof", ...
/// The inverse of semanticName; empty for an unknown name.
std::optional<SurfaceSemantic> semanticFromName(std::string_view name);

/// Colour of an untextured surface (app:X3DMaterial): linear RGB in [0,1].
struct Material {
    std::array<float, 3> diffuse{0.8f, 0.8f, 0.8f};
    float transparency = 0.0f;  ///< 0 = opaque, as in X3D
    friend bool operator==(const Material&, const Material&) = default;
};

/// A building or building part, with its attributes.
struct Feature {
    std::string gml_id;
    std::string name;
    std::string source_file;
    int32_t parent = -1;  ///< index of the parent feature (BuildingPart -> Building), or -1
    int8_t lod = 0;       ///< LOD of the geometry taken (1 or 2); 0 when it has none of its own
    std::optional<double> measured_height_m;
    std::string roof_type;
    std::string function;
    std::map<std::string, std::string> attributes;  ///< generic attributes, as text
};

/// One triangle with everything the atlas and tile stages need per triangle.
/// Corners are counter-clockwise seen from the side the surface faces.
struct Triangle {
    std::array<Vec3d, 3> position_local;  ///< metres, local frame (see file comment)
    std::array<Vec2d, 3> uv;              ///< texture coordinates; zero when untextured
    int32_t texture = -1;                 ///< index into Scene::textures, or -1
    int32_t material = -1;                ///< index into Scene::materials (used when texture < 0), or -1
    uint32_t feature = 0;                 ///< index into Scene::features
    SurfaceSemantic semantic = SurfaceSemantic::Unclassified;
};

/// Where the local frame sits on Earth.
struct Georeference {
    std::string source_crs;   ///< e.g. "EPSG:25832"; compound CRS as "EPSG:25832+7837"
    Vec3d origin_source;      ///< origin of the local frame, in source CRS units
    /// Local frame -> ECEF (EPSG:4978), 4x4 column-major, metres: exact for
    /// ENU frames; for grid frames the tangent-linear map at the origin, which
    /// cannot follow the Earth's curvature (7.8 m of drop 10 km out; the
    /// ingest report states the error over the scene). Renderers of large
    /// scenes should place tiles with enu_to_ecef and per-vertex exact
    /// positions (ingest/georef.h, LocalToEcef::toEnu). Empty when the scene
    /// is not georeferenced (local engineering CRS) or not yet computed.
    std::optional<std::array<double, 16>> local_to_ecef;
    /// East/north/up tangent frame at the origin -> ECEF, 4x4 column-major:
    /// the 3D Tiles root transform.
    std::optional<std::array<double, 16>> enu_to_ecef;
    bool grid_frame = false;  ///< local coordinates are grid offsets of a projected CRS
};

struct Scene {
    Georeference georef;
    std::vector<Triangle> triangles;
    TextureTable textures;
    std::vector<Material> materials;
    std::vector<Feature> features;

    /// Adds a material unless an equal one exists; returns its index.
    int32_t internMaterial(const Material& m);
};

/// Summary figures of a scene, computed from the triangles (used by reports,
/// the CLI and tests).
struct SceneStats {
    size_t triangles = 0;
    size_t textured_triangles = 0;
    size_t features = 0;
    size_t textures = 0;
    std::array<size_t, kSurfaceSemanticCount> triangles_by_semantic{};
    std::array<double, kSurfaceSemanticCount> area_by_semantic_m2{};
    Box3d bounds_local;
};
SceneStats computeStats(const Scene& scene);

/// Builds SceneStats one triangle at a time (for streaming ingests that never
/// hold the whole scene).
class SceneStatsAccumulator {
public:
    void add(const Triangle& t);
    SceneStats finish() const;  ///< features and textures are left for the caller

private:
    SceneStats stats_;
    std::array<double, kSurfaceSemanticCount> sum_{}, correction_{};
};

/// Area of a triangle in square metres.
double triangleArea(const std::array<Vec3d, 3>& p);

}  // namespace cityatlas
