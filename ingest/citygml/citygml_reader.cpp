// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/citygml/citygml_reader.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>
#include <unordered_map>
#include <unordered_set>

#include <fmt/format.h>

#include "core/external_sort.h"
#include "ingest/citygml/appearance.h"
#include "ingest/citygml/xml_input.h"
#include "ingest/citygml/xml_scan.h"
#include "ingest/image_georeference.h"
#include "ingest/texture_resolver.h"
#include "ingest/triangulate.h"

namespace cityatlas {
namespace fs = std::filesystem;
using namespace citygml;

namespace {

// Named tolerances (local metres).
constexpr double kDuplicatePointTolerance_m = 1e-4;  // consecutive vertices closer than this are one
constexpr double kNonPlanarTolerance_m = 0.01;        // report polygons bent more than 1 cm

// ---------------------------------------------------------------------------
// Raw geometry as read, before cleanup and triangulation.

struct RawRing {
    std::string id;
    std::vector<Vec3d> points;  // source coordinates in file axis order, closing point as written
    int64_t line = 0;
};

struct RawPolygon {
    std::string id;                       // may be empty
    std::vector<std::string> surface_ids; // enclosing surfaces with ids, innermost first (appearance targets)
    std::vector<RawRing> rings;           // exterior first
    bool reversed = false;                // from OrientableSurface orientation="-"
    SurfaceSemantic semantic = SurfaceSemantic::Unclassified;
    std::string solid;                    // id of the solid it bounds, if any
    int64_t line = 0;
};

std::string versionOf(const std::string& ns) {
    if (ns.find("/3.0") != std::string::npos) return "3.0";
    if (ns.find("/2.0") != std::string::npos) return "2.0";
    if (ns.find("/1.0") != std::string::npos || ns.find("/1/0") != std::string::npos) return "1.0";
    return "";
}

bool isCityGmlNamespace(const std::string& ns) {
    return ns.find("opengis.net/citygml") != std::string::npos || ns.find("citygml.org/citygml") != std::string::npos;
}

bool isFeatureCollectionNamespace(const std::string& ns) {
    return ns.rfind("http://www.opengis.net/wfs", 0) == 0 || ns.rfind("http://www.opengis.net/gml", 0) == 0;
}

// Namespaces whose elements the reader knows (CityGML modules, GML, xAL
// addresses, XLink); an element in any other namespace inside a city object
// is an Application Domain Extension (ADE) and is ignored, counted.
bool isKnownNamespace(xmlNodePtr n) {
    if (!n->ns || !n->ns->href) return true;  // no namespace: read by local name, as before
    const std::string ns = reinterpret_cast<const char*>(n->ns->href);
    return isCityGmlNamespace(ns) || ns.rfind("http://www.opengis.net/gml", 0) == 0 ||
           ns.find("xAL") != std::string::npos || ns == "http://www.w3.org/1999/xlink";
}

SurfaceSemantic semanticOf(const char* name) {
    static const std::pair<const char*, SurfaceSemantic> table[] = {
        {"WallSurface", SurfaceSemantic::Wall},        {"RoofSurface", SurfaceSemantic::Roof},
        {"GroundSurface", SurfaceSemantic::Ground},    {"ClosureSurface", SurfaceSemantic::Closure},
        {"OuterFloorSurface", SurfaceSemantic::OuterFloor}, {"OuterCeilingSurface", SurfaceSemantic::OuterCeiling},
    };
    for (const auto& [n, s] : table)
        if (std::strcmp(name, n) == 0) return s;
    return SurfaceSemantic::Unclassified;
}

bool startsWith(const char* s, const char* prefix) { return std::strncmp(s, prefix, std::strlen(prefix)) == 0; }

// Whitespace-separated doubles. Returns false at a token that is not a
// number (parse error); NaN/inf parse and are caught by the caller.
bool parseDoubles(const char* p, const char* end, std::vector<double>* out) {
    while (p < end) {
        while (p < end && std::isspace(static_cast<unsigned char>(*p))) ++p;
        if (p == end) break;
        double v = 0;
        auto [next, ec] = std::from_chars(p, end, v);
        if (ec != std::errc() || (next < end && !std::isspace(static_cast<unsigned char>(*next)))) return false;
        out->push_back(v);
        p = next;
    }
    return true;
}

// The element's text as text() gives it; no copy when it is one text node
// (the usual case), else concatenated into `scratch`.
std::string_view textView(xmlNodePtr n, std::string* scratch) {
    const xmlChar* only = nullptr;
    int count = 0;
    for (xmlNodePtr c = n->children; c; c = c->next)
        if ((c->type == XML_TEXT_NODE || c->type == XML_CDATA_SECTION_NODE) && c->content && count++ == 0) only = c->content;
    if (count == 1) return reinterpret_cast<const char*>(only);
    *scratch = text(n);
    return *scratch;
}

// The dimension of a ring's numbers when no srsDimension says it (GML's
// default is the CRS's, which a 3D city model's projected CRS does not give):
// the one under which the ring closes, 3 before 2; else the one that divides
// the count, 3 before 2.
int guessDimension(const std::vector<double>& v) {
    auto closes = [&](size_t d) {
        return v.size() % d == 0 && v.size() >= 4 * d &&
               std::equal(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(d), v.end() - static_cast<std::ptrdiff_t>(d));
    };
    if (closes(3)) return 3;
    if (closes(2)) return 2;
    return v.size() % 3 == 0 ? 3 : v.size() % 2 == 0 ? 2 : 3;
}

// srsDimension declared on the element or its ancestors, else `above`: the
// one in effect above the subtree's root (a captured subtree has no parents).
int declaredDimension(xmlNodePtr n, int above = 0) {
    for (; n && n->type == XML_ELEMENT_NODE; n = n->parent) {
        const std::string d = attribute(n, "srsDimension");
        if (!d.empty()) return std::atoi(d.c_str());
    }
    return above;
}

// ---------------------------------------------------------------------------

class FileReader {
public:
    FileReader(const fs::path& file, IngestState& state) : file_(file), state_(state) {}

    Status run() {
        if (Status s = indexPass(); !s.ok()) return s;
        if (Status s = setUpFrame(); !s.ok()) return s;
        if (Status s = chooseTheme(); !s.ok()) return s;
        if (!foreign_needed_.empty())
            if (Status s = foreignPass(); !s.ok()) return s;
        return readPass();
    }

private:
    const fs::path file_;
    const fs::path base_dir_ = file_.parent_path();  // image URIs are relative to it
    IngestState& state_;
    InputFileSummary summary_;
    int file_dimension_ = 0;              // srsDimension from the root envelope
    std::string srs_name_;
    std::optional<Vec3d> first_point_;    // origin fallback when there is no envelope
    bool lat_lon_order_ = false;          // geographic file written as lat, lon
    SourceCrs crs_;
    std::unique_ptr<LocalFrame::Mapper> mapper_;

    ThemeCatalogue theme_catalogue_;
    AppearanceStore global_appearances_;
    std::string theme_;

    // Cross-object xlinks: (id hash, member) pairs from the index pass. A
    // file's geometry ids are sorted with bounded memory (16 bytes an id: 1.6
    // GB for a million LOD2 buildings of a hundred polygons each), in the
    // scratch folder beyond 32 MB; the references to other city objects are
    // few, held in a deque (chunked: no doubling copy).
    struct IdOwner {
        uint64_t hash;
        uint32_t member;
        bool operator<(const IdOwner& o) const { return hash < o.hash || (hash == o.hash && member < o.member); }
    };
    ExternalSorter<IdOwner> id_owner_{state_.options.scratch_dir};
    std::deque<std::pair<uint64_t, uint32_t>> href_user_;
    std::vector<uint64_t> member_ids_, member_hrefs_;  // the city object being indexed: its ids and references
    std::unordered_set<uint64_t> foreign_needed_;
    std::unordered_map<std::string, std::vector<RawPolygon>> foreign_geometry_;

    // Per member during the read pass.
    int member_dimension_ = 0;  // srsDimension in effect above the member
    std::unordered_map<std::string_view, xmlNodePtr> ids_;  // keys point into the member's DOM
    std::unordered_set<std::string> emitted_ids_;  // polygons already emitted for this city object
    AppearanceStore local_appearances_;
    TextureResolver textures_{*state_.sink, state_.diagnostics};

    void warn(const char* code, int64_t line, const std::string& id, std::string detail) {
        state_.diagnostics.warn(code, {file_.string(), line, id, std::move(detail)});
    }

    void warnUnsupported(AppearanceStore& store) {
        for (const auto& [line, name] : store.unsupported_seen)
            warn(warn::kAppearanceUnsupported, line, "", fmt::format("app:{} is not used", name));
        store.unsupported_seen.clear();
    }

