// SPDX-License-Identifier: GPL-3.0-or-later
/// citygml_oracle — an independent reference reader for tests.
///
/// Loads a CityGML file with libcitygml (not cityatlas's own reader) and
/// prints, per top-level bldg:Building, the total triangle area, the number of
/// non-degenerate triangles and the number of distinct polygons, as JSON on
/// stdout. A building's figures include its BuildingParts, boundary surfaces,
/// openings and installations (every child city object). Areas are computed
/// here, in double, from the vertices and indices libcitygml returns after its
/// GLU tessellation; zero-area triangles (GLU keeps each ring's closing vertex,
/// which gives most polygons one degenerate triangle) are counted in
/// "degenerate_triangles", never in "triangles".
///
/// Usage: citygml_oracle FILE.gml [--lod N] [--dest-srs SRS] [--src-srs SRS]
///                              [--verbose] [--allow-doctype]
///   --lod N       count only LOD N: sets ParserParams minLOD = maxLOD = N and,
///                 because libcitygml 2.4.3 ignores those two fields, also
///                 drops geometries whose getLOD() != N here;
///                 default: libcitygml's defaults (every LOD, all counted)
///   --dest-srs S  let libcitygml reproject (ParserParams.destSRS, through
///                 GDAL/PROJ), e.g. EPSG:6677; output axes follow S's
///                 authority order (EPSG:6677 gives northing first)
///   --src-srs S   override the file's srsName (ParserParams.srcSRS)
///   --verbose     echo libcitygml's log lines (warnings, errors) to stderr
///   --allow-doctype  parse files with a DOCTYPE (refused by default: libcitygml
///                 resolves external entities and DTDs, even over http)
///
/// Output (one JSON object):
///   {"file", "lod" (null = every LOD), "dest_srs", "src_srs", "srs_name",
///    "buildings": [{"gml_id", "area_m2", "triangles", "polygons",
///                   "degenerate_triangles", "polygon_refs",
///                   "area_by_lod": {"2": ...}, "bbox": [x0,y0,z0,x1,y1,z1],
///                   "parts", optional "other_lod_geometries",
///                   "nonfinite_vertices", "implicit_geometries"}],
///    "totals": {same fields, "buildings", "building_parts"},
///    "other_root_objects": {"ReliefFeature": 1, ...},
///    "libcitygml_log": {"errors": n, "warnings": n, "first_messages": [...]},
///    "stats": {"load_s", "walk_s", "peak_rss_kib"}}
/// "polygons" counts distinct polygon objects; a polygon that a solid reuses
/// through xlink:href (libcitygml shares the same object) counts, and adds
/// area, once. "polygon_refs" counts every reference. "area_m2" is in the
/// units of the output coordinates: right for projected CRSs, meaningless for
/// an unprojected lat/lon/h file (degrees mixed with metres: use --dest-srs).
/// Not counted: line strings, implicit geometries (counted, not placed), and
/// what libcitygml 2.4.3 does not parse (bldg:lod0FootPrint/lod0RoofEdge,
/// anything in CityGML 3.0).
/// Exit: 0 ok; 1 load failure (one line on stderr); 2 usage error.

#include <citygml/citygml.h>
#include <citygml/citygmllogger.h>
#include <citygml/citymodel.h>
#include <citygml/cityobject.h>
#include <citygml/geometry.h>
#include <citygml/polygon.h>

#include <sys/resource.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <unordered_set>
#include <vector>

namespace {

/// Collects libcitygml's log lines instead of letting its default logger
/// print them (its default StdLogger writes non-error lines to stdout, which
/// would corrupt the JSON).
class CollectingLogger : public citygml::CityGMLLogger {
public:
    explicit CollectingLogger(bool echo)
        : citygml::CityGMLLogger(LOGLEVEL::LL_WARNING), echo_(echo) {}

