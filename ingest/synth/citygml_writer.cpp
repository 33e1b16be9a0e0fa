// SPDX-License-Identifier: GPL-3.0-or-later
// CityGML 2.0 writer for synthetic towns. Element order follows the 2.0
// schemas exactly (a test validates the output with xmllint against them).
#include <charconv>
#include <cstdio>
#include <fstream>
#include <map>

#include <fmt/format.h>

#include "cityatlas_version.h"
#include "ingest/crs.h"
#include "ingest/synth/write_town.h"

namespace cityatlas::synth {

std::string exactDecimal(double v) {
    if (v == 0) return "0";
    char buf[64];
    auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed);
    if (ec != std::errc()) {  // only for magnitudes far beyond any coordinate
        end = std::to_chars(buf, buf + sizeof buf, v).ptr;
    }
    return std::string(buf, end);
}

namespace {

constexpr const char* kTheme = "rgbTexture";

struct GmlWriter {
    std::string out;
    const Town& town;
    const std::string srs;

    explicit GmlWriter(const Town& t) : town(t), srs(epsgUrn(t.settings.crs_epsg)) {}

    Vec3d source(const Vec3d& local) const { return local + town.settings.origin_source; }

    void number(double v) { out += exactDecimal(v); }

    void envelope(const Box3d& box_local, const char* indent) {
        const Vec3d lo = source(box_local.min), hi = source(box_local.max);
        fmt::format_to(std::back_inserter(out),
                       "{0}<gml:boundedBy>\n{0}  <gml:Envelope srsName=\"{1}\" srsDimension=\"3\">\n"
                       "{0}    <gml:lowerCorner>{2} {3} {4}</gml:lowerCorner>\n"
                       "{0}    <gml:upperCorner>{5} {6} {7}</gml:upperCorner>\n"
                       "{0}  </gml:Envelope>\n{0}</gml:boundedBy>\n",
                       indent, srs, exactDecimal(lo.x), exactDecimal(lo.y), exactDecimal(lo.z), exactDecimal(hi.x),
                       exactDecimal(hi.y), exactDecimal(hi.z));
    }

    void ring(const std::string& id, const std::vector<Vec3d>& pts, bool use_pos) {
        fmt::format_to(std::back_inserter(out), "<gml:LinearRing gml:id=\"{}\">", id);
        // Rings are closed in GML: the first point is repeated at the end.
        if (use_pos) {
            for (size_t i = 0; i <= pts.size(); ++i) {
                const Vec3d p = source(pts[i % pts.size()]);
                out += "<gml:pos>";
                number(p.x), out += ' ', number(p.y), out += ' ', number(p.z);
                out += "</gml:pos>";
            }
        } else {
            out += "<gml:posList srsDimension=\"3\">";
            for (size_t i = 0; i <= pts.size(); ++i) {
                const Vec3d p = source(pts[i % pts.size()]);
                if (i) out += ' ';
                number(p.x), out += ' ', number(p.y), out += ' ', number(p.z);
            }
            out += "</gml:posList>";
        }
        out += "</gml:LinearRing>";
    }

    void polygon(const SynthSurface& s, bool use_pos, const char* indent) {
        fmt::format_to(std::back_inserter(out), "{}<gml:Polygon gml:id=\"{}\">", indent, s.gml_id);
        for (size_t r = 0; r < s.rings.size(); ++r) {
            out += r == 0 ? "<gml:exterior>" : "<gml:interior>";
            ring(fmt::format("{}_r{}", s.gml_id, r), s.rings[r], use_pos);
            out += r == 0 ? "</gml:exterior>" : "</gml:interior>";
        }
        out += "</gml:Polygon>";
    }