    void progress(const char* pass, const XmlInput& in) {
        if (state_.progress) state_.progress(pass, in.bytesConsumed(), in.fileSize());
    }

    // ---- pass 1 ---------------------------------------------------------------

    // The root: a CityModel in a CityGML namespace; also, as producers write
    // them, a CityModel in no namespace at all (FME's CityGML 1.0 exports:
    // only the bldg:/gen: children carry one) and a WFS/GML FeatureCollection
    // (3DCityDB's WFS). The first pass reports the no-namespace root once.
    Status openRoot(XmlInput& in, bool report) {
        if (Status s = in.open(file_); !s.ok()) return s;
        std::string name, ns;
        if (Status s = in.rootElement(&name, &ns); !s.ok()) return s;
        return checkRoot(name, ns, report);
    }
    Status checkRoot(const std::string& name, const std::string& ns, bool report) {
        const bool city_model = name == "CityModel" && (ns.empty() || isCityGmlNamespace(ns));
        const bool collection = name == "FeatureCollection" && isFeatureCollectionNamespace(ns);
        if (!city_model && !collection)
            return Status::Invalid(fmt::format("{}: {}: the root element is <{}>{}, not a CityGML CityModel",
                                            fatal::kNotCityGml, file_.string(), name,
                                            ns.empty() ? "" : " in namespace " + ns));
        if (report && city_model && ns.empty())
            warn(warn::kCityGmlNoNamespace, 1, "",
                 "<CityModel> has no namespace (CityGML's is http://www.opengis.net/citygml/<version>); read as CityGML, "
                 "the version taken from the city objects");
        if (report) summary_.citygml_version = versionOf(ns);
        return Status::Ok();
    }

    // A child of the root that holds a city object: the object inside a
    // member element, or (schema-invalid, but written) the object itself.
    enum class RootChild { Other, Member, BareObject };
    static RootChild classify(const std::string& local_name) {
        if (local_name == "cityObjectMember" || local_name == "featureMember" || local_name == "member")
            return RootChild::Member;
        if (local_name == "Building") return RootChild::BareObject;
        return RootChild::Other;
    }
    static xmlNodePtr objectOf(xmlNodePtr child, RootChild kind) {
        return kind == RootChild::BareObject ? child : firstChild(child);
    }

    // The version of a file whose root does not say it, from its first city object.
    void noteVersion(const char* object_namespace) {
        if (!summary_.citygml_version.empty() || !object_namespace || !*object_namespace) return;
        summary_.citygml_version = versionOf(object_namespace);
    }

    // `inherited_dimension`: srsDimension of boundedBy's ancestors (not in a captured subtree).
    void readEnvelope(xmlNodePtr bounded_by, int inherited_dimension) {
        xmlNodePtr env = child(bounded_by, "Envelope");
        if (!env) return;
        if (srs_name_.empty()) srs_name_ = attribute(env, "srsName");
        xmlNodePtr lo = child(env, "lowerCorner"), hi = child(env, "upperCorner");
        if (!file_dimension_) {
            const int declared = declaredDimension(lo ? lo : env);
            file_dimension_ = declared ? declared : inherited_dimension;
        }
        std::vector<double> a, b;
        const std::string ta = lo ? text(lo) : "", tb = hi ? text(hi) : "";
        if (lo && hi && parseDoubles(ta.data(), ta.data() + ta.size(), &a) &&
            parseDoubles(tb.data(), tb.data() + tb.size(), &b) && a.size() >= 2 && a.size() == b.size()) {
            summary_.has_envelope = true;
            summary_.envelope_min = {a[0], a[1], a.size() > 2 ? a[2] : 0.0};
            summary_.envelope_max = {b[0], b[1], b.size() > 2 ? b[2] : 0.0};
        }
    }

    static bool isGeometryElement(const char* n) {
        if (n[0] != 'P' && n[0] != 'C' && n[0] != 'M' && n[0] != 'S' && n[0] != 'O' && n[0] != 'T') return false;
        static const char* names[] = {"Polygon", "CompositeSurface", "MultiSurface", "Solid", "OrientableSurface",
                                      "Surface", "TriangulatedSurface", "Tin", "Triangle", "Shell", "MultiSolid",
                                      "CompositeSolid"};
        for (const char* g : names)
            if (std::strcmp(n, g) == 0) return true;
        return false;
    }

    // The texture images the read pass will resolve, read in the background
    // meanwhile (only the theme asked for, when one is).
    void prefetchImages(xmlNodePtr appearance) {
        std::string theme;
        const std::vector<std::string> uris = textureImageUris(appearance, &theme);
        if (!state_.options.theme.empty() && theme != state_.options.theme) return;
        for (const std::string& uri : uris) textures_.prefetch(base_dir_, uri);
    }

    // The index pass as a SAX scan (no DOM but for the envelope, appearances
    // and the first coordinates): per city object, the ids of its geometry
    // and the xlinks it makes; the file's srsName, dimension, first point,
    // themes and global appearances.
    struct IndexScan : ScanHandler {
        FileReader& r;
        RootChild current = RootChild::Other;  // the root child being scanned
        bool object_seen = false;              // its first element (the city object) met
        uint32_t member = 0, members = 0;
        explicit IndexScan(FileReader& reader) : r(reader) {}
        Status root(const ScanElement& e) override { return r.checkRoot(e.local_name, e.ns, true); }
        bool element(const ScanElement& e) override { return r.indexElement(e, *this); }
        bool captured(xmlNodePtr n, int depth, int dimension, int64_t) override {
            return r.indexCaptured(n, depth, dimension);
        }
        void namespaceError(int64_t line, const std::string& message) override {
            r.warn(warn::kXmlNamespaceError, line, "", message + "; read as in no namespace");
        }
        void progress(uint64_t done) override {
            if (r.state_.progress) r.state_.progress("index", done, r.summary_.bytes);
        }
        void endOfScan() override { r.finishGlobalMember(); }
    };

    static constexpr const char* kGmlNamespace = "http://www.opengis.net/gml";
    static constexpr const char* kXlinkNamespace = "http://www.w3.org/1999/xlink";

    // True for the subtrees indexCaptured() reads.
    bool indexElement(const ScanElement& e, IndexScan& scan) {
        const char* n = e.local_name;
        if (e.depth == 1) {
            if (scan.current != RootChild::Other) flushMemberRefs(scan.member);
            finishGlobalMember();
            scan.current = classify(n);
            scan.object_seen = false;
            if (std::strcmp(n, "appearanceMember") == 0) global_.open = true;
            if (scan.current == RootChild::Other) return std::strcmp(n, "boundedBy") == 0;
            scan.member = scan.members++;
            if (scan.current == RootChild::BareObject) {
                warn(warn::kCityGmlMemberMissing, e.line, e.attribute("id", kGmlNamespace),
                     "a <Building> directly under the root, not inside a <cityObjectMember>; read all the same");
                noteVersion(e.ns);
                scan.object_seen = true;
            }
            return false;
        }
        if (global_.open) return globalElement(e);
        if (scan.current == RootChild::Other) return false;
        if (!scan.object_seen) {  // a member's first element: its city object
            noteVersion(e.ns);
            scan.object_seen = true;
        }
        if (std::strcmp(n, "appearance") == 0) return true;
        if (srs_name_.empty()) {
            std::string srs = e.attribute("srsName");
            if (!srs.empty()) srs_name_ = std::move(srs);
        }
        // (std::hash of a string_view equals that of the std::string the read pass hashes.)
        std::string scratch;
        if (const std::string_view id = e.attributeView("id", kGmlNamespace, &scratch); !id.empty()) {
            const uint64_t hash = std::hash<std::string_view>{}(id);
            member_ids_.push_back(hash);
            if (isGeometryElement(n)) (void)id_owner_.push({hash, scan.member});  // a failure comes back when sorted
        }
        const std::string_view href = e.attributeView("href", kXlinkNamespace, &scratch);
        if (!href.empty()) member_hrefs_.push_back(std::hash<std::string_view>{}(href[0] == '#' ? href.substr(1) : href));
        return !first_point_ && (std::strcmp(n, "posList") == 0 || std::strcmp(n, "pos") == 0);
    }

    // A city object's references to its own ids resolve inside it (the read
    // pass looks there first): only the others are kept for the cross-object
    // match. A solid's xlinks to its own surfaces are most of a LOD2 file's
    // references: keeping them all took 0.5 GB at a million buildings.
    void flushMemberRefs(uint32_t member) {
        std::sort(member_ids_.begin(), member_ids_.end());
        for (const uint64_t h : member_hrefs_)
            if (!std::binary_search(member_ids_.begin(), member_ids_.end(), h)) href_user_.emplace_back(h, member);
        member_ids_.clear();
        member_hrefs_.clear();
    }