    void log(LOGLEVEL level, const std::string& message, const char* /*file*/,
             int /*line*/) const override {
        std::lock_guard<std::mutex> lock(mutex_);
        const bool is_error = level == LOGLEVEL::LL_ERROR;
        if (is_error)
            ++errors_;
        else if (level == LOGLEVEL::LL_WARNING)
            ++warnings_;
        else
            return;
        if (first_.size() < 10) first_.push_back((is_error ? "ERROR " : "WARNING ") + message);
        if (is_error && first_error_.empty()) first_error_ = message;
        if (echo_) std::cerr << "libcitygml " << (is_error ? "ERROR " : "WARNING ") << message << "\n";
    }

    uint64_t errors() const { return errors_; }
    uint64_t warnings() const { return warnings_; }
    const std::vector<std::string>& first() const { return first_; }
    const std::string& firstError() const { return first_error_; }

private:
    bool echo_;
    mutable std::mutex mutex_;
    mutable uint64_t errors_ = 0;
    mutable uint64_t warnings_ = 0;
    mutable std::vector<std::string> first_;
    mutable std::string first_error_;
};

std::string jsonString(const std::string& s) {
    std::string out = "\"";
    for (unsigned char c : s) {
        switch (c) {
        case '"': out += "\\\""; break;
        case '\\': out += "\\\\"; break;
        case '\n': out += "\\n"; break;
        case '\r': out += "\\r"; break;
        case '\t': out += "\\t"; break;
        default:
            if (c < 0x20) {
                char buf[8];
                std::snprintf(buf, sizeof buf, "\\u%04x", c);
                out += buf;
            } else {
                out += static_cast<char>(c);
            }
        }
    }
    return out + "\"";
}

std::string jsonNumber(double v) {
    if (!std::isfinite(v)) return "null";
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

struct Tally {
    double area = 0.0;
    uint64_t triangles = 0;           // non-degenerate
    uint64_t degenerate = 0;          // zero (or numerically zero) area
    uint64_t polygons = 0;            // distinct polygon objects
    uint64_t polygon_refs = 0;        // every reference, xlink reuse included
    uint64_t nonfinite_vertices = 0;  // NaN/inf coordinates that reached the mesh
    uint64_t bad_indices = 0;         // index out of range (should never happen)
    uint64_t skipped_geometries = 0;  // geometries of another LOD than --lod
    std::map<unsigned, double> area_by_lod;
    std::array<double, 6> bbox{std::numeric_limits<double>::infinity(),
                               std::numeric_limits<double>::infinity(),
                               std::numeric_limits<double>::infinity(),
                               -std::numeric_limits<double>::infinity(),
                               -std::numeric_limits<double>::infinity(),
                               -std::numeric_limits<double>::infinity()};
    std::unordered_set<const citygml::Polygon*> seen;

    void add(const Tally& o) {
        area += o.area;
        triangles += o.triangles;
        degenerate += o.degenerate;
        polygons += o.polygons;
        polygon_refs += o.polygon_refs;
        nonfinite_vertices += o.nonfinite_vertices;
        bad_indices += o.bad_indices;
        skipped_geometries += o.skipped_geometries;
        for (auto& [lod, a] : o.area_by_lod) area_by_lod[lod] += a;
        for (int k = 0; k < 3; ++k) {
            bbox[k] = std::min(bbox[k], o.bbox[k]);
            bbox[k + 3] = std::max(bbox[k + 3], o.bbox[k + 3]);
        }
    }
};

void addPolygon(const citygml::Polygon& poly, unsigned lod, Tally& t) {
    ++t.polygon_refs;
    if (!t.seen.insert(&poly).second) return;  // shared through xlink: count once
    ++t.polygons;
    const std::vector<TVec3d>& v = poly.getVertices();
    const std::vector<unsigned int>& idx = poly.getIndices();
    for (const TVec3d& p : v) {
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
            ++t.nonfinite_vertices;
            continue;
        }
        t.bbox[0] = std::min(t.bbox[0], p.x);
        t.bbox[1] = std::min(t.bbox[1], p.y);
        t.bbox[2] = std::min(t.bbox[2], p.z);
        t.bbox[3] = std::max(t.bbox[3], p.x);
        t.bbox[4] = std::max(t.bbox[4], p.y);
        t.bbox[5] = std::max(t.bbox[5], p.z);
    }
    double poly_area = 0.0;
    for (size_t i = 0; i + 2 < idx.size(); i += 3) {
        if (idx[i] >= v.size() || idx[i + 1] >= v.size() || idx[i + 2] >= v.size()) {
            ++t.bad_indices;
            continue;
        }
        const TVec3d& a = v[idx[i]];
        const TVec3d& b = v[idx[i + 1]];
        const TVec3d& c = v[idx[i + 2]];
        const double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z;
        const double wx = c.x - a.x, wy = c.y - a.y, wz = c.z - a.z;
        const double cx = uy * wz - uz * wy;
        const double cy = uz * wx - ux * wz;
        const double cz = ux * wy - uy * wx;
        const double twice = std::sqrt(cx * cx + cy * cy + cz * cz);
        // Degenerate: |u x w| tiny against the longest edge squared (scale-free,
        // so it works for degree coordinates as well as metres).
        const double e1 = ux * ux + uy * uy + uz * uz;
        const double e2 = wx * wx + wy * wy + wz * wz;
        const double dx = c.x - b.x, dy = c.y - b.y, dz = c.z - b.z;
        const double e3 = dx * dx + dy * dy + dz * dz;
        const double longest2 = std::max({e1, e2, e3});
        if (!std::isfinite(twice)) {
            ++t.degenerate;  // NaN coordinates: not an area
            continue;
        }
        if (twice <= 1e-12 * longest2 || longest2 == 0.0) {
            ++t.degenerate;
            continue;
        }
        ++t.triangles;
        poly_area += 0.5 * twice;
    }
    t.area += poly_area;
    t.area_by_lod[lod] += poly_area;
}

/// lod_filter < 0: every LOD. libcitygml 2.4.3 stores ParserParams.minLOD and
/// maxLOD but does not filter with them (measured: --lod 2 on an LOD1-only
/// file still returned its LOD1 solid), so the oracle filters here on
/// Geometry::getLOD(), which the parser sets from the lodN... property name.
void addGeometry(const citygml::Geometry& g, int lod_filter, Tally& t) {
    const bool wanted = lod_filter < 0 || g.getLOD() == static_cast<unsigned>(lod_filter);
    if (wanted) {
        for (unsigned i = 0; i < g.getPolygonsCount(); ++i) {
            std::shared_ptr<const citygml::Polygon> p = g.getPolygon(i);
            if (p) addPolygon(*p, g.getLOD(), t);
        }
    } else {
        ++t.skipped_geometries;
    }
    for (unsigned i = 0; i < g.getGeometriesCount(); ++i) addGeometry(g.getGeometry(i), lod_filter, t);
}

/// Walks a city object and all its children (BuildingParts, boundary
/// surfaces, openings, installations, rooms...). Implicit geometries
/// (prototypes placed by a matrix) are counted but not added to the area.
void addCityObject(const citygml::CityObject& o, int lod_filter, Tally& t, uint64_t& parts,
                   uint64_t& implicit) {
    if (o.getType() == citygml::CityObject::CityObjectsType::COT_BuildingPart) ++parts;
    implicit += o.getImplicitGeometryCount();
    for (unsigned i = 0; i < o.getGeometriesCount(); ++i) addGeometry(o.getGeometry(i), lod_filter, t);
    for (unsigned i = 0; i < o.getChildCityObjectsCount(); ++i)
        addCityObject(o.getChildCityObject(i), lod_filter, t, parts, implicit);
}

std::string tallyFields(const Tally& t) {
    std::ostringstream s;
    s << "\"area_m2\": " << jsonNumber(t.area) << ", \"triangles\": " << t.triangles
      << ", \"polygons\": " << t.polygons << ", \"degenerate_triangles\": " << t.degenerate
      << ", \"polygon_refs\": " << t.polygon_refs;
    if (t.nonfinite_vertices) s << ", \"nonfinite_vertices\": " << t.nonfinite_vertices;
    if (t.bad_indices) s << ", \"bad_indices\": " << t.bad_indices;
    if (t.skipped_geometries) s << ", \"other_lod_geometries\": " << t.skipped_geometries;
    s << ", \"area_by_lod\": {";
    bool first = true;
    for (auto& [lod, a] : t.area_by_lod) {
        s << (first ? "" : ", ") << "\"" << lod << "\": " << jsonNumber(a);
        first = false;
    }
    s << "}, \"bbox\": ";
    if (t.bbox[0] <= t.bbox[3]) {
        s << "[";
        for (int k = 0; k < 6; ++k) s << (k ? ", " : "") << jsonNumber(t.bbox[k]);
        s << "]";
    } else {
        s << "null";
    }
    return s.str();
}

[[noreturn]] void usage(const std::string& why) {
    std::cerr << "citygml_oracle: error: " << why
              << "\nusage: citygml_oracle FILE.gml [--lod N] [--dest-srs SRS] [--src-srs SRS] [--verbose] [--allow-doctype]\n";
    std::exit(2);
}

long peakRssKib() {
    struct rusage ru {};
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_maxrss;  // KiB on Linux
}

}  // namespace