    void texCoords(const SynthSurface& s) {
        fmt::format_to(std::back_inserter(out), "            <app:target uri=\"#{}\"><app:TexCoordList>", s.gml_id);
        for (size_t r = 0; r < s.uv.size(); ++r) {
            fmt::format_to(std::back_inserter(out), "<app:textureCoordinates ring=\"#{}_r{}\">", s.gml_id, r);
            const auto& uv = s.uv[r];
            for (size_t i = 0; i <= uv.size(); ++i) {
                if (i) out += ' ';
                number(uv[i % uv.size()].x), out += ' ', number(uv[i % uv.size()].y);
            }
            out += "</app:textureCoordinates>";
        }
        out += "</app:TexCoordList></app:target>\n";
    }

    void parameterizedTexture(const SynthTexture& tex, const std::vector<const SynthSurface*>& targets) {
        fmt::format_to(std::back_inserter(out),
                       "        <app:surfaceDataMember>\n"
                       "          <app:ParameterizedTexture>\n"
                       "            <app:imageURI>{}</app:imageURI>\n"
                       "            <app:mimeType>image/png</app:mimeType>\n"
                       "            <app:wrapMode>wrap</app:wrapMode>\n",
                       tex.relative_path);
        for (const SynthSurface* s : targets) texCoords(*s);
        out += "          </app:ParameterizedTexture>\n        </app:surfaceDataMember>\n";
    }

    void material(const Material& m, const std::vector<const SynthSurface*>& targets) {
        fmt::format_to(std::back_inserter(out),
                       "        <app:surfaceDataMember>\n          <app:X3DMaterial>\n"
                       "            <app:diffuseColor>{} {} {}</app:diffuseColor>\n"
                       "            <app:transparency>{}</app:transparency>\n",
                       exactDecimal(m.diffuse[0]), exactDecimal(m.diffuse[1]), exactDecimal(m.diffuse[2]),
                       exactDecimal(m.transparency));
        for (const SynthSurface* s : targets)
            fmt::format_to(std::back_inserter(out), "            <app:target>#{}</app:target>\n", s->gml_id);
        out += "          </app:X3DMaterial>\n        </app:surfaceDataMember>\n";
    }

    // The building's own appearance: its facade texture and its materials.
    // Paving is shared by many buildings and goes into one global appearance.
    void localAppearance(const SynthBuilding& b) {
        std::vector<const SynthSurface*> facade;
        std::map<int32_t, std::vector<const SynthSurface*>> by_material;
        for (const SynthSurface& s : b.surfaces) {
            if (s.texture == b.facade_texture && s.texture >= 0) facade.push_back(&s);
            else if (s.texture < 0 && s.material >= 0) by_material[s.material].push_back(&s);
        }
        fmt::format_to(std::back_inserter(out), "      <app:appearance>\n        <app:Appearance>\n"
                                                 "        <app:theme>{}</app:theme>\n", kTheme);
        if (!facade.empty()) parameterizedTexture(town.textures[b.facade_texture], facade);
        for (const auto& [m, targets] : by_material) material(town.materials[m], targets);
        out += "        </app:Appearance>\n      </app:appearance>\n";
    }

    static const char* thematicElement(SurfaceSemantic s) {
        switch (s) {
            case SurfaceSemantic::Wall: return "bldg:WallSurface";
            case SurfaceSemantic::Roof: return "bldg:RoofSurface";
            case SurfaceSemantic::Ground: return "bldg:GroundSurface";
            default: return "bldg:ClosureSurface";
        }
    }