    // True: the handler keeps `n` (a global surface data's header, freed with it).
    bool indexCaptured(xmlNodePtr n, int depth, int dimension) {
        if (global_.open) return globalCaptured(n, depth);
        if (depth == 1 && isNamed(n, "boundedBy")) {
            readEnvelope(n, dimension);
        } else if (isNamed(n, "appearance")) {
            theme_catalogue_.note(firstChild(n) ? firstChild(n) : n);
            if (xmlNodePtr a = firstChild(n)) prefetchImages(a);
        } else {  // the first posList or pos
            std::vector<double> v;
            const std::string t = text(n);
            if (parseDoubles(t.data(), t.data() + t.size(), &v) && v.size() >= 2)
                first_point_ = Vec3d{v[0], v[1], v.size() >= 3 && dimension != 2 ? v[2] : 0.0};
        }
        return false;
    }

    // --- Global appearances, a piece at a time.
    // A global appearanceMember can hold a city's texture coordinates (a
    // shared texture's targets on every roof, or a 3DCityDB export's
    // appearances): as one DOM it took ~450 bytes a building. The scan
    // captures its pieces instead: the theme, each surface data's header
    // children (imageURI, wrapMode, colours; kept in a "shell" element) and
    // each of its targets alone, handed to the store inside a small
    // Appearance > surfaceDataMember > shell wrapper. The store gets the same
    // calls a whole DOM would give it, target by target, as the schema
    // orders them (header before targets; a header element after a target
    // is warned, as it applies to the later targets only).
    struct GlobalAppearance {
        bool open = false;             // inside a depth-1 appearanceMember
        xmlDocPtr doc = nullptr;       // the scan's, for the wrapper and the shell
        bool appearance = false;       // inside its Appearance
        std::string theme;             // its app:theme (the first), "" without
        bool theme_seen = false, noted = false;
        xmlNodePtr shell = nullptr;    // the surface data being streamed, header children only
        bool streams_targets = false;  // a kind whose targets are independent (PT, GeoreferencedTexture, X3DMaterial)
        bool data_noted = false;       // catalogue and prefetch have seen this surface data
        uint64_t targets = 0;          // streamed so far
    };
    GlobalAppearance global_;

    bool globalElement(const ScanElement& e) {
        const char* n = e.local_name;
        global_.doc = e.doc;
        if (e.depth == 2) {  // the Appearance
            finishGlobalAppearance();
            global_.appearance = true;
            return false;
        }
        if (e.depth == 3) {
            finishGlobalData();
            if (std::strcmp(n, "theme") == 0) return !global_.theme_seen;
            // A member by reference (xlink:href, no content) is small: whole.
            std::string scratch;
            return std::strcmp(n, "surfaceDataMember") == 0 && !e.attributeView("href", kXlinkNamespace, &scratch).empty();
        }
        if (e.depth == 4) {  // the surface data: its shell now, its children one at a time
            finishGlobalData();
            xmlNodePtr shell = xmlNewDocNode(e.doc, nullptr, reinterpret_cast<const xmlChar*>(n), nullptr);
            std::string scratch;
            if (const std::string_view id = e.attributeView("id", kGmlNamespace, &scratch); !id.empty()) {
                const std::string value(id);
                xmlNsPtr gml = xmlNewNs(shell, reinterpret_cast<const xmlChar*>(kGmlNamespace),
                                        reinterpret_cast<const xmlChar*>("gml"));
                xmlNewNsProp(shell, gml, reinterpret_cast<const xmlChar*>("id"), reinterpret_cast<const xmlChar*>(value.c_str()));
            }
            shell->line = static_cast<unsigned short>(std::min<int64_t>(e.line, 65535));  // as libxml2 keeps element lines
            global_.shell = shell;
            global_.streams_targets = std::strcmp(n, "ParameterizedTexture") == 0 ||
                                      std::strcmp(n, "GeoreferencedTexture") == 0 || std::strcmp(n, "X3DMaterial") == 0;
            return false;
        }
        return e.depth == 5 && global_.shell;
    }

    bool globalCaptured(xmlNodePtr n, int depth) {
        if (depth == 3 && isNamed(n, "theme")) {
            global_.theme = text(n);
            global_.theme_seen = true;
            return false;
        }
        if (depth == 3) {  // a surfaceDataMember by reference
            giveGlobal(n);
            return false;
        }
        GlobalAppearance& g = global_;
        const bool target = isNamed(n, "target");
        // A texture's targets wait for its imageURI (the store reads it from the shell).
        const bool ready = isNamed(g.shell, "X3DMaterial") || child(g.shell, "imageURI");
        if (target && g.streams_targets && ready) {
            xmlAddChild(g.shell, n);
            giveGlobal(g.shell);
            xmlUnlinkNode(n);
            ++g.targets;
            return false;
        }
        if (!target && g.targets > 0)
            warn(warn::kAppearanceUnsupported, lineOf(n), gmlId(g.shell),
                 fmt::format("app:{} after the targets of app:{}: applies to the targets after it only", localName(n),
                             localName(g.shell)));
        xmlAddChild(g.shell, n);  // header (or a target waiting for it): given with the shell at its end
        return true;
    }

    // An Appearance with this appearance's theme, in the scan's document.
    xmlNodePtr newGlobalAppearance() const {
        xmlNodePtr appearance = xmlNewDocNode(global_.doc, nullptr, reinterpret_cast<const xmlChar*>("Appearance"), nullptr);
        if (global_.theme_seen)
            xmlNewTextChild(appearance, nullptr, reinterpret_cast<const xmlChar*>("theme"),
                            reinterpret_cast<const xmlChar*>(global_.theme.c_str()));
        return appearance;
    }

    // The store, the theme catalogue and the prefetch get `data` (a
    // surfaceDataMember, or a surface data shell) inside an Appearance with
    // this appearance's theme.
    void giveGlobal(xmlNodePtr data) {
        GlobalAppearance& g = global_;
        xmlNodePtr appearance = newGlobalAppearance();
        xmlNodePtr member = data;
        if (!isNamed(data, "surfaceDataMember")) {
            member = xmlNewDocNode(g.doc, nullptr, reinterpret_cast<const xmlChar*>("surfaceDataMember"), nullptr);
            xmlAddChild(member, data);
        }
        xmlAddChild(appearance, member);
        // Once per surface data (its kind and image do not change from target to target).
        if (member == data || !g.data_noted) {
            theme_catalogue_.note(appearance);
            prefetchImages(appearance);
            g.data_noted = member != data;  // a member by reference is one call of its own
            g.noted = true;
        }
        global_appearances_.addAppearance(appearance);
        warnUnsupported(global_appearances_);
        xmlUnlinkNode(data);  // the caller's
        xmlFreeNode(appearance);
    }

    // The surface data ends: its shell goes to the store once more when it
    // gave none of its targets yet or holds some that waited.
    void finishGlobalData() {
        GlobalAppearance& g = global_;
        if (!g.shell) return;
        bool waiting = false;
        for (xmlNodePtr c = firstChild(g.shell); c && !waiting; c = nextSibling(c)) waiting = isNamed(c, "target");
        if (g.targets == 0 || waiting) giveGlobal(g.shell);
        xmlFreeNode(g.shell);
        g.shell = nullptr;
        g.streams_targets = g.data_noted = false;
        g.targets = 0;
    }

    void finishGlobalAppearance() {
        finishGlobalData();
        GlobalAppearance& g = global_;
        if (g.appearance && !g.noted) {  // an appearance with no surface data still names its theme
            xmlNodePtr appearance = newGlobalAppearance();
            theme_catalogue_.note(appearance);
            xmlFreeNode(appearance);
        }
        g.theme.clear();
        g.appearance = g.theme_seen = g.noted = false;
    }

    // The appearanceMember ends (the next root child, or the end of the scan).
    void finishGlobalMember() {
        if (!global_.open) return;
        finishGlobalAppearance();
        global_ = GlobalAppearance{};
    }

