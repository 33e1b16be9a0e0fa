// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/citygml/appearance.h"

#include <charconv>
#include <cstring>

#include "ingest/citygml/xml_input.h"

namespace cityatlas::citygml {
namespace {

WrapMode parseWrap(const std::string& s) {
    if (s == "wrap") return WrapMode::Wrap;
    if (s == "mirror") return WrapMode::Mirror;
    if (s == "clamp") return WrapMode::Clamp;
    if (s == "border") return WrapMode::Border;
    return WrapMode::None;
}

// Whitespace-separated doubles; false on a token that is not a number.
bool parseNumbers(const std::string& s, std::vector<double>* out) {
    const char* p = s.data();
    const char* end = p + s.size();
    while (p < end) {
        while (p < end && std::isspace(static_cast<unsigned char>(*p))) ++p;
        if (p == end) break;
        double v = 0;
        auto [next, ec] = std::from_chars(p, end, v);
        if (ec != std::errc()) return false;
        out->push_back(v);
        p = next;
    }
    return true;
}

std::string stripHash(std::string s) { return !s.empty() && s[0] == '#' ? s.substr(1) : s; }

std::string themeOf(xmlNodePtr appearance) {
    xmlNodePtr t = child(appearance, "theme");
    return t ? text(t) : std::string();
}

// The first set's entries win, as the first of two definitions does elsewhere.
void mergeInto(ThemeData& to, const ThemeData& from) {
    to.ring_texcoords.insert(from.ring_texcoords.begin(), from.ring_texcoords.end());
    to.texgen.insert(from.texgen.begin(), from.texgen.end());
    to.georeferenced.insert(from.georeferenced.begin(), from.georeferenced.end());
    to.materials.insert(from.materials.begin(), from.materials.end());
}

void mergeInto(ThemeData& to, const AppearanceStore::SurfaceDataById& from) {
    for (const auto* ring : from.rings) to.ring_texcoords.insert(*ring);
    for (const auto* material : from.materials) to.materials.insert(*material);
    if (from.rest) mergeInto(to, *from.rest);
}

}  // namespace

uint32_t AppearanceStore::image(const std::string& uri, WrapMode wrap) {
    auto key = std::make_pair(uri, static_cast<int>(wrap));
    auto it = image_index_.find(key);
    if (it != image_index_.end()) return it->second;
    images.push_back({uri, wrap});
    const auto idx = static_cast<uint32_t>(images.size() - 1);
    image_index_[key] = idx;
    return idx;
}


void AppearanceStore::addAppearance(xmlNodePtr appearance) {
    ThemeData& theme = themes[themeOf(appearance)];
    for (xmlNodePtr member = firstChild(appearance); member; member = nextSibling(member)) {
        if (!isNamed(member, "surfaceDataMember")) continue;
        if (xmlNodePtr data = firstChild(member)) {
            const uint64_t unsupported_before = theme.unsupported;
            addSurfaceData(data, theme);
            const std::string id = gmlId(data);
            if (!id.empty() && theme.unsupported == unsupported_before) keepById(data, theme, surface_data_by_id_[id]);
        } else if (auto it = surface_data_by_id_.find(xlinkHref(member)); it != surface_data_by_id_.end()) {
            mergeInto(theme, it->second);
        }
    }
}

// What `data` (just added to `theme`) gives, for a later reference by id:
// parsed again on its own, each ring whose coordinates its theme now holds
// points at that entry (entries are never changed or erased, and nodes of
// the maps never move); the rest is copied.
void AppearanceStore::keepById(xmlNodePtr data, const ThemeData& theme, SurfaceDataById& by_id) {
    ThemeData own;
    addSurfaceData(data, own);
    auto rest = [&]() -> ThemeData& {
        if (!by_id.rest) by_id.rest = std::make_unique<ThemeData>();
        return *by_id.rest;
    };
    // Each of own's entries: the theme's when equal, else kept in `rest`.
    auto point = [&](auto& own_map, const auto& theme_map, auto& pointers, const auto& rest_map, const auto& same) {
        for (auto& entry : own_map) {
            const auto it = theme_map.find(entry.first);
            if (it != theme_map.end() && same(it->second, entry.second))
                pointers.push_back(&*it);
            else
                rest_map().insert(std::move(entry));
        }
        own_map.clear();
    };
    point(own.ring_texcoords, theme.ring_texcoords, by_id.rings, [&]() -> auto& { return rest().ring_texcoords; },
          [](const RingTexcoords& a, const RingTexcoords& b) { return a.image == b.image && a.uv == b.uv; });
    point(own.materials, theme.materials, by_id.materials, [&]() -> auto& { return rest().materials; },
          [](const Material& a, const Material& b) { return a == b; });
    if (!own.texgen.empty() || !own.georeferenced.empty()) mergeInto(rest(), own);
}

void AppearanceStore::addSurfaceData(xmlNodePtr data, ThemeData& theme) {
    if (isNamed(data, "ParameterizedTexture")) {
        addParameterizedTexture(data, theme);
    } else if (isNamed(data, "GeoreferencedTexture")) {
        addGeoreferencedTexture(data, theme);
    } else if (isNamed(data, "X3DMaterial")) {
        Material mat;
        std::vector<double> v;
        if (xmlNodePtr d = child(data, "diffuseColor"); d && parseNumbers(text(d), &v) && v.size() == 3)
            mat.diffuse = {static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2])};
        v.clear();
        if (xmlNodePtr t = child(data, "transparency"); t && parseNumbers(text(t), &v) && v.size() == 1)
            mat.transparency = static_cast<float>(v[0]);
        for (xmlNodePtr target = firstChild(data); target; target = nextSibling(target))
            if (isNamed(target, "target")) theme.materials.emplace(stripHash(text(target)), mat);
    } else {
        theme.unsupported++;  // CityGML 3.0's and ADEs' surface data
        unsupported_seen.emplace_back(lineOf(data), localName(data));
    }
}

