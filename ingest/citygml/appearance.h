// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// CityGML appearances (1.0, 2.0; app: namespace) reduced to what the Scene
// needs: per theme, which texture and texture coordinates a ring has, which
// texture-generation matrix or material colour a surface has.

#include <libxml/tree.h>

#include <array>
#include <cstdint>
#include <map>
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
    std::array<double, 12> world_to_texture{};  ///< 3x4, row-major, applied to source coordinates
};

/// Everything one theme says, keyed by gml:id without '#'.
struct ThemeData {
    std::unordered_map<std::string, RingTexcoords> ring_texcoords;  ///< by LinearRing id
    std::unordered_map<std::string, TexGen> texgen;                 ///< by target surface id
    std::unordered_map<std::string, Material> materials;            ///< by target surface id
    uint64_t unsupported = 0;   ///< GeoreferencedTexture and other surface data we skip
    uint64_t duplicate_ring_targets = 0;  ///< a ring's coordinates given twice (first kept)
};

struct AppearanceStore {
    std::vector<TextureImage> images;
    std::map<std::string, ThemeData> themes;   ///< "" for appearances without a theme
    /// Surface data we do not use (GeoreferencedTexture, ...): (line, element
    /// name), for the reader to warn about; it clears the list.
    std::vector<std::pair<int64_t, std::string>> unsupported_seen;
    /// Parses one app:Appearance element into the store.
    void addAppearance(xmlNodePtr appearance);

private:
    std::map<std::pair<std::string, int>, uint32_t> image_index_;  // (uri, wrap) -> index
    uint32_t image(const std::string& uri, WrapMode wrap);
};

/// Theme names in document order and whether each has a texture (for the
/// default theme choice: the first textured one).
struct ThemeCatalogue {
    std::vector<std::string> order;
    std::map<std::string, bool> textured;
    void note(xmlNodePtr appearance);
};

}  // namespace cityatlas::citygml