    Status indexPass() {
        summary_.path = file_.string();
        IndexScan scan(*this);
        if (Status s = scanXml(file_, scan, &summary_.bytes); !s.ok()) return s;
        if (scan.current != RootChild::Other) flushMemberRefs(scan.member);
        if (state_.progress) state_.progress("index", summary_.bytes, summary_.bytes);

        // One walk over the ids in order: a reference whose target's first
        // owner (the smallest member holding that id) is another city object,
        // and an id that two city objects hold.
        std::sort(href_user_.begin(), href_user_.end());
        size_t h = 0;
        std::optional<IdOwner> previous;
        const Status sorted = id_owner_.forEachSorted([&](const IdOwner& e) {
            if (previous && previous->hash == e.hash) {
                if (previous->member != e.member) duplicate_across_members_.insert(e.hash);
            } else {
                while (h < href_user_.size() && href_user_[h].first < e.hash) ++h;
                for (; h < href_user_.size() && href_user_[h].first == e.hash; ++h)
                    if (href_user_[h].second != e.member) foreign_needed_.insert(e.hash);
            }
            previous = e;
        });
        std::deque<std::pair<uint64_t, uint32_t>>().swap(href_user_);  // the read pass holds the two sets above
        if (!sorted.ok()) return sorted;
        return Status::Ok();
    }
    std::unordered_set<uint64_t> duplicate_across_members_;

    Status setUpFrame() {
        if (srs_name_.empty()) srs_name_ = state_.options.fallback_crs;
        if (srs_name_.empty())
            return Status::Invalid(fmt::format("{}: {}: no srsName on the envelope or any geometry; give --crs",
                                            fatal::kCrsMissing, file_.string()));
        if (Status s = parseSrsName(srs_name_, &crs_); !s.ok())
            return Status::Invalid(fmt::format("{}: {}: {}", fatal::kCrsUnknown, file_.string(), s.error));
        summary_.srs_name = srs_name_;
        summary_.crs = crs_.name;
        if (!crs_.vertical_ignored.empty())
            warn(warn::kCrsVerticalIgnored, 0, "",
                 fmt::format("{} in \"{}\" is not a vertical CRS PROJ knows; heights are used as written with {}",
                             crs_.vertical_ignored, srs_name_, crs_.name));
        if (crs_.kind == SourceCrs::Kind::LocalEngineering)
            warn(warn::kCrsNotGeoreferenced, 0, "", fmt::format("{}: coordinates used as local metres", srs_name_));

        // Geographic files follow the CRS's axis order (lat, lon) as GML
        // says; a file that obviously has longitudes first is taken as it is.
        if (crs_.kind == SourceCrs::Kind::Geographic) {
            const Vec3d probe = summary_.has_envelope ? summary_.envelope_min : first_point_.value_or(Vec3d{});
            lat_lon_order_ = !(std::abs(probe.x) > 90 && std::abs(probe.y) <= 90);
        }
        if (!state_.frame) {
            Vec3d origin;
            if (summary_.has_envelope) {
                origin = 0.5 * (summary_.envelope_min + summary_.envelope_max);
            } else if (first_point_) {
                origin = *first_point_;
            }
            origin = axisOrder(origin);
            if (crs_.kind != SourceCrs::Kind::Geographic) {
                // Whole metres keep the origin readable; precision lives in the local doubles.
                origin = {std::round(origin.x), std::round(origin.y), std::round(origin.z)};
            }
            if (Status s = LocalFrame::create(crs_, origin, &state_.frame); !s.ok())
                return Status::Invalid(fmt::format("{}: {}: {}", fatal::kCrsUnknown, file_.string(), s.error));
            Georeference g;
            g.source_crs = crs_.definition.empty() ? crs_.declared : crs_.definition;
            g.origin_source = origin;
            state_.sink->setGeoreference(g);
        }
        if (Status s = state_.frame->mapperFor(crs_, &mapper_); !s.ok())
            return Status::Invalid(fmt::format("{}: {}: {}", fatal::kCrsUnknown, file_.string(), s.error));
        return Status::Ok();
    }

    Vec3d axisOrder(const Vec3d& p) const { return lat_lon_order_ ? Vec3d{p.y, p.x, p.z} : p; }

    Status chooseTheme() {
        for (const std::string& t : theme_catalogue_.order)
            if (std::find(state_.counts.themes.begin(), state_.counts.themes.end(), t) == state_.counts.themes.end())
                state_.counts.themes.push_back(t);
        if (!state_.options.theme.empty()) {
            theme_ = state_.options.theme;
            if (!theme_catalogue_.order.empty() && !theme_catalogue_.textured.count(theme_)) {
                std::string all;
                for (const auto& t : theme_catalogue_.order) all += (all.empty() ? "" : ", ") + ("\"" + t + "\"");
                return Status::Invalid(fmt::format("{}: {}: theme \"{}\" not found; the file has {}", fatal::kThemeUnknown,
                                                file_.string(), theme_, all));
            }
        } else {
            for (const std::string& t : theme_catalogue_.order)
                if (theme_catalogue_.textured[t]) {
                    theme_ = t;
                    break;
                }
            if (theme_.empty() && !theme_catalogue_.order.empty()) theme_ = theme_catalogue_.order.front();
        }
        if (state_.counts.theme_used.empty()) state_.counts.theme_used = theme_;
        return Status::Ok();
    }

    // ---- pass 1b: geometry referenced from other city objects -----------------

    Status foreignPass() {
        XmlInput in;
        if (Status s = openRoot(in, false); !s.ok()) return s;
        while (in.nextChild()) {
            if (classify(in.currentLocalName()) == RootChild::Other) continue;
            xmlNodePtr n = in.expand();
            if (!n) break;
            ids_.clear();
            indexIds(n, false);
            for (const auto& [id, node] : ids_) {
                if (!foreign_needed_.count(std::hash<std::string_view>{}(id))) continue;
                std::vector<RawPolygon> polys;
                resolveTarget(node, SurfaceSemantic::Unclassified, false, "", polys, 0);
                foreign_geometry_[std::string(id)] = std::move(polys);
            }
            progress("xlinks", in);
        }
        ids_.clear();
        return in.status();
    }

    // ---- pass 2 -----------------------------------------------------------------

    void indexIds(xmlNodePtr node, bool report_duplicates) {
        for (xmlNodePtr c = firstChild(node); c; c = nextSibling(c)) {
            const std::string_view id = gmlIdView(c);
            if (!id.empty()) {
                auto [it, inserted] = ids_.emplace(id, c);
                if (!inserted && report_duplicates)
                    warn(warn::kDuplicateGmlId, lineOf(c), std::string(id), "gml:id used twice in one city object; first kept");
                else if (inserted && report_duplicates && isGeometryElement(localName(c)) &&
                         duplicate_across_members_.count(std::hash<std::string_view>{}(id)))
                    warn(warn::kDuplicateGmlId, lineOf(c), std::string(id), "gml:id also used in another city object");
            }
            indexIds(c, report_duplicates);
        }
    }

    void collectAppearances(xmlNodePtr node) {
        for (xmlNodePtr c = firstChild(node); c; c = nextSibling(c)) {
            if (isNamed(c, "appearance")) {
                if (xmlNodePtr a = firstChild(c)) local_appearances_.addAppearance(a);
                continue;
            }
            collectAppearances(c);
        }
    }

    // One city object at a time: the scan (this thread) parses a member into
    // a DOM while a worker thread reads the one before (geometry, appearances,
    // triangulation, the sink). The one worker takes the members in file
    // order, so everything it does happens in the order one thread would do
    // it. At most kMembersInFlight DOMs exist at a time; the scan frees them
    // (they hold its dictionary's names).
    static constexpr size_t kMembersInFlight = 16;
    struct ReadScan : ScanHandler {
        struct Member {
            xmlNodePtr node;
            RootChild kind;
            int dimension_above;
        };
        FileReader& r;
        std::mutex mutex;
        std::condition_variable work_ready, space_ready;
        std::deque<Member> work;
        std::vector<xmlNodePtr> done;  // read by the worker, for the scan to free
        size_t in_flight = 0;
        bool closed = false;
        std::exception_ptr error;      // what the worker threw; it then skips the rest
        std::thread worker;

        explicit ReadScan(FileReader& reader) : r(reader), worker([this] { run(); }) {}
        ~ReadScan() override { endOfScan(); }

