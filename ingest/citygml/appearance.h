// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// CityGML appearances (1.0, 2.0; app: namespace) reduced to what the Scene
// needs: per theme, which texture and texture coordinates a ring has, which
// texture-generation matrix or material colour a surface has.

#include <libxml/tree.h>

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "ingest/scene.h"

namespace cityatlas::citygml {

struct TextureImage {
    std::string uri;        ///< as written (imageURI)
    WrapMode wrap = WrapMode::None;
};

struct RingTexcoords {
    uint32_t image = 0;            ///< index into AppearanceStore::images
    std::vector<Vec2d> uv;         ///< as written, closing pair included if present
};

struct TexGen {
    uint32_t image = 0;
    std::array<double, 12> world_to_texture{};  ///< 3x4, row-major, applied to source coordinates - offset
    Vec3d offset{};  ///< 0 for a TexCoordGen; a georeferenced image's corner, so large coordinates cancel exactly
};

/// A GeoreferencedTexture: an image laid over the ground plan. Its pixel
/// grid's georeference, (x, y) = M (col, row) + reference with (col, row) the
/// centre of a pixel counted from the upper left one, comes from
/// referencePoint + orientation when both are given, else from the image's
/// world file or its embedded GeoTIFF tags (found by the reader, which knows
/// the files).
struct GeoTexture {
    uint32_t image = 0;
    bool has_georeference = false;       ///< referencePoint and orientation both given
    std::array<double, 6> pixel_to_world{};  ///< x = a0 col + a1 row + a2, y = a3 col + a4 row + a5
    bool prefer_world_file = true;       ///< over the image's own georeference (CityGML's default)
    int64_t line = 0;
};

/// Everything one theme says, keyed by gml:id without '#'.
struct ThemeData {
    std::unordered_map<std::string, RingTexcoords> ring_texcoords;  ///< by LinearRing id
    std::unordered_map<std::string, TexGen> texgen;                 ///< by target surface id
    std::unordered_map<std::string, GeoTexture> georeferenced;      ///< by target surface id
    std::unordered_map<std::string, Material> materials;            ///< by target surface id
    uint64_t unsupported = 0;   ///< surface data we skip (CityGML 3.0's, ADEs')
    uint64_t duplicate_ring_targets = 0;  ///< a ring's coordinates given twice (first kept)
};

struct AppearanceStore {
    std::vector<TextureImage> images;
    std::map<std::string, ThemeData> themes;   ///< "" for appearances without a theme
    /// Surface data we do not use: (line, element name), for the reader to
    /// warn about; it clears the list.
    std::vector<std::pair<int64_t, std::string>> unsupported_seen;
    /// Parses one app:Appearance element into the store. Surface data and
    /// TexCoordLists with a gml:id are kept, so a later surfaceDataMember or
    /// target that points at them by xlink:href (another theme reusing a
    /// texture) gets the same data.
    void addAppearance(xmlNodePtr appearance);

    /// Surface data kept by gml:id for a later surfaceDataMember that points
    /// at it: its rings and material targets as the entries its theme holds
    /// for them (8 bytes each; a city's surface data have ids in 3DCityDB and
    /// FME exports), and a copy of whatever else it gave (generated
    /// coordinates, georeferenced textures, an entry its theme had from
    /// another surface data).
    struct SurfaceDataById {
        std::vector<const std::pair<const std::string, RingTexcoords>*> rings;
        std::vector<const std::pair<const std::string, Material>*> materials;
        std::unique_ptr<ThemeData> rest;
    };

private:
    std::map<std::pair<std::string, int>, uint32_t> image_index_;  // (uri, wrap) -> index
    std::unordered_map<std::string, SurfaceDataById> surface_data_by_id_;
    std::unordered_map<std::string, std::vector<std::pair<std::string, std::vector<Vec2d>>>> texcoord_lists_by_id_;
    uint32_t image(const std::string& uri, WrapMode wrap);
    void addSurfaceData(xmlNodePtr data, ThemeData& theme);
    void addParameterizedTexture(xmlNodePtr data, ThemeData& theme);
    void addGeoreferencedTexture(xmlNodePtr data, ThemeData& theme);
    void keepById(xmlNodePtr data, const ThemeData& theme, SurfaceDataById& by_id);
};

/// Theme names in document order and whether each has a texture (for the
/// default theme choice: the first textured one).
struct ThemeCatalogue {
    std::vector<std::string> order;
    std::map<std::string, bool> textured;
    void note(xmlNodePtr appearance);
};

/// The imageURI of every texture (parameterized or georeferenced) in an
/// appearance, as written, and the appearance's theme ("" when it has none).
std::vector<std::string> textureImageUris(xmlNodePtr appearance, std::string* theme);

}  // namespace cityatlas::citygml