    void building(const SynthBuilding& b) {
        Box3d box;
        for (const SynthSurface& s : b.surfaces)
            for (const auto& r : s.rings)
                for (const Vec3d& p : r) box.extend(p);
        const bool use_pos = b.number % 5 == 0;

        fmt::format_to(std::back_inserter(out),
                       "  <core:cityObjectMember>\n    <bldg:Building gml:id=\"{}\">\n"
                       "      <gml:name>Building {}</gml:name>\n",
                       b.gml_id, b.number);
        envelope(box, "      ");
        fmt::format_to(std::back_inserter(out),
                       "      <gen:stringAttribute name=\"footprint_shape\"><gen:value>{}</gen:value></gen:stringAttribute>\n"
                       "      <gen:intAttribute name=\"number\"><gen:value>{}</gen:value></gen:intAttribute>\n",
                       shapeName(b.shape), b.number);
        localAppearance(b);
        fmt::format_to(std::back_inserter(out),
                       "      <bldg:roofType>{}</bldg:roofType>\n"
                       "      <bldg:measuredHeight uom=\"m\">{}</bldg:measuredHeight>\n"
                       "      <bldg:storeysAboveGround>{}</bldg:storeysAboveGround>\n"
                       "      <bldg:storeyHeightsAboveGround uom=\"m\">",
                       roofTypeCityGmlCode(b.roof), exactDecimal(b.ridge_height_m), b.storeys);
        for (int i = 0; i < b.storeys; ++i) {
            if (i) out += ' ';
            number(b.storey_height_m);
        }
        out += "</bldg:storeyHeightsAboveGround>\n";

        if (town.settings.lod == 1) {
            // LOD1: one solid, polygons inline, no thematic surfaces.
            out += "      <bldg:lod1Solid><gml:Solid><gml:exterior><gml:CompositeSurface>\n";
            for (const SynthSurface& s : b.surfaces) {
                out += "        <gml:surfaceMember>";
                polygon(s, use_pos, "");
                out += "</gml:surfaceMember>\n";
            }
            out += "      </gml:CompositeSurface></gml:exterior></gml:Solid></bldg:lod1Solid>\n";
        } else {
            // LOD2: the solid references the boundary polygons, which are
            // defined later in boundedBy: forward xlinks, as real exports have.
            out += "      <bldg:lod2Solid><gml:Solid><gml:exterior><gml:CompositeSurface>\n";
            for (const SynthSurface& s : b.surfaces)
                fmt::format_to(std::back_inserter(out), "        <gml:surfaceMember xlink:href=\"#{}\"/>\n", s.gml_id);
            out += "      </gml:CompositeSurface></gml:exterior></gml:Solid></bldg:lod2Solid>\n";
            for (const SynthSurface& s : b.surfaces) {
                const char* element = thematicElement(s.semantic);
                fmt::format_to(std::back_inserter(out),
                               "      <bldg:boundedBy>\n        <{} gml:id=\"{}_ts\">\n"
                               "          <bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember>\n",
                               element, s.gml_id);
                polygon(s, use_pos, "            ");
                fmt::format_to(std::back_inserter(out),
                               "\n          </gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface>\n"
                               "        </{}>\n      </bldg:boundedBy>\n",
                               element);
            }
        }
        out += "    </bldg:Building>\n  </core:cityObjectMember>\n";
    }
};

}  // namespace