        Status root(const ScanElement& e) override { return r.checkRoot(e.local_name, e.ns, false); }
        bool element(const ScanElement& e) override { return e.depth == 1 && classify(e.local_name) != RootChild::Other; }
        bool captured(xmlNodePtr n, int, int dimension, int64_t) override {
            std::vector<xmlNodePtr> to_free;
            {
                std::unique_lock lock(mutex);
                space_ready.wait(lock, [&] { return in_flight < kMembersInFlight; });
                to_free.swap(done);
                work.push_back({n, classify(localName(n)), dimension});
                ++in_flight;
            }
            work_ready.notify_one();
            for (xmlNodePtr f : to_free) xmlFreeNode(f);
            return true;
        }
        void progress(uint64_t done_bytes) override {
            if (r.state_.progress) r.state_.progress("read", done_bytes, r.summary_.bytes);
        }
        // Waits for the worker to read what is queued, then frees it all.
        void endOfScan() override {
            {
                std::lock_guard lock(mutex);
                closed = true;
            }
            work_ready.notify_one();
            if (worker.joinable()) worker.join();
            for (xmlNodePtr f : done) xmlFreeNode(f);
            done.clear();
        }
        void run() {
            for (;;) {
                Member m;
                {
                    std::unique_lock lock(mutex);
                    work_ready.wait(lock, [&] { return closed || !work.empty(); });
                    if (work.empty()) return;
                    m = work.front();
                    work.pop_front();
                }
                if (!error) {
                    try {
                        r.readMember(m.node, m.kind, m.dimension_above);
                    } catch (...) {
                        error = std::current_exception();
                    }
                }
                {
                    std::lock_guard lock(mutex);
                    done.push_back(m.node);
                    --in_flight;
                }
                space_ready.notify_one();
            }
        }
    };

    Status readPass() {
        uint64_t bytes = 0;
        Status s;
        std::exception_ptr error;
        {
            ReadScan scan(*this);
            s = scanXml(file_, scan, &bytes);
            scan.endOfScan();
            error = scan.error;
        }
        if (error) std::rethrow_exception(error);
        if (!s.ok()) return s;
        if (state_.progress) state_.progress("read", summary_.bytes, summary_.bytes);
        state_.counts.textures_ok += textures_.resolved();
        state_.counts.textures_failed += textures_.failed();
        state_.files.push_back(summary_);
        return Status::Ok();
    }

    // One root child that holds a city object (worker thread, in file order).
    void readMember(xmlNodePtr member, RootChild kind, int dimension_above) {
        member_dimension_ = dimension_above;
        xmlNodePtr object = objectOf(member, kind);
        if (!object) return;
        if (isNamed(object, "Building")) {
            ids_.clear();
            emitted_ids_.clear();
            indexIds(member, true);
            local_appearances_ = AppearanceStore();
            collectAppearances(member);
            warnUnsupported(local_appearances_);
            state_.counts.objects_read["Building"]++;
            summary_.buildings++;
            const bool any = readFeature(object, -1);
            if (!any) {
                state_.counts.features_without_geometry++;
                warn(warn::kNoLodGeometry, lineOf(object), gmlId(object),
                     state_.options.lod ? fmt::format("no LOD{} geometry", state_.options.lod)
                                        : "no LOD1 or LOD2 geometry (LOD0/3/4 only, or none)");
            }
        } else {
            state_.counts.objects_skipped[localName(object)]++;
        }
    }

    // Attributes of a Building / BuildingPart.
    Feature makeFeature(xmlNodePtr b, int32_t parent) {
        Feature f;
        f.gml_id = gmlId(b);
        f.source_file = file_.string();
        f.parent = parent;
        for (xmlNodePtr c = firstChild(b); c; c = nextSibling(c)) {
            const char* n = localName(c);
            if (std::strcmp(n, "name") == 0 && f.name.empty()) f.name = text(c);
            else if (std::strcmp(n, "measuredHeight") == 0) {
                const std::string t = text(c);
                double v = 0;
                if (std::from_chars(t.data(), t.data() + t.size(), v).ec == std::errc() && std::isfinite(v))
                    f.measured_height_m = v;
            } else if (std::strcmp(n, "roofType") == 0) f.roof_type = text(c);
            else if (std::strcmp(n, "function") == 0) f.function = text(c);
            else if (isGenericAttribute(c)) {  // gen:stringAttribute, intAttribute, ... (2.0 and 1.0)
                readGenericAttribute(c, "", &f.attributes);
            } else if (std::strcmp(n, "genericAttribute") == 0) {  // CityGML 3.0
                if (xmlNodePtr a = firstChild(c)) {
                    xmlNodePtr k = child(a, "name"), v = child(a, "value");
                    if (k && v) f.attributes[text(k)] = text(v);
                }
            }
        }
        return f;
    }

    // CityGML 1.0/2.0 generic attributes (gen:stringAttribute ... and sets);
    // not an ADE's element that merely has "Attribute" in its name.
    static bool isGenericAttribute(xmlNodePtr c) {
        static const char* names[] = {"stringAttribute", "intAttribute",     "doubleAttribute",    "dateAttribute",
                                      "uriAttribute",    "measureAttribute", "genericAttributeSet"};
        if (!isKnownNamespace(c)) return false;
        for (const char* g : names)
            if (std::strcmp(localName(c), g) == 0) return true;
        return false;
    }
    // A set's members are keyed "set.member".
    static void readGenericAttribute(xmlNodePtr c, const std::string& prefix, std::map<std::string, std::string>* out) {
        const std::string key = prefix + attribute(c, "name");
        if (attribute(c, "name").empty()) return;
        if (std::strcmp(localName(c), "genericAttributeSet") == 0) {
            for (xmlNodePtr m = firstChild(c); m; m = nextSibling(m))
                if (isGenericAttribute(m)) readGenericAttribute(m, key + ".", out);
            return;
        }
        if (xmlNodePtr v = child(c, "value")) (*out)[key] = text(v);
    }

    // Reads a Building or BuildingPart; returns whether it or a part had geometry.
    bool readFeature(xmlNodePtr b, int32_t parent) {
        const uint32_t feature = state_.sink->addFeature(makeFeature(b, parent));
        std::vector<RawPolygon> thematic[3], plain[3];
        bool any = false;
        for (xmlNodePtr c = firstChild(b); c; c = nextSibling(c)) {
            const char* n = localName(c);
            if (std::strcmp(n, "lod1Solid") == 0 || std::strcmp(n, "lod1MultiSurface") == 0) {
                collectGeometry(c, SurfaceSemantic::Unclassified, false, "", plain[1]);
            } else if (std::strcmp(n, "lod2Solid") == 0 || std::strcmp(n, "lod2MultiSurface") == 0) {
                collectGeometry(c, SurfaceSemantic::Unclassified, false, "", plain[2]);
            } else if (std::strcmp(n, "boundedBy") == 0 || std::strcmp(n, "boundary") == 0) {
                readThematic(firstChild(c), std::nullopt, thematic);
            } else if (std::strcmp(n, "outerBuildingInstallation") == 0 || std::strcmp(n, "buildingInstallation") == 0) {
                if (xmlNodePtr inst = firstChild(c)) readInstallation(inst, thematic);
            } else if (std::strcmp(n, "consistsOfBuildingPart") == 0 || std::strcmp(n, "buildingPart") == 0) {
                if (xmlNodePtr part = firstChild(c); part && isNamed(part, "BuildingPart")) {
                    state_.counts.objects_read["BuildingPart"]++;
                    any |= readFeature(part, static_cast<int32_t>(feature));
                }
            } else if (startsWith(n, "lod0") || startsWith(n, "lod3") || startsWith(n, "lod4") ||
                       std::strstr(n, "TerrainIntersection") || std::strstr(n, "MultiCurve") ||
                       std::strcmp(n, "interiorRoom") == 0 || std::strcmp(n, "interiorBuildingInstallation") == 0) {
                state_.counts.geometry_skipped[n]++;
            } else if (!isKnownNamespace(c)) {
                warnAde(c);
            }
        }
        int lod = state_.options.lod;
        auto has = [&](int l) { return !thematic[l].empty() || !plain[l].empty(); };
        if (lod == 0) lod = has(2) ? 2 : has(1) ? 1 : 0;
        if (lod == 0 || !has(lod)) return any;
        (lod == 2 ? state_.counts.features_lod2 : state_.counts.features_lod1)++;
        state_.sink->setFeatureLod(feature, static_cast<int8_t>(lod));

        // Thematic surfaces first; a solid that references the same polygons
        // (by xlink or by equal geometry) must not add them twice.
        std::vector<RawPolygon> polygons = std::move(thematic[lod]);
        std::unordered_set<std::string> seen_ids;
        std::unordered_set<uint64_t> seen_shapes;
        auto shapeKey = [](const RawPolygon& p) {
            uint64_t h = 1469598103934665603ull;
            for (const Vec3d& q : p.rings.front().points)
                for (double v : {q.x, q.y, q.z}) h = (h ^ std::hash<double>{}(v)) * 1099511628211ull;
            return h;
        };
        std::unordered_map<std::string, std::string> solid_of;  // polygon id -> solid, for thematic ones
        for (const RawPolygon& p : polygons) {
            if (!p.id.empty()) seen_ids.insert(p.id);
            if (!p.rings.empty()) seen_shapes.insert(shapeKey(p));
        }
        for (RawPolygon& p : plain[lod]) {
            const bool dup = (!p.id.empty() && seen_ids.count(p.id)) || (!p.rings.empty() && seen_shapes.count(shapeKey(p)));
            if (dup) {
                if (!p.solid.empty() && !p.id.empty()) solid_of[p.id] = p.solid;
                continue;
            }
            polygons.push_back(std::move(p));
        }
        for (RawPolygon& p : polygons)
            if (p.solid.empty() && !p.id.empty())
                if (auto it = solid_of.find(p.id); it != solid_of.end()) p.solid = it->second;
        // A polygon that another part of the same building already used (by
        // xlink, often reversed: the wall between a house and its garage)
        // is one face, emitted once.
        std::erase_if(polygons, [&](const RawPolygon& p) {
            if (p.id.empty()) return false;
            const bool repeat = !emitted_ids_.insert(p.id).second;
            state_.counts.polygons_shared += repeat;
            return repeat;
        });
        emitPolygons(polygons, feature);
        return true;
    }