void AppearanceStore::addParameterizedTexture(xmlNodePtr data, ThemeData& theme) {
    xmlNodePtr uri = child(data, "imageURI");
    if (!uri) return;
    xmlNodePtr wrap = child(data, "wrapMode");
    const uint32_t img = image(text(uri), wrap ? parseWrap(text(wrap)) : WrapMode::None);
    auto addRing = [&](const std::string& ring, std::vector<Vec2d> uv) {
        RingTexcoords rt;
        rt.image = img;
        rt.uv = std::move(uv);
        if (!theme.ring_texcoords.emplace(ring, std::move(rt)).second) theme.duplicate_ring_targets++;
    };
    // CityGML 3.0 wraps targets in textureParameterization/TextureAssociation,
    // which this reader does not follow yet: say so rather than drop silently.
    if (child(data, "textureParameterization") && !child(data, "target")) {
        theme.unsupported++;
        unsupported_seen.emplace_back(lineOf(data), "ParameterizedTexture (CityGML 3.0 textureParameterization)");
        return;
    }
    for (xmlNodePtr target = firstChild(data); target; target = nextSibling(target)) {
        if (!isNamed(target, "target")) continue;
        const std::string target_id = stripHash(attribute(target, "uri"));
        if (!firstChild(target)) {  // the parameterization by reference
            if (auto it = texcoord_lists_by_id_.find(xlinkHref(target)); it != texcoord_lists_by_id_.end())
                for (const auto& [ring, uv] : it->second) addRing(ring, uv);
            continue;
        }
        for (xmlNodePtr param = firstChild(target); param; param = nextSibling(param)) {
            if (isNamed(param, "TexCoordList")) {
                std::vector<std::pair<std::string, std::vector<Vec2d>>> list;
                for (xmlNodePtr tc = firstChild(param); tc; tc = nextSibling(tc)) {
                    if (!isNamed(tc, "textureCoordinates")) continue;
                    std::vector<double> v;
                    if (!parseNumbers(text(tc), &v)) continue;  // reported as a mismatch at use
                    std::vector<Vec2d> uv;
                    for (size_t i = 0; i + 1 < v.size(); i += 2) uv.push_back({v[i], v[i + 1]});
                    list.emplace_back(stripHash(attribute(tc, "ring")), std::move(uv));
                }
                for (const auto& [ring, uv] : list) addRing(ring, uv);
                if (const std::string id = gmlId(param); !id.empty()) texcoord_lists_by_id_.emplace(id, std::move(list));
            } else if (isNamed(param, "TexCoordGen")) {
                xmlNodePtr m = child(param, "worldToTexture");
                std::vector<double> v;
                if (m && parseNumbers(text(m), &v) && v.size() == 12) {
                    TexGen g;
                    g.image = img;
                    std::copy(v.begin(), v.end(), g.world_to_texture.begin());
                    theme.texgen.emplace(target_id, g);
                }
            }
        }
    }
}