Status writeCityGml(const Town& town, const std::filesystem::path& file) {
    std::ofstream os(file, std::ios::binary);
    if (!os) return Status::Io(fmt::format("{}: cannot create file", file.string()));

    GmlWriter w(town);
    const TownSettings& s = town.settings;
    w.out = fmt::format(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
        "<!-- Synthetic town written by cityatlas {}: seed={} buildings={} lod={} texture-size={} crs=EPSG:{} -->\n"
        "<core:CityModel xmlns:core=\"http://www.opengis.net/citygml/2.0\"\n"
        "  xmlns:bldg=\"http://www.opengis.net/citygml/building/2.0\"\n"
        "  xmlns:app=\"http://www.opengis.net/citygml/appearance/2.0\"\n"
        "  xmlns:gen=\"http://www.opengis.net/citygml/generics/2.0\"\n"
        "  xmlns:gml=\"http://www.opengis.net/gml\"\n"
        "  xmlns:xlink=\"http://www.w3.org/1999/xlink\"\n"
        "  xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\"\n"
        "  xsi:schemaLocation=\"http://www.opengis.net/citygml/building/2.0 "
        "http://schemas.opengis.net/citygml/building/2.0/building.xsd "
        "http://www.opengis.net/citygml/appearance/2.0 http://schemas.opengis.net/citygml/appearance/2.0/appearance.xsd "
        "http://www.opengis.net/citygml/generics/2.0 http://schemas.opengis.net/citygml/generics/2.0/generics.xsd\">\n"
        "  <gml:name>Synthetic town, seed {}</gml:name>\n",
        kCityAtlasVersion, s.seed, s.buildings, s.lod, s.texture_size_px, s.crs_epsg, s.seed);
    Box3d all;
    for (const SynthBuilding& b : town.buildings)
        for (const SynthSurface& sf : b.surfaces)
            for (const auto& r : sf.rings)
                for (const Vec3d& p : r) all.extend(p);
    w.envelope(all, "  ");

    // Flush per building so memory stays at one building's text.
    for (const SynthBuilding& b : town.buildings) {
        w.building(b);
        os.write(w.out.data(), static_cast<std::streamsize>(w.out.size()));
        w.out.clear();
    }

    // One global appearance for the shared paving texture, targeting roofs of
    // many buildings: readers must resolve targets anywhere in the file.
    std::vector<const SynthSurface*> paved;
    for (const SynthBuilding& b : town.buildings)
        for (const SynthSurface& sf : b.surfaces)
            if (sf.texture >= 0 && town.textures[sf.texture].kind == SynthTexture::Kind::Paving) paved.push_back(&sf);
    if (!paved.empty()) {
        fmt::format_to(std::back_inserter(w.out),
                       "  <app:appearanceMember>\n    <app:Appearance>\n        <app:theme>{}</app:theme>\n", kTheme);
        w.parameterizedTexture(town.textures[0], paved);
        w.out += "    </app:Appearance>\n  </app:appearanceMember>\n";
    }
    // The orthophoto on every roof: one GeoreferencedTexture whose targets
    // are the roof polygons; placed by the world file beside the image, or
    // by referencePoint + orientation (the centre of the upper left pixel).
    if (town.orthophoto_texture >= 0) {
        const OrthophotoGrid& g = town.orthophoto;
        fmt::format_to(std::back_inserter(w.out),
                       "  <app:appearanceMember>\n    <app:Appearance>\n      <app:theme>{}</app:theme>\n"
                       "      <app:surfaceDataMember>\n        <app:GeoreferencedTexture>\n"
                       "          <app:imageURI>{}</app:imageURI>\n          <app:mimeType>image/png</app:mimeType>\n"
                       "          <app:wrapMode>none</app:wrapMode>\n",
                       kTheme, town.textures[town.orthophoto_texture].relative_path);
        if (s.orthophoto == OrthophotoMode::ReferencePoint)
            fmt::format_to(std::back_inserter(w.out),
                           "          <app:referencePoint><gml:Point><gml:pos srsDimension=\"2\">{} {}</gml:pos></gml:Point>"
                           "</app:referencePoint>\n          <app:orientation>{} 0 0 {}</app:orientation>\n",
                           exactDecimal(g.west_m + 0.5 * g.pixel_m), exactDecimal(g.north_m - 0.5 * g.pixel_m),
                           exactDecimal(g.pixel_m), exactDecimal(-g.pixel_m));
        for (const SynthBuilding& b : town.buildings)
            for (const SynthSurface& sf : b.surfaces)
                if (sf.texture == town.orthophoto_texture)
                    fmt::format_to(std::back_inserter(w.out), "          <app:target>#{}</app:target>\n", sf.gml_id);
        w.out += "        </app:GeoreferencedTexture>\n      </app:surfaceDataMember>\n    </app:Appearance>\n"
                 "  </app:appearanceMember>\n";
    }
    w.out += "</core:CityModel>\n";
    os.write(w.out.data(), static_cast<std::streamsize>(w.out.size()));
    os.close();
    if (!os) return Status::Io(fmt::format("{}: write failed (disk full?)", file.string()));
    return Status::Ok();
}

}  // namespace cityatlas::synth