    void readThematic(xmlNodePtr surface, std::optional<SurfaceSemantic> forced, std::vector<RawPolygon>* out) {
        if (!surface) return;
        const SurfaceSemantic sem = forced ? *forced : semanticOf(localName(surface));
        for (xmlNodePtr g = firstChild(surface); g; g = nextSibling(g)) {
            const char* n = localName(g);
            if (std::strcmp(n, "lod2MultiSurface") == 0) collectGeometry(g, sem, false, "", out[2]);
            else if (std::strcmp(n, "lod1MultiSurface") == 0) collectGeometry(g, sem, false, "", out[1]);
            else if (startsWith(n, "lod3") || startsWith(n, "lod4") || std::strcmp(n, "opening") == 0)
                state_.counts.geometry_skipped[n]++;
            else if (!isKnownNamespace(g))
                warnAde(g);
        }
    }

    void warnAde(xmlNodePtr n) {
        warn(warn::kAdeIgnored, lineOf(n), gmlId(n->parent),
             fmt::format("<{}{}{}> in namespace {} (an ADE) is not read", n->ns->prefix ? reinterpret_cast<const char*>(n->ns->prefix) : "",
                         n->ns->prefix ? ":" : "", localName(n), reinterpret_cast<const char*>(n->ns->href)));
    }

    void readInstallation(xmlNodePtr inst, std::vector<RawPolygon>* out) {
        for (xmlNodePtr g = firstChild(inst); g; g = nextSibling(g)) {
            const char* n = localName(g);
            if (std::strcmp(n, "lod2Geometry") == 0 || std::strcmp(n, "lod2MultiSurface") == 0)
                collectGeometry(g, SurfaceSemantic::Installation, false, "", out[2]);
            else if (std::strcmp(n, "boundedBy") == 0 || std::strcmp(n, "boundary") == 0)
                readThematic(firstChild(g), SurfaceSemantic::Installation, out);
            else if (startsWith(n, "lod3") || startsWith(n, "lod4"))
                state_.counts.geometry_skipped[n]++;
        }
    }

    // ---- geometry ---------------------------------------------------------------

    std::vector<double> coordinates_;  // readRing's, reused
    std::string text_;                 // textView's, reused

    bool readRing(xmlNodePtr ring, RawRing* out) {
        out->id = gmlId(ring);
        out->line = lineOf(ring);
        std::vector<double>& v = coordinates_;
        v.clear();
        int dim = 0;
        bool ok = true;
        for (xmlNodePtr c = firstChild(ring); c; c = nextSibling(c)) {
            const char* n = localName(c);
            if (std::strcmp(n, "posList") == 0 || std::strcmp(n, "coordinates") == 0) {
                std::string_view t = textView(c, &text_);
                if (std::strcmp(n, "coordinates") == 0) {
                    if (t.data() != text_.data()) text_.assign(t);
                    std::replace(text_.begin(), text_.end(), ',', ' ');
                    t = text_;
                }
                ok &= parseDoubles(t.data(), t.data() + t.size(), &v);
                dim = declaredDimension(c, member_dimension_);
            } else if (std::strcmp(n, "pos") == 0) {
                const std::string_view t = textView(c, &text_);
                const size_t before = v.size();
                ok &= parseDoubles(t.data(), t.data() + t.size(), &v);
                if (!dim) dim = declaredDimension(c, member_dimension_);
                if (!dim && v.size() - before == 2) dim = 2;
            }
        }
        if (!ok) {
            warn(warn::kCoordinateParse, out->line, out->id, "a coordinate is not a number; polygon skipped");
            return false;
        }
        if (!dim) dim = file_dimension_;
        if (!dim) dim = guessDimension(v);
        if (dim != 2 && dim != 3) dim = 3;
        if (v.size() % static_cast<size_t>(dim) != 0) {
            warn(warn::kCoordinateParse, out->line, out->id,
                 fmt::format("{} numbers do not make {}D points; polygon skipped", v.size(), dim));
            return false;
        }
        if (dim == 2) warn(warn::kCoordinates2d, out->line, out->id, "2D coordinates; z = 0");
        for (size_t i = 0; i + dim <= v.size(); i += dim) {
            const Vec3d p{v[i], v[i + 1], dim == 3 ? v[i + 2] : 0.0};
            if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
                warn(warn::kCoordinateNotFinite, out->line, out->id, "NaN or infinite coordinate; polygon skipped");
                return false;
            }
            out->points.push_back(p);
        }
        return true;
    }

    void readPolygonLike(xmlNodePtr poly, SurfaceSemantic sem, bool reversed, const std::string& solid,
                         std::vector<RawPolygon>& out) {
        RawPolygon p;
        p.id = gmlId(poly);
        p.surface_ids.assign(ancestors_.rbegin(), ancestors_.rend());
        p.reversed = reversed;
        p.semantic = sem;
        p.solid = solid;
        p.line = lineOf(poly);
        state_.counts.polygons_read++;
        for (xmlNodePtr c = firstChild(poly); c; c = nextSibling(c)) {
            const char* n = localName(c);
            const bool exterior = std::strcmp(n, "exterior") == 0 || std::strcmp(n, "outerBoundaryIs") == 0;
            const bool interior = std::strcmp(n, "interior") == 0 || std::strcmp(n, "innerBoundaryIs") == 0;
            if (!exterior && !interior) continue;
            xmlNodePtr ring = firstChild(c);
            if (!ring) continue;
            RawRing r;
            if (!readRing(ring, &r)) {
                state_.counts.polygons_skipped++;
                return;
            }
            if (exterior) p.rings.insert(p.rings.begin(), std::move(r));
            else p.rings.push_back(std::move(r));
        }
        if (p.rings.empty()) {
            state_.counts.polygons_skipped++;
            warn(warn::kRingTooFewPoints, p.line, p.id, "polygon without an exterior ring; skipped");
            return;
        }
        out.push_back(std::move(p));
    }

    // Enclosing geometry ids while collectGeometry descends, outermost first
    // (a stack, not a copy per level; empty between top-level calls).
    std::vector<std::string> ancestors_;

    void collectGeometry(xmlNodePtr node, SurfaceSemantic sem, bool reversed, const std::string& solid,
                         std::vector<RawPolygon>& out, int depth = 0) {
        if (depth > 64) return;  // a reference cycle; real geometry is never this deep
        const std::string href = xlinkHref(node);
        if (!href.empty() && !firstChild(node)) {
            auto it = ids_.find(href);
            if (it != ids_.end()) {
                state_.counts.xlinks_resolved++;
                resolveTarget(it->second, sem, reversed, solid, out, depth);
                return;
            }
            if (auto f = foreign_geometry_.find(href); f != foreign_geometry_.end()) {
                state_.counts.xlinks_resolved++;
                state_.counts.xlinks_cross_object++;
                for (RawPolygon p : f->second) {
                    p.semantic = sem;
                    p.reversed ^= reversed;
                    if (p.solid.empty()) p.solid = solid;
                    state_.counts.polygons_read++;
                    out.push_back(std::move(p));
                }
                return;
            }
            warn(warn::kXlinkUnresolved, lineOf(node), href, fmt::format("xlink:href=\"#{}\" names no geometry in this file", href));
            return;
        }
        for (xmlNodePtr c = firstChild(node); c; c = nextSibling(c))
            resolveTarget(c, sem, reversed, solid, out, depth + 1);
    }

