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
        xmlNodePtr data = firstChild(member);
        if (!data) continue;
        if (isNamed(data, "ParameterizedTexture")) {
            xmlNodePtr uri = child(data, "imageURI");
            if (!uri) continue;
            xmlNodePtr wrap = child(data, "wrapMode");
            const uint32_t img = image(text(uri), wrap ? parseWrap(text(wrap)) : WrapMode::None);
            for (xmlNodePtr target = firstChild(data); target; target = nextSibling(target)) {
                if (!isNamed(target, "target")) continue;
                const std::string target_id = stripHash(attribute(target, "uri"));
                for (xmlNodePtr param = firstChild(target); param; param = nextSibling(param)) {
                    if (isNamed(param, "TexCoordList")) {
                        for (xmlNodePtr tc = firstChild(param); tc; tc = nextSibling(tc)) {
                            if (!isNamed(tc, "textureCoordinates")) continue;
                            RingTexcoords rt;
                            rt.image = img;
                            std::vector<double> v;
                            if (!parseNumbers(text(tc), &v)) continue;  // reported as a mismatch at use
                            for (size_t i = 0; i + 1 < v.size(); i += 2) rt.uv.push_back({v[i], v[i + 1]});
                            auto [it, inserted] = theme.ring_texcoords.emplace(stripHash(attribute(tc, "ring")), std::move(rt));
                            if (!inserted) theme.duplicate_ring_targets++;
                        }
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
            theme.unsupported++;  // GeoreferencedTexture and anything newer
            unsupported_seen.emplace_back(lineOf(data), localName(data));
        }
    }
}

void ThemeCatalogue::note(xmlNodePtr appearance) {
    const std::string name = themeOf(appearance);
    bool has_texture = false;
    for (xmlNodePtr member = firstChild(appearance); member; member = nextSibling(member))
        if (isNamed(member, "surfaceDataMember"))
            if (xmlNodePtr d = firstChild(member); d && isNamed(d, "ParameterizedTexture")) has_texture = true;
    auto it = textured.find(name);
    if (it == textured.end()) {
        order.push_back(name);
        textured[name] = has_texture;
    } else {
        it->second = it->second || has_texture;
    }
}

}  // namespace cityatlas::citygml