int main(int argc, char** argv) {
    std::string file;
    std::string dest_srs, src_srs;
    int lod = -1;
    bool verbose = false;
    bool allow_doctype = false;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto value = [&](const char* name) -> std::string {
            if (i + 1 >= argc) usage(std::string(name) + " needs a value");
            return argv[++i];
        };
        if (a == "--lod") {
            const std::string v = value("--lod");
            if (v.size() != 1 || v[0] < '0' || v[0] > '4') usage("--lod must be 0..4");
            lod = v[0] - '0';
        } else if (a == "--dest-srs") {
            dest_srs = value("--dest-srs");
        } else if (a == "--src-srs") {
            src_srs = value("--src-srs");
        } else if (a == "--verbose") {
            verbose = true;
        } else if (a == "--allow-doctype") {
            allow_doctype = true;
        } else if (a == "-h" || a == "--help") {
            std::cout << "usage: citygml_oracle FILE.gml [--lod N] [--dest-srs SRS] [--src-srs SRS] [--verbose] [--allow-doctype]\n";
            return 0;
        } else if (!a.empty() && a[0] == '-') {
            usage("unknown option " + a);
        } else if (file.empty()) {
            file = a;
        } else {
            usage("more than one input file");
        }
    }
    if (file.empty()) usage("no input file");

    // libcitygml's Xerces input source reports a missing file only through
    // its logger; check first so the message is clear. Also refuse any
    // DOCTYPE: libcitygml's Xerces parser fetches external DTDs and entities
    // (file:// and http://, measured) and spins for minutes on an entity
    // bomb, so the oracle is only for trusted, DTD-free files.
    if (FILE* f = std::fopen(file.c_str(), "rb")) {
        std::string head(64 * 1024, '\0');
        head.resize(std::fread(head.data(), 1, head.size(), f));
        std::fclose(f);
        if (!allow_doctype && (head.find("<!DOCTYPE") != std::string::npos ||
                               head.find("<!ENTITY") != std::string::npos)) {
            std::cerr << "citygml_oracle: error: " << file
                      << ": has a DOCTYPE; refused (libcitygml would resolve its entities; --allow-doctype overrides)\n";
            return 1;
        }
    } else {
        std::cerr << "citygml_oracle: error: cannot open " << file << "\n";
        return 1;
    }

    citygml::ParserParams params;
    if (lod >= 0) {
        params.minLOD = static_cast<unsigned>(lod);
        params.maxLOD = static_cast<unsigned>(lod);
    }
    params.destSRS = dest_srs;
    params.srcSRS = src_srs;

    auto logger = std::make_shared<CollectingLogger>(verbose);
    const auto t0 = std::chrono::steady_clock::now();
    std::shared_ptr<const citygml::CityModel> model;
    try {
        model = citygml::load(file, params, logger);
    } catch (const std::exception& e) {
        std::cerr << "citygml_oracle: error: " << file << ": libcitygml threw: " << e.what() << "\n";
        return 1;
    } catch (...) {
        std::cerr << "citygml_oracle: error: " << file << ": libcitygml threw a non-standard exception\n";
        return 1;
    }
    const auto t1 = std::chrono::steady_clock::now();
    if (!model) {
        std::cerr << "citygml_oracle: error: " << file << ": libcitygml returned no model"
                  << (logger->firstError().empty() ? "" : ": " + logger->firstError()) << "\n";
        return 1;
    }

    std::ostringstream buildings;
    Tally total;
    uint64_t n_buildings = 0, total_parts = 0, total_implicit = 0;
    std::map<std::string, uint64_t> others;
    const citygml::ConstCityObjects roots = model->getRootCityObjects();
    for (const citygml::CityObject* root : roots) {
        if (!root) continue;
        if (root->getType() != citygml::CityObject::CityObjectsType::COT_Building) {
            ++others[root->getTypeAsString()];
            continue;
        }
        Tally t;
        uint64_t parts = 0, implicit = 0;
        addCityObject(*root, lod, t, parts, implicit);
        buildings << (n_buildings ? ",\n    " : "\n    ") << "{\"gml_id\": " << jsonString(root->getId())
                  << ", " << tallyFields(t) << ", \"parts\": " << parts;
        if (implicit) buildings << ", \"implicit_geometries\": " << implicit;
        buildings << "}";
        ++n_buildings;
        total_parts += parts;
        total_implicit += implicit;
        total.add(t);
    }
    const auto t2 = std::chrono::steady_clock::now();

    std::ostringstream out;
    out << "{\"file\": " << jsonString(file) << ",\n  \"lod\": " << (lod >= 0 ? std::to_string(lod) : "null")
        << ", \"dest_srs\": " << jsonString(dest_srs) << ", \"src_srs\": " << jsonString(src_srs)
        << ", \"srs_name\": " << jsonString(model->getSRSName()) << ",\n  \"buildings\": [" << buildings.str()
        << (n_buildings ? "\n  ],\n" : "],\n");
    out << "  \"totals\": {\"buildings\": " << n_buildings << ", \"building_parts\": " << total_parts
        << ", \"implicit_geometries\": " << total_implicit << ", " << tallyFields(total) << "},\n";
    out << "  \"other_root_objects\": {";
    bool first = true;
    for (auto& [type, n] : others) {
        out << (first ? "" : ", ") << jsonString(type) << ": " << n;
        first = false;
    }
    out << "},\n  \"libcitygml_log\": {\"errors\": " << logger->errors() << ", \"warnings\": " << logger->warnings()
        << ", \"first_messages\": [";
    for (size_t i = 0; i < logger->first().size(); ++i)
        out << (i ? ", " : "") << jsonString(logger->first()[i]);
    out << "]},\n  \"stats\": {\"load_s\": " << jsonNumber(std::chrono::duration<double>(t1 - t0).count())
        << ", \"walk_s\": " << jsonNumber(std::chrono::duration<double>(t2 - t1).count())
        << ", \"peak_rss_kib\": " << peakRssKib() << "}}\n";
    std::cout << out.str();
    std::cout.flush();
    if (!std::cout) {
        std::cerr << "citygml_oracle: error: cannot write to stdout\n";
        return 1;
    }
    return 0;
}