    void resolveTarget(xmlNodePtr g, SurfaceSemantic sem, bool reversed, const std::string& solid,
                       std::vector<RawPolygon>& out, int depth) {
        const char* n = localName(g);
        if (std::strcmp(n, "Polygon") == 0 || std::strcmp(n, "Triangle") == 0 || std::strcmp(n, "PolygonPatch") == 0 ||
            std::strcmp(n, "Rectangle") == 0) {
            readPolygonLike(g, sem, reversed, solid, out);
            return;
        }
        const std::string id = gmlId(g);
        if (std::strcmp(n, "OrientableSurface") == 0 && attribute(g, "orientation") == "-") reversed = !reversed;
        if (std::strcmp(n, "Solid") == 0) {
            const std::string own = id.empty() ? fmt::format("solid@{}", lineOf(g)) : id;
            // Only the outer shell is visible; interior shells are voids.
            if (xmlNodePtr ext = child(g, "exterior")) collectGeometry(ext, sem, reversed, own, out, depth + 1);
            return;
        }
        if (std::strcmp(n, "interior") == 0 && g->parent && isNamed(g->parent, "Solid")) return;
        const bool enclosing = !id.empty() && isGeometryElement(n);
        if (enclosing) ancestors_.push_back(id);
        collectGeometry(g, sem, reversed, solid, out, depth + 1);
        if (enclosing) ancestors_.pop_back();
    }

    // ---- appearance lookup -------------------------------------------------------

    template <typename Map>
    const typename Map::mapped_type* lookup(Map ThemeData::*field, const std::string& key, const AppearanceStore** from) {
        for (const AppearanceStore* store : {&local_appearances_, &global_appearances_}) {
            auto t = store->themes.find(theme_);
            if (t == store->themes.end()) continue;
            auto it = (t->second.*field).find(key);
            if (it != (t->second.*field).end()) {
                *from = store;
                return &it->second;
            }
        }
        return nullptr;
    }

    int32_t sceneTexture(const AppearanceStore& store, uint32_t image, int64_t line, const std::string& polygon_id) {
        const TextureImage& img = store.images[image];
        // resolve() gives the same answer for the same image and wrap (it
        // warns the first time only); most polygons ask again for their
        // building's image, so the path work is done once per image.
        texture_key_.assign(img.uri);
        texture_key_ += '#';
        texture_key_ += std::to_string(static_cast<int>(img.wrap));
        if (auto it = texture_index_.find(texture_key_); it != texture_index_.end()) return it->second;
        const int32_t index = textures_.resolve(base_dir_, img.uri, img.wrap, {file_.string(), line, polygon_id, ""});
        // A cache, not a table: resolve() keeps every answer (and warns
        // once), so forgetting is exact, and a city's worth of uris would be
        // a second copy of its texture paths (~130 bytes a texture).
        if (texture_index_.size() >= kTextureCacheEntries) texture_index_.clear();
        texture_index_.emplace(texture_key_, index);
        return index;
    }
    static constexpr size_t kTextureCacheEntries = 4096;
    std::string texture_key_;
    std::unordered_map<std::string, int32_t> texture_index_;  // (uri#wrap) -> resolve()'s answer, recent ones

    // A GeoreferencedTexture as a texture-generation matrix: the inverse of
    // its pixel-to-world map, scaled to the image's size, applied to a
    // vertex's ground position (source coordinates, easting first).
    std::optional<TexGen> georeferencedTexGen(const AppearanceStore& store, const GeoTexture& geo,
                                              const std::string& polygon_id) {
        const int32_t texture = sceneTexture(store, geo.image, geo.line, polygon_id);
        const std::optional<TextureRef> ref = textures_.info(texture);
        if (!ref || ref->width_px <= 0 || ref->height_px <= 0) return std::nullopt;  // texture_missing/unreadable
        std::array<double, 6> a = geo.pixel_to_world;
        if (!geo.has_georeference) {
            const std::string key = ref->path + (geo.prefer_world_file ? "#w" : "#i");
            auto it = image_georeference_.find(key);
            if (it == image_georeference_.end())
                it = image_georeference_.emplace(key, readImageGeoreference(ref->path, geo.prefer_world_file)).first;
            if (!it->second) {
                if (georeference_missing_warned_.insert(ref->path).second)
                    warn(warn::kGeoreferenceMissing, geo.line, polygon_id,
                         fmt::format("GeoreferencedTexture {}: no referencePoint and orientation, no world file (.{}w, "
                                     ".wld, ...) and no georeference in the image; a colour is used instead",
                                     ref->path, fs::path(ref->path).extension().string().substr(1)));
                return std::nullopt;
            }
            a = *it->second;
        }
        // (col, row) = A^-1 ((x, y) - (a2, a5)); s = (col + 1/2) / w; t = 1 - (row + 1/2) / h (t up).
        // The difference to the reference pixel is taken first (TexGen::offset):
        // applied to raw coordinates of 10^6 m the constant terms would cancel
        // to 1e-11 of the image.
        const double det = a[0] * a[4] - a[1] * a[3];
        const double i00 = a[4] / det, i01 = -a[1] / det, i10 = -a[3] / det, i11 = a[0] / det;
        const double w = ref->width_px, h = ref->height_px;
        double sx = i00 / w, sy = i01 / w, tx = -i10 / h, ty = -i11 / h;
        Vec3d offset{a[2], a[5], 0};
        if (lat_lon_order_) std::swap(sx, sy), std::swap(tx, ty), std::swap(offset.x, offset.y);  // file order: y first
        TexGen g;
        g.image = geo.image;
        g.offset = offset;
        g.world_to_texture = {sx, sy, 0, 0.5 / w, tx, ty, 0, 1.0 - 0.5 / h, 0, 0, 0, 1};
        return g;
    }
    std::unordered_map<std::string, std::optional<std::array<double, 6>>> image_georeference_;
    std::unordered_set<std::string> georeference_missing_warned_;

    // ---- cleanup, triangulation, output ---------------------------------------------

    struct CleanRing {
        std::vector<Vec3d> local;
        std::vector<Vec2d> uv;
    };

    // Source points -> local frame; closing point, consecutive duplicates
    // removed with their texture coordinates. False if fewer than 3 remain.
    bool cleanRing(const RawRing& ring, const std::vector<Vec2d>* uv, const std::string& polygon_id, CleanRing* out) {
        const auto& pts = ring.points;
        bool closed_as_written = pts.size() > 1 && pts.front() == pts.back();
        out->local.clear();
        out->uv.clear();
        for (size_t i = 0; i < pts.size(); ++i) {
            Vec3d q;
            if (!mapper_->toLocal(axisOrder(pts[i]), &q)) {
                warn(warn::kCoordinateNotFinite, ring.line, polygon_id, "a point PROJ cannot transform; polygon skipped");
                return false;
            }
            Vec3d src;
            mapper_->toFrameCrs(axisOrder(pts[i]), &src);
            state_.bounds_source.extend(src);
            out->local.push_back(q);
            if (uv) out->uv.push_back((*uv)[i]);
        }
        // Closure: the last point repeats the first (exactly, or within the tolerance).
        if (out->local.size() > 1 && length(out->local.back() - out->local.front()) <= kDuplicatePointTolerance_m) {
            out->local.pop_back();
            if (uv) out->uv.pop_back();
        } else if (!closed_as_written) {
            warn(warn::kRingUnclosed, ring.line, ring.id.empty() ? polygon_id : ring.id,
                 "ring does not end at its first point; closed implicitly");
        }
        size_t removed = 0;
        for (size_t i = 1; i < out->local.size();) {
            if (length(out->local[i] - out->local[i - 1]) <= kDuplicatePointTolerance_m) {
                out->local.erase(out->local.begin() + static_cast<long>(i));
                if (uv) out->uv.erase(out->uv.begin() + static_cast<long>(i));
                ++removed;
            } else {
                ++i;
            }
        }
        while (out->local.size() > 1 && length(out->local.back() - out->local.front()) <= kDuplicatePointTolerance_m) {
            out->local.pop_back();
            if (uv) out->uv.pop_back();
            ++removed;
        }
        if (removed)
            warn(warn::kRingDuplicatePoints, ring.line, ring.id.empty() ? polygon_id : ring.id,
                 fmt::format("{} repeated consecutive point(s) removed", removed));
        if (out->local.size() < 3) {
            warn(warn::kRingTooFewPoints, ring.line, ring.id.empty() ? polygon_id : ring.id,
                 fmt::format("{} distinct point(s); ring dropped", out->local.size()));
            return false;
        }
        return true;
    }