void AppearanceStore::addGeoreferencedTexture(xmlNodePtr data, ThemeData& theme) {
    xmlNodePtr uri = child(data, "imageURI");
    if (!uri) return;
    xmlNodePtr wrap = child(data, "wrapMode");
    GeoTexture g;
    g.image = image(text(uri), wrap ? parseWrap(text(wrap)) : WrapMode::None);
    g.line = lineOf(data);
    if (xmlNodePtr p = child(data, "preferWorldFile")) g.prefer_world_file = text(p) != "false" && text(p) != "0";
    std::vector<double> ref, m;
    xmlNodePtr point = child(data, "referencePoint");
    if (point) point = child(point, "Point");
    xmlNodePtr pos = point ? child(point, "pos") : nullptr;
    if (!pos && point) pos = child(point, "coordinates");
    xmlNodePtr orientation = child(data, "orientation");
    if (pos && orientation && parseNumbers(text(pos), &ref) && ref.size() >= 2 && parseNumbers(text(orientation), &m) &&
        m.size() == 4 && m[0] * m[3] - m[1] * m[2] != 0) {
        g.has_georeference = true;  // orientation row-major: x = m0 col + m1 row, y = m2 col + m3 row
        g.pixel_to_world = {m[0], m[1], ref[0], m[2], m[3], ref[1]};
    }
    for (xmlNodePtr target = firstChild(data); target; target = nextSibling(target))
        if (isNamed(target, "target")) theme.georeferenced.emplace(stripHash(text(target)), g);
}

void ThemeCatalogue::note(xmlNodePtr appearance) {
    const std::string name = themeOf(appearance);
    bool has_texture = false;
    for (xmlNodePtr member = firstChild(appearance); member; member = nextSibling(member))
        if (isNamed(member, "surfaceDataMember"))
            if (xmlNodePtr d = firstChild(member);
                d && (isNamed(d, "ParameterizedTexture") || isNamed(d, "GeoreferencedTexture")))
                has_texture = true;
    auto it = textured.find(name);
    if (it == textured.end()) {
        order.push_back(name);
        textured[name] = has_texture;
    } else {
        it->second = it->second || has_texture;
    }
}

std::vector<std::string> textureImageUris(xmlNodePtr appearance, std::string* theme) {
    *theme = themeOf(appearance);
    std::vector<std::string> uris;
    for (xmlNodePtr member = firstChild(appearance); member; member = nextSibling(member))
        if (isNamed(member, "surfaceDataMember"))
            if (xmlNodePtr d = firstChild(member);
                d && (isNamed(d, "ParameterizedTexture") || isNamed(d, "GeoreferencedTexture")))
                if (xmlNodePtr uri = child(d, "imageURI")) uris.push_back(text(uri));
    return uris;
}

}  // namespace cityatlas::citygml