    void emitPolygons(std::vector<RawPolygon>& polygons, uint32_t feature) {
        std::vector<Triangle> tris;
        std::vector<uint32_t> tri_polygon;  // polygon of each triangle: its solid, for the orientation check
        for (size_t i = 0; i < polygons.size(); ++i) emitPolygon(polygons[i], feature, tris, tri_polygon, static_cast<uint32_t>(i));
        auto solidOf = [&](size_t triangle) -> const std::string& { return polygons[tri_polygon[triangle]].solid; };

        // A closed solid whose faces point inward has negative volume: flip it.
        std::unordered_map<std::string, double> volume;
        for (size_t i = 0; i < tris.size(); ++i) {
            if (solidOf(i).empty()) continue;
            const auto& q = tris[i].position_local;
            volume[solidOf(i)] += dot(q[0], cross(q[1], q[2])) / 6.0;
        }
        for (const auto& [solid, v] : volume) {
            if (v >= 0) continue;
            warn(warn::kSolidInverted, 0, solid, fmt::format("faces point inward (volume {:.3f} m3); flipped", v));
            for (size_t i = 0; i < tris.size(); ++i)
                if (solidOf(i) == solid) {
                    std::swap(tris[i].position_local[1], tris[i].position_local[2]);
                    std::swap(tris[i].uv[1], tris[i].uv[2]);
                }
        }
        state_.sink->addTriangles(tris);
    }

    void emitPolygon(const RawPolygon& p, uint32_t feature, std::vector<Triangle>& tris, std::vector<uint32_t>& tri_polygon,
                     uint32_t polygon) {
        const std::string& pid = p.id.empty() ? (p.surface_ids.empty() ? std::string() : p.surface_ids.front()) : p.id;
        // Appearance: texture coordinates per ring, or a generation matrix on
        // the polygon or an enclosing surface; a material the same way.
        const AppearanceStore* tex_store = nullptr;
        int32_t texture = -1;
        std::vector<std::vector<Vec2d>> ring_uv;
        bool textured = false;
        if (!theme_.empty() || !global_appearances_.themes.empty() || !local_appearances_.themes.empty()) {
            const RingTexcoords* rt = p.rings.front().id.empty()
                                          ? nullptr
                                          : lookup(&ThemeData::ring_texcoords, p.rings.front().id, &tex_store);
            if (rt) {
                bool ok = true;
                for (const RawRing& r : p.rings) {
                    const AppearanceStore* s2 = nullptr;
                    const RingTexcoords* t = r.id.empty() ? nullptr : lookup(&ThemeData::ring_texcoords, r.id, &s2);
                    if (!t || t->uv.size() < r.points.size() || t->uv.size() > r.points.size() + 1) {
                        ok = false;
                        warn(warn::kTexcoordsMismatch, r.line, r.id.empty() ? pid : r.id,
                             fmt::format("{} texture coordinates for {} points; texture dropped", t ? t->uv.size() : 0,
                                         r.points.size()));
                        break;
                    }
                    std::vector<Vec2d> uv(t->uv.begin(), t->uv.begin() + static_cast<long>(r.points.size()));
                    ring_uv.push_back(std::move(uv));
                }
                if (ok) {
                    texture = sceneTexture(*tex_store, rt->image, p.line, pid);
                    textured = texture >= 0;
                }
            } else {
                std::vector<std::string> ids;
                if (!p.id.empty()) ids.push_back(p.id);
                ids.insert(ids.end(), p.surface_ids.begin(), p.surface_ids.end());
                for (const std::string& id : ids) {
                    const TexGen* g = lookup(&ThemeData::texgen, id, &tex_store);
                    std::optional<TexGen> from_georeference;
                    if (!g)
                        if (const GeoTexture* geo = lookup(&ThemeData::georeferenced, id, &tex_store)) {
                            from_georeference = georeferencedTexGen(*tex_store, *geo, pid);
                            if (!from_georeference) break;  // warned; a colour instead
                            g = &*from_georeference;
                        }
                    if (!g) continue;
                    const auto& m = g->world_to_texture;
                    for (const RawRing& r : p.rings) {
                        std::vector<Vec2d> uv;
                        for (const Vec3d& source : r.points) {
                            const Vec3d q = source - g->offset;
                            const double s = m[0] * q.x + m[1] * q.y + m[2] * q.z + m[3];
                            const double t = m[4] * q.x + m[5] * q.y + m[6] * q.z + m[7];
                            const double w = m[8] * q.x + m[9] * q.y + m[10] * q.z + m[11];
                            uv.push_back(w != 0 ? Vec2d{s / w, t / w} : Vec2d{});
                        }
                        ring_uv.push_back(std::move(uv));
                    }
                    texture = sceneTexture(*tex_store, g->image, p.line, pid);
                    textured = texture >= 0;
                    break;
                }
            }
        }
        int32_t material = -1;
        if (!textured) {
            ring_uv.clear();
            std::vector<std::string> ids;
            if (!p.id.empty()) ids.push_back(p.id);
            ids.insert(ids.end(), p.surface_ids.begin(), p.surface_ids.end());
            const AppearanceStore* from = nullptr;
            for (const std::string& id : ids)
                if (const Material* m = lookup(&ThemeData::materials, id, &from)) {
                    material = state_.sink->addMaterial(*m);
                    break;
                }
            if (material < 0 && texture < 0 && tex_store) material = state_.sink->addMaterial(Material{});  // failed texture
        }

        // Clean every ring; a bad exterior drops the polygon, a bad hole only the hole.
        std::vector<CleanRing> rings;
        for (size_t r = 0; r < p.rings.size(); ++r) {
            CleanRing c;
            if (!cleanRing(p.rings[r], textured ? &ring_uv[r] : nullptr, pid, &c)) {
                if (r == 0) {
                    state_.counts.polygons_skipped++;
                    return;
                }
                continue;
            }
            rings.push_back(std::move(c));
        }
        PolygonRings input;
        for (const CleanRing& c : rings) {
            input.rings.emplace_back(c.local);
            if (textured) input.uv.emplace_back(c.uv);
        }
        const PolygonTriangulation t = triangulatePolygon(input);
        if (t.degenerate) {
            state_.counts.polygons_skipped++;
            warn(warn::kPolygonDegenerate, p.line, pid, "zero area or collinear; skipped");
            return;
        }
        if (t.max_plane_deviation_m > kNonPlanarTolerance_m)
            warn(warn::kPolygonNonPlanar, p.line, pid,
                 fmt::format("{:.3f} m off its best-fit plane; triangulated", t.max_plane_deviation_m));
        state_.counts.max_plane_deviation_m = std::max(state_.counts.max_plane_deviation_m, t.max_plane_deviation_m);
        if (!t.added_points.empty())
            warn(warn::kRingSelfIntersection, p.line, pid,
                 fmt::format("rings cross; {} point(s) added to triangulate", t.added_points.size()));
        if (t.repeated_vertices)
            warn(warn::kRingSelfTouching, p.line, pid, fmt::format("{} vertex(es) repeated", t.repeated_vertices));
        state_.counts.polygons_triangulated++;
        (textured ? state_.counts.polygons_textured : state_.counts.polygons_coloured)++;

        SurfaceSemantic sem = p.semantic;
        Vec3d n = t.unit_normal;
        if (p.reversed) n = -1.0 * n;
        if (sem == SurfaceSemantic::Unclassified) {
            // LOD1 solids and bare LOD2 solids: the kind the geometry implies.
            sem = n.z > 0.5 ? SurfaceSemantic::Roof : n.z < -0.5 ? SurfaceSemantic::Ground : SurfaceSemantic::Wall;
            state_.counts.polygons_semantic_inferred++;
        }
        std::vector<Vec3d> all_pos;
        std::vector<Vec2d> all_uv;
        for (const CleanRing& c : rings) {
            all_pos.insert(all_pos.end(), c.local.begin(), c.local.end());
            all_uv.insert(all_uv.end(), c.uv.begin(), c.uv.end());
        }
        all_pos.insert(all_pos.end(), t.added_points.begin(), t.added_points.end());
        if (textured) all_uv.insert(all_uv.end(), t.added_uv.begin(), t.added_uv.end());
        for (const auto& idx : t.triangles) {
            Triangle tri;
            for (int k = 0; k < 3; ++k) {
                const int kk = p.reversed ? (3 - k) % 3 : k;  // reversed: 0, 2, 1
                tri.position_local[k] = all_pos[idx[kk]];
                if (textured) tri.uv[k] = all_uv[idx[kk]];
            }
            tri.texture = textured ? texture : -1;
            tri.material = textured ? -1 : material;
            tri.feature = feature;
            tri.semantic = sem;
            tris.push_back(tri);
            tri_polygon.push_back(polygon);
        }
    }
};

}  // namespace

Status readCityGml(const fs::path& file, IngestState& state) {
    FileReader reader(file, state);
    return reader.run();
}

}  // namespace cityatlas
