// SPDX-License-Identifier: GPL-3.0-or-later
// `cityatlas inspect`: the checks of tiles/inspect.h. tileset.json is validated
// against the compiled-in schema first; everything after reads the document
// through accessors that throw BadEntry instead of trusting that the schema
// held, so a damaged index still gets every check that can run, and nothing in
// it can crash the checker. Defects are collected per node (or block, or
// table) and concatenated in index order: the report is the same for any
// thread count.
#include "tiles/inspect.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <fstream>
#include <functional>
#include <iterator>
#include <memory>
#include <set>
#include <stdexcept>
#include <string_view>
#include <tuple>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <valijson/adapters/nlohmann_json_adapter.hpp>
#include <valijson/schema.hpp>
#include <valijson/schema_parser.hpp>
#include <valijson/validation_results.hpp>
#include <valijson/validator.hpp>

#include "format/blockmap_file.h"
#include "format/feature_bounds.h"
#include "format/tileset_document_json.h"
#include "format/tileset_index.h"
#include "tiles/glb_writer.h"
#include "tiles/texture_codec.h"
#include "tiles/tileset.h"

namespace cityatlas::tiles {

const nlohmann::json& tilesetSchema() {
    static const nlohmann::json schema = nlohmann::json::parse(
#include "tiles/tileset_schema.inc"
    );
    return schema;
}

namespace {
namespace fs = std::filesystem;
using nlohmann::json;
using Defects = std::vector<std::string>;

// libstdc++'s std::regex recurses once per character (a 100k-character uri
// overflows the stack inside valijson), and valijson and the tree walk recurse
// once per nesting level: both are bounded before anything else runs.
constexpr size_t kMaxStringChars = 1024;
constexpr int kMaxNesting = 256;
constexpr double kRelTolerance = 1e-9;  // for values the writer derives from one another

// --- Reading the index without trusting it -----------------------------------

struct BadEntry : std::runtime_error {
    using std::runtime_error::runtime_error;
};

const json& member(const json& j, const char* key) {
    if (!j.is_object()) throw BadEntry(fmt::format("not an object (looking for '{}')", key));
    const auto it = j.find(key);
    if (it == j.end()) throw BadEntry(fmt::format("no '{}'", key));
    return *it;
}
const json& arrayOf(const json& j, const char* key) {
    const json& v = member(j, key);
    if (!v.is_array()) throw BadEntry(fmt::format("'{}' is not an array", key));
    return v;
}
double numberOf(const json& v, const char* what) {
    if (!v.is_number() || !std::isfinite(v.get<double>())) throw BadEntry(fmt::format("'{}' is not a number", what));
    return v.get<double>();
}
double number(const json& j, const char* key) { return numberOf(member(j, key), key); }
// JSON Schema integers include 1.0; a value that does not fit is an error, never a wrapped number.
int64_t integerOf(const json& v, const char* what) {
    if (v.is_number_unsigned() && v.get<uint64_t>() <= uint64_t{INT64_MAX})
        return static_cast<int64_t>(v.get<uint64_t>());
    if (v.is_number_integer() && !v.is_number_unsigned()) return v.get<int64_t>();
    if (v.is_number_float() && std::abs(v.get<double>()) < 9e15 && v.get<double>() == std::floor(v.get<double>()))
        return static_cast<int64_t>(v.get<double>());
    throw BadEntry(fmt::format("'{}' is not an integer", what));
}
int64_t integer(const json& j, const char* key) { return integerOf(member(j, key), key); }
int64_t count(const json& j, const char* key) {
    const int64_t v = integer(j, key);
    if (v < 0) throw BadEntry(fmt::format("'{}' is negative", key));
    return v;
}
std::string text(const json& j, const char* key) {
    const json& v = member(j, key);
    if (!v.is_string()) throw BadEntry(fmt::format("'{}' is not a string", key));
    return v.get<std::string>();
}
bool near(double a, double b) { return std::abs(a - b) <= kRelTolerance * std::max(std::abs(a), std::abs(b)); }

// Cuts over-long strings to kMaxStringChars + 1 characters (still too long for
// every check that cares, short enough for std::regex) and returns the deepest
// nesting; iterative, so any document is safe.
int boundDocument(json& doc) {
    int deepest = 0;
    std::vector<std::pair<json*, int>> stack{{&doc, 1}};
    while (!stack.empty()) {
        auto [j, depth] = stack.back();
        stack.pop_back();
        deepest = std::max(deepest, depth);
        if (depth > kMaxNesting) break;
        if (j->is_string() && j->get_ref<const std::string&>().size() > kMaxStringChars)
            j->get_ref<std::string&>().resize(kMaxStringChars + 1);
        if (j->is_structured())
            for (json& c : *j) stack.emplace_back(&c, depth + 1);
    }
    return deepest;
}

// --- Schema --------------------------------------------------------------------

// The JSON pointer of a valijson context ("<root>", "[root]", "[children]", "[0]", ...).
std::string pointerOf(const std::vector<std::string>& context) {
    std::string p;
    for (const std::string& c : context) {
        if (c.size() < 2 || c.front() != '[' || c.back() != ']') continue;
        p += '/';
        for (char ch : std::string_view(c).substr(1, c.size() - 2))
            p += ch == '~' ? "~0" : ch == '/' ? "~1" : std::string(1, ch);
    }
    return p.empty() ? "/" : p;
}

const valijson::Schema& compiledSchema() {
    static const auto schema = [] {
        auto s = std::make_unique<valijson::Schema>();
        valijson::SchemaParser parser(valijson::SchemaParser::kDraft7);
        valijson::adapters::NlohmannJsonAdapter adapter(tilesetSchema());
        parser.populateSchema(adapter, *s);
        return s;
    }();
    return *schema;
}

// One line per schema error. valijson also reports every ancestor of an error
// ("Failed to validate against schema associated with property name 'root'"):
// those add nothing and are left out.
void validateSchema(const json& doc, Defects& out) {
    try {
        valijson::Validator validator;
        valijson::ValidationResults results;
        valijson::adapters::NlohmannJsonAdapter adapter(doc);
        if (validator.validate(compiledSchema(), adapter, &results)) return;
        std::vector<std::pair<std::string, std::string>> errors;
        valijson::ValidationResults::Error e;
        while (results.popError(e)) errors.emplace_back(pointerOf(e.context), e.description);
        std::set<std::string> seen;
        for (const auto& error : errors) {
            const std::string& where = error.first;  // not a structured binding: clang < 16 cannot capture one
            const std::string& what = error.second;
            const std::string below = where == "/" ? "/" : where + "/";
            auto deeper = [&](const auto& o) { return o.first != where && o.first.rfind(below, 0) == 0; };
            if (what.rfind("Failed to validate", 0) == 0 && std::any_of(errors.begin(), errors.end(), deeper)) continue;
            if (seen.insert(where + what).second) out.push_back(fmt::format("tileset.json: {}: {}", where, what));
        }
    } catch (const std::exception& ex) {
        out.push_back(fmt::format("tileset.json: schema validation failed: {}", ex.what()));
    }
}

// --- Files ---------------------------------------------------------------------

// Why `uri` is not a relative path inside the folder (the schema's uri rule, without std::regex); empty if it is.
std::string uriProblem(const std::string& uri) {
    if (uri.empty()) return "empty uri";
    if (uri.size() > kMaxStringChars) return fmt::format("uri longer than {} characters", kMaxStringChars);
    auto plain = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; };
    if (!plain(uri.front())) return "uri does not start with a letter, digit or '_'";
    for (char c : uri)
        if (!plain(c) && c != '.' && c != '/' && c != '-') return "uri has characters other than A-Z a-z 0-9 _ . / -";
    if (uri == ".." || uri.find("/../") != std::string::npos || uri.ends_with("/.."))
        return "uri leaves the folder ('..')";
    return {};
}

// The folder: every file is looked at through check(), which counts it.
class Folder {
public:
    explicit Folder(const fs::path& folder) : folder_(folder) {
        std::error_code ec;
        root_ = fs::weakly_canonical(folder, ec);
    }
    // Whether `uri` names a regular file inside the folder (symlinks resolved)
    // of `bytes` bytes (any size when negative); a defect naming it otherwise.
    bool check(const std::string& uri, int64_t bytes, Defects& d) {
        ++files_checked;
        if (std::string why = uriProblem(uri); !why.empty()) {
            d.push_back(fmt::format("{}: {}", uri.substr(0, 200), why));
            return false;
        }
        std::error_code ec;
        const fs::path p = folder_ / uri;
        const fs::file_status st = fs::status(p, ec);
        if (!fs::exists(st)) {
            d.push_back(fmt::format("{}: missing", uri));
            return false;
        }
        const fs::path real = fs::weakly_canonical(p, ec);
        const fs::path rel = ec ? fs::path() : real.lexically_relative(root_);
        if (rel.empty() || *rel.begin() == "..") {
            d.push_back(fmt::format("{}: resolves to {}, outside the folder", uri, real.string()));
            return false;
        }
        if (!fs::is_regular_file(st)) {
            d.push_back(fmt::format("{}: not a regular file", uri));
            return false;
        }
        const uintmax_t size = fs::file_size(p, ec);
        if (ec || (bytes >= 0 && size != static_cast<uint64_t>(bytes))) {
            d.push_back(fmt::format("{}: {} bytes, tileset.json says {}", uri, ec ? 0 : size, bytes));
            return false;
        }
        return true;
    }
    fs::path path(const std::string& uri) const { return folder_ / uri; }
    std::atomic<uint64_t> files_checked{0};

private:
    fs::path folder_, root_;
};

// Up to `max` bytes of `path` from `offset` (fewer at its end; none when unreadable).
std::vector<uint8_t> readBytes(const fs::path& path, uint64_t offset, uint64_t max) {
    std::vector<uint8_t> b;
    std::ifstream f(path, std::ios::binary);
    if (!f || !f.seekg(static_cast<std::streamoff>(offset))) return b;
    b.resize(static_cast<size_t>(max));
    f.read(reinterpret_cast<char*>(b.data()), static_cast<std::streamsize>(b.size()));
    b.resize(static_cast<size_t>(f.gcount()));
    return b;
}

// The DDS header at `offset` of a checked file against its entry; only the
// header is read. `what` prefixes the messages (empty for a file that is one DDS).
void checkDds(const fs::path& path, const std::string& uri, uint64_t offset, const std::string& what, int channels,
              int64_t width, int64_t height, int64_t mips, uint64_t bytes, Defects& d) {
    const std::vector<uint8_t> head = readBytes(path, offset, 148);  // with a DX10 header's 20 bytes
    DdsInfo info;
    if (Status st = parseDdsHeader(head.data(), head.size(), &info); !st.ok()) {
        d.push_back(fmt::format("{}: {}{}", uri, what, st.error));
        return;
    }
    const auto name = format::bcFormatName;
    if (info.channels != channels || info.width != width || info.height != height || info.mips != mips)
        d.push_back(fmt::format("{}: {}the DDS is {} {}x{} with {} mips, tileset.json says {} {}x{} with {}", uri, what,
                                name(info.channels), info.width, info.height, info.mips, name(channels), width, height,
                                mips));
    if (info.expected_bytes != bytes)
        d.push_back(fmt::format("{}: {}{} bytes, its DDS header makes {}", uri, what, bytes, info.expected_bytes));
}

int fullMipCount(int64_t w, int64_t h) {
    int n = 1;
    for (; w > 1 || h > 1; w = std::max<int64_t>(1, w / 2), h = std::max<int64_t>(1, h / 2)) ++n;
    return n;
}

// --- The tree --------------------------------------------------------------------

struct Layer {
    std::string name;  // "opaque" / "alpha"
    std::string geometry_uri;
    int64_t geometry_bytes = 0, triangles = 0;
    double geometric_error_m = 0;
    int64_t left_out_over_cap = 0;  // buildings its merge left out over the cap (tiles/node_geometry.h)
    bool has_atlas = false;
    std::string atlas_uri, atlas_format;
    int64_t atlas_bytes = 0, atlas_w = 0, atlas_h = 0, atlas_mips = 0;
    std::array<int64_t, 2> atlas_offset{};
    std::vector<format::ComputedFileEntry> computed;  // aligned with extras.cityatlas.computed
};

struct Node {
    std::string pointer;  // in tileset.json, e.g. /root/children/1
    int parent = -1;      // index into the preorder list
    bool usable = false;  // every field below could be read
    bool leaf = true;
    bool transform = false;
    int64_t id = -1, level = 0, quadrant = 0, bytes = 0, feature_count = 0;
    double min_distance_m = 0, sharp_from_m = 0, world_texel_m = 0, geometric_error = 0;
    Vec3d centre;
    std::array<double, 12> box{};
    std::vector<Layer> layers;
    std::vector<std::string> contents;
    std::vector<int64_t> texture_blocks, feature_tables, dropped;
    std::optional<format::BlockMapEntry> blockmap;
    std::string where() const { return fmt::format("tileset.json: {} (node {})", pointer, id); }
};

// One tile through the format library's reader, the one the client's index
// is built from (format/tileset_document.h): inspect checks what the client
// reads, not a second reading of the file.
void readNode(const json& tile, Node& n) {
    format::TileEntry t;
    if (Status st = format::readTileEntry(tile, n.pointer, &t); !st.ok()) {
        // The reader's message starts with the pointer ("P: ..." or "P layer opaque: ..."); readTree adds it again.
        std::string why = st.error;
        if (why.rfind(n.pointer, 0) == 0) why.erase(0, why.find_first_not_of(".: ", n.pointer.size()));
        throw BadEntry(why);
    }
    n.id = t.id;
    n.level = t.level;
    n.quadrant = t.quadrant;
    n.bytes = static_cast<int64_t>(t.bytes);
    n.min_distance_m = t.min_distance_m;
    n.sharp_from_m = t.sharp_from_m;
    n.world_texel_m = t.world_texel_m;
    n.geometric_error = t.geometric_error;
    n.transform = t.transform.has_value();
    n.centre = t.centre;
    n.box = t.box;
    for (int li = 0; li < format::kTileLayers; ++li) {
        const auto& e = t.layers[static_cast<size_t>(li)];
        if (!e) continue;
        Layer l;
        l.name = format::layerName(li);
        l.geometry_uri = e->geometry.uri;
        l.geometry_bytes = static_cast<int64_t>(e->geometry.bytes);
        l.triangles = static_cast<int64_t>(e->triangles);
        l.geometric_error_m = e->geometric_error_m;
        l.left_out_over_cap = static_cast<int64_t>(e->left_out_over_cap);
        if (e->atlas) {
            l.has_atlas = true;
            l.atlas_uri = e->atlas->file.uri;
            l.atlas_bytes = static_cast<int64_t>(e->atlas->file.bytes);
            l.atlas_format = e->atlas->format;
            l.atlas_w = e->atlas->width_px;
            l.atlas_h = e->atlas->height_px;
            l.atlas_offset = e->atlas->offset;
            l.atlas_mips = e->atlas->mips;
        }
        l.computed = e->computed;
        n.layers.push_back(std::move(l));
    }
    n.contents = t.contents;
    n.texture_blocks = t.texture_blocks;
    n.feature_count = static_cast<int64_t>(t.feature_count);
    n.feature_tables.assign(t.feature_tables.begin(), t.feature_tables.end());
    n.dropped.assign(t.features_dropped.begin(), t.features_dropped.end());
    n.blockmap = std::move(t.blockmap);
    n.usable = true;
}

// The tiles in depth-first preorder; a tile that cannot be read is a defect and
// an unusable node (its children are still read). Nesting is bounded, so the
// recursion is too.
void readTree(const json& tile, const std::string& pointer, int parent, std::vector<Node>& nodes, Defects& d) {
    const json* children = tile.is_object() && tile.contains("children") ? &tile["children"] : nullptr;
    Node n;
    n.pointer = pointer;
    n.parent = parent;
    n.leaf = !children || !children->is_array() || children->empty();
    try {
        readNode(tile, n);
    } catch (const BadEntry& e) {
        n.usable = false;
        d.push_back(fmt::format("tileset.json: {}: tile not checked: {}", pointer, e.what()));
    }
    const bool leaf = n.leaf;
    const int index = static_cast<int>(nodes.size());
    nodes.push_back(std::move(n));
    if (!leaf)
        for (size_t c = 0; c < children->size(); ++c)
            readTree((*children)[c], fmt::format("{}/children/{}", pointer, c), index, nodes, d);
}

// What the whole index says, for the per-node checks.
struct Index {
    double focal_px = 0, corner_factor = 1, d_min_m = 0;
    int64_t atlas_size_px = 0, materials = 0, feature_count = 0, block_size = 1;
    bool all_originals = false;  // build.originals == "all": leaves list the blocks of every texture they use
    std::string blockmaps = "off";  // build.blockmaps
    std::vector<int64_t> texture_block;  // per texture; -2: the entry cannot be read
    size_t blocks = 0, tables = 0;
    std::vector<int64_t> computed_scale;   // per computed texture (extras.cityatlas.computed)
    std::vector<uint64_t> computed_bytes;  // what each entry says its files take
};

// A node layer's computed textures against the index: one per computed
// texture where the layer has an atlas (none where it has not), each
// 1/scale of the atlas with the full mip chain; their bytes add up to `sums`.
void checkComputedLayer(const Layer& l, const Index& ix, std::vector<uint64_t>& sums,
                        const std::function<void(const std::string&)>& bad) {
    const size_t k_all = ix.computed_scale.size();
    if (l.computed.empty() && (!l.has_atlas || k_all == 0)) return;
    if (l.computed.size() != k_all) {
        bad(fmt::format("{} layer lists {} computed textures, the index has {}", l.name, l.computed.size(), k_all));
        return;
    }
    for (size_t k = 0; k < k_all; ++k) {
        const format::ComputedFileEntry& c = l.computed[k];
        if (c.file.uri.empty()) {
            if (l.has_atlas) bad(fmt::format("{} layer: no computed texture {} for its atlas", l.name, k));
            continue;
        }
        if (!l.has_atlas) {
            bad(fmt::format("{} layer: computed texture {} without an atlas", l.name, k));
            continue;
        }
        sums[k] += c.file.bytes;
        const int64_t s = ix.computed_scale[k];
        const int64_t w = (l.atlas_w + s - 1) / s, h = (l.atlas_h + s - 1) / s;
        if (c.width_px != w || c.height_px != h)
            bad(fmt::format("{}: {}x{}, its {}x{} atlas at scale {} makes {}x{}", c.file.uri, c.width_px, c.height_px,
                            l.atlas_w, l.atlas_h, s, w, h));
        if (c.mips != fullMipCount(c.width_px, c.height_px)) bad(fmt::format("{}: {} mips, not the full chain", c.file.uri, c.mips));
    }
}

// Corner extremes of a 3D Tiles box per axis (exact for the writer's
// axis-aligned boxes; the enclosing axis-aligned box otherwise).
std::array<double, 6> extent(const std::array<double, 12>& b) {
    std::array<double, 6> e{};
    for (size_t k = 0; k < 3; ++k) {
        const double h = std::abs(b[3 + k]) + std::abs(b[6 + k]) + std::abs(b[9 + k]);
        e[k] = b[k] - h, e[3 + k] = b[k] + h;
    }
    return e;
}

// Checks that need the tree but no file: cheap, serial, in preorder.
// A child's atlas, halved, lies at offset(child) / 2 - offset(parent) inside
// its parent's atlas, apart from its siblings' (atlas/atlas_tree.h).
struct PlacedRect {
    std::string layer;
    int64_t x0, y0, x1, y1;
};
template <class Bad>
void checkPlacement(const Node& n, const Node& p, std::vector<PlacedRect>& siblings, const Bad& bad) {
    if (p.layers.empty()) return;  // a parent `--blockmaps replace` left to its BlockMap holds no atlas
    for (const Layer& l : n.layers) {
        if (!l.has_atlas) continue;
        const auto pl = std::find_if(p.layers.begin(), p.layers.end(), [&](const Layer& x) { return x.name == l.name; });
        if (pl == p.layers.end() || !pl->has_atlas) {
            bad(fmt::format("a {} atlas under a parent without one", l.name));
            continue;
        }
        if (l.atlas_offset[0] % 2 || l.atlas_offset[1] % 2) {
            bad(fmt::format("{} atlas offset [{}, {}] is odd: not a placement in its parent's atlas", l.name,
                            l.atlas_offset[0], l.atlas_offset[1]));
            continue;
        }
        const PlacedRect r{l.name, l.atlas_offset[0] / 2 - pl->atlas_offset[0], l.atlas_offset[1] / 2 - pl->atlas_offset[1],
                           0, 0};
        PlacedRect box = r;
        box.x1 = r.x0 + (l.atlas_w + 1) / 2, box.y1 = r.y0 + (l.atlas_h + 1) / 2;
        if (box.x0 < 0 || box.y0 < 0 || box.x1 > pl->atlas_w || box.y1 > pl->atlas_h) {
            bad(fmt::format("{} atlas {}x{} halved at [{}, {}] leaves its parent's {}x{} atlas", l.name, l.atlas_w,
                            l.atlas_h, box.x0, box.y0, pl->atlas_w, pl->atlas_h));
            continue;
        }
        for (const PlacedRect& o : siblings)
            if (o.layer == box.layer && box.x0 < o.x1 && o.x0 < box.x1 && box.y0 < o.y1 && o.y0 < box.y1) {
                bad(fmt::format("{} atlas halved at [{}, {}] overlaps a sibling's in the parent's atlas", l.name, box.x0,
                                box.y0));
                break;
            }
        siblings.push_back(box);
    }
}

// `--blockmaps replace` (tiles/node_blockmaps.h, replacedLevels): the flag
// and the files agree. Nodes without geometry are whole levels from the
// root, each node an inner one with a BlockMap; the level below them holds a
// leaf or a node without a BlockMap (else it would have been replaced too);
// their geometry and atlas files are gone. Without the flag every node has
// geometry.
void checkReplaced(const std::vector<Node>& nodes, const Index& ix, const fs::path& folder, Defects& d) {
    const bool replace = ix.blockmaps == "replace";
    std::map<int64_t, std::pair<size_t, size_t>> by_level;  // level -> (nodes, without geometry)
    std::map<int64_t, bool> keeps;                           // level -> holds a leaf or a node without a BlockMap
    for (const Node& n : nodes) {
        if (!n.usable) continue;
        auto& [all, bare] = by_level[n.level];
        ++all;
        keeps[n.level] = keeps[n.level] || n.leaf || !n.blockmap;
        if (!n.layers.empty()) continue;
        ++bare;
        auto bad = [&](const std::string& what) { d.push_back(fmt::format("{}: {}", n.where(), what)); };
        if (!replace) {
            bad(fmt::format("no geometry, and build.blockmaps is {}, not replace", ix.blockmaps));
            continue;
        }
        if (!n.blockmap) bad("no geometry and no BlockMap to stand for it");
        if (n.leaf) bad("a leaf without geometry (nothing finer stands for it)");
        if (!n.contents.empty()) bad("contents listed for a node without geometry");
        for (const char* kind : {"geometry", "atlas"})
            for (const char* layer : {"opaque", "alpha"}) {
                const std::string uri = fmt::format("{}/{}/{}.{}", kind, layer, n.id, kind[0] == 'g' ? "glb" : "dds");
                std::error_code ec;
                if (fs::exists(folder / uri, ec)) bad(fmt::format("{} is in the folder: replaced, its node lists none", uri));
            }
    }
    if (!replace) return;
    int64_t replaced = 0;  // levels 0..replaced-1 are without geometry
    for (const auto& [level, counts] : by_level) {
        const auto [all, bare] = counts;
        if (bare == all && level == replaced) {
            ++replaced;
        } else if (bare > 0) {
            d.push_back(fmt::format("tileset.json: level {}: {} of its {} nodes without geometry: replace leaves whole "
                                    "levels from the root to their BlockMaps",
                                    level, bare, all));
        }
    }
    if (by_level.count(replaced) && !keeps[replaced])
        d.push_back(fmt::format("tileset.json: level {}: every node is an inner node with a BlockMap, yet it keeps its "
                                "geometry under build.blockmaps replace",
                                replaced));
}

void checkTree(const std::vector<Node>& nodes, const Index& ix, Defects& d) {
    std::vector<uint64_t> computed_sums(ix.computed_scale.size(), 0);
    std::set<int64_t> ids;
    std::map<int, std::set<int64_t>> quadrants;
    std::map<int, std::vector<PlacedRect>> placed;
    std::map<int, double> widest_child;  // parent -> largest child sharp_from_m
    bool preorder = true;
    for (size_t i = 0; i < nodes.size(); ++i) {
        const Node& n = nodes[i];
        if (!n.usable) continue;
        auto bad = [&](const std::string& what) { d.push_back(fmt::format("{}: {}", n.where(), what)); };
        if (n.id != static_cast<int64_t>(i) && preorder) {
            bad(fmt::format("id {} is not its depth-first preorder index {} (later ids not compared)", n.id, i));
            preorder = false;
        }
        if (n.id >= static_cast<int64_t>(nodes.size())) bad(fmt::format("id outside 0..{}", nodes.size() - 1));
        if (!ids.insert(n.id).second) bad("id used twice");
        const double focal = ix.focal_px, texel_focal = ix.focal_px * ix.corner_factor;
        // A layer whose merge was capped has an error above the texel, which
        // the tile's covers (in the texel's units: error * corner_factor).
        double expected_error = n.min_distance_m / focal;
        for (const Layer& l : n.layers) expected_error = std::max(expected_error, l.geometric_error_m * ix.corner_factor);
        if (!near(n.geometric_error, expected_error))
            bad(fmt::format("geometricError {} != min_distance_m / focal_px = {}{}", n.geometric_error,
                            n.min_distance_m / focal,
                            expected_error > n.min_distance_m / focal
                                ? fmt::format(" raised to its layers' error * corner_factor = {}", expected_error)
                                : std::string()));
        if (!near(n.world_texel_m, n.min_distance_m / texel_focal))
            bad(fmt::format("world_texel_m {} != min_distance_m / (focal_px * corner_factor) = {}", n.world_texel_m,
                            n.min_distance_m / texel_focal));
        if (n.leaf && !near(n.min_distance_m, ix.d_min_m))
            bad(fmt::format("a leaf with min_distance_m {}, build.d_min_m is {}", n.min_distance_m, ix.d_min_m));
        if (n.leaf ? n.sharp_from_m < n.min_distance_m * (1 - kRelTolerance) : !near(n.sharp_from_m, n.min_distance_m))
            bad(fmt::format("sharp_from_m {} with min_distance_m {} ({})", n.sharp_from_m, n.min_distance_m,
                            n.leaf ? "a leaf's is at least that" : "an inner node's is that"));
        int64_t bytes = 0;
        std::set<std::string> layer_uris;
        for (const Layer& l : n.layers) {
            checkComputedLayer(l, ix, computed_sums, bad);
            bytes += l.geometry_bytes + (l.has_atlas ? l.atlas_bytes : 0);
            layer_uris.insert(l.geometry_uri);
            if (l.geometric_error_m > 0 && l.geometric_error_m >= n.world_texel_m && l.left_out_over_cap == 0)
                bad(fmt::format("{} geometric_error_m {} is not below world_texel_m {} (and no building left out over "
                                "the merge's cap)",
                                l.name, l.geometric_error_m, n.world_texel_m));
        }
        if (bytes != n.bytes) bad(fmt::format("bytes {} != its geometry and atlases ({})", n.bytes, bytes));
        if (n.contents.size() != n.layers.size() || std::set(n.contents.begin(), n.contents.end()) != layer_uris)
            bad("contents do not list exactly the layers' geometry");
        for (int64_t b : n.texture_blocks)
            if (b < 0 || static_cast<size_t>(b) >= ix.blocks) bad(fmt::format("texture block {} does not exist", b));
        for (int64_t t : n.feature_tables)
            if (t < 0 || static_cast<size_t>(t) >= ix.tables) bad(fmt::format("feature table {} does not exist", t));
        for (int64_t f : n.dropped)
            if (f < 0 || f >= ix.feature_count) bad(fmt::format("dropped feature {} does not exist", f));
        if (n.parent < 0) {
            if (n.level != 0 || n.quadrant != -1) bad("the root is not at level 0 with quadrant -1");
            for (const Layer& l : n.layers)
                if (l.has_atlas && l.atlas_offset != std::array<int64_t, 2>{0, 0})
                    bad(fmt::format("{} atlas offset [{}, {}], the root's is [0, 0]", l.name, l.atlas_offset[0],
                                    l.atlas_offset[1]));
            continue;
        }
        if (n.transform) bad("a transform below the root (3D Tiles would apply it on top of the root's)");
        const Node& p = nodes[static_cast<size_t>(n.parent)];
        if (!p.usable) continue;
        if (n.level != p.level + 1) bad(fmt::format("level {} under a parent at level {}", n.level, p.level));
        if (n.quadrant < 0 || n.quadrant > 3) {
            bad(fmt::format("a child with quadrant {}", n.quadrant));
        } else if (!quadrants[n.parent].insert(n.quadrant).second) {
            bad(fmt::format("a second child in quadrant {}", n.quadrant));
        }
        checkPlacement(n, p, placed[n.parent], bad);
        if (p.min_distance_m < 2 * n.sharp_from_m * (1 - kRelTolerance))
            bad(fmt::format("sharp_from_m {} is more than half its parent's min_distance_m {}", n.sharp_from_m,
                            p.min_distance_m));
        widest_child[n.parent] = std::max(widest_child[n.parent], n.sharp_from_m);
        const auto c = extent(n.box), e = extent(p.box);
        (void)ix;
        for (size_t k = 0; k < 3; ++k) {
            const double tol = 1e-6 * std::max({std::abs(e[k]), std::abs(e[3 + k]), 1.0}) + 1e-6;
            if (c[k] < e[k] - tol || c[3 + k] > e[3 + k] + tol) {
                bad(fmt::format("box [{}, {}] along {} is not inside its parent's [{}, {}]", c[k], c[3 + k], "xyz"[k],
                                e[k], e[3 + k]));
                break;
            }
        }
    }
    for (size_t k = 0; k < computed_sums.size(); ++k)
        if (computed_sums[k] != ix.computed_bytes[k])
            d.push_back(fmt::format("tileset.json: /extras/cityatlas/computed/{}: bytes {}, its files take {}", k,
                                    ix.computed_bytes[k], computed_sums[k]));
    for (const auto& [parent, widest] : widest_child) {
        const Node& p = nodes[static_cast<size_t>(parent)];
        if (p.usable && !near(p.min_distance_m, 2 * widest))
            d.push_back(fmt::format("{}: min_distance_m {} is not 2 x its children's largest sharp_from_m {}", p.where(),
                                    p.min_distance_m, widest));
    }
}

// --- Files of a node -------------------------------------------------------------

// The geometry (decoded and compared with the index) and atlases (DDS headers) of one node.
// A node's BlockMap (format/blockmap_file.h): the decoder checks every
// index the ray caster follows; here, that the file says what the index says,
// and that it holds the node's buildings: those of its geometry and those its
// geometry dropped, each either in a cell or listed as missing. `buildings`
// gets what it holds or lists (a node without geometry: the node's features).
void checkBlockMap(const Node& n, const format::BlockMapEntry& e, const Index& ix, Folder& folder,
                   const std::set<uint32_t>& geometry_features, bool geometry_decoded, Defects& d,
                   std::set<uint32_t>* buildings) {
    auto bad = [&](const std::string& what) { d.push_back(fmt::format("{}: {}", e.file.uri, what)); };
    if (!folder.check(e.file.uri, static_cast<int64_t>(e.file.bytes), d)) return;
    format::BlockMap bm;
    if (Status st = format::decodeBlockMapFile(readBytes(folder.path(e.file.uri), 0, e.file.bytes), e.file.uri, &bm);
        !st.ok()) {
        d.push_back(st.error);
        return;
    }
    if (bm.nx != e.grid[0] || bm.ny != e.grid[1])
        bad(fmt::format("{} x {} cells, tileset.json says {} x {}", bm.nx, bm.ny, e.grid[0], e.grid[1]));
    if (!near(bm.cell_m, e.texel_m) || !near(bm.origin.x, e.origin.x) || !near(bm.origin.y, e.origin.y) ||
        !near(bm.origin.z, e.origin.z) || !near(bm.z_hi, e.z_top_m))
        bad("its grid (cell, origin, height range) is not the one tileset.json gives");
    if (bm.columns.size() != e.columns || bm.wall_width != e.wall_px[0] || bm.wall_height != e.wall_px[1])
        bad(fmt::format("{} columns in {} x {} wall texels, tileset.json says {} in {} x {}", bm.columns.size(),
                        bm.wall_width, bm.wall_height, e.columns, e.wall_px[0], e.wall_px[1]));
    if (bm.gpuBytes(!bm.roof.empty()) != e.gpu_bytes)
        bad(fmt::format("{} bytes on the GPU, tileset.json says {}", bm.gpuBytes(!bm.roof.empty()), e.gpu_bytes));
    if (bm.features.size() != e.features)
        bad(fmt::format("{} buildings, tileset.json says {}", bm.features.size(), e.features));
    if (!near(e.min_distance_m, n.min_distance_m))
        bad(fmt::format("min_distance_m {}, its node's is {}", e.min_distance_m, n.min_distance_m));
    std::set<uint32_t> held(bm.features.begin(), bm.features.end());
    for (const uint32_t f : bm.features)
        if (f >= static_cast<uint64_t>(ix.feature_count)) {
            bad(fmt::format("feature id {}, there are {} features", f, ix.feature_count));
            return;
        }
    for (const uint32_t f : e.features_missing)
        if (held.count(f)) {
            bad(fmt::format("feature {} is listed as missing but holds cells", f));
            return;
        }
    held.insert(e.features_missing.begin(), e.features_missing.end());
    *buildings = held;
    if (!geometry_decoded || n.layers.empty()) return;
    std::set<uint32_t> node_features = geometry_features;
    node_features.insert(n.dropped.begin(), n.dropped.end());
    if (held != node_features)
        bad(fmt::format("holds or lists as missing {} buildings, its node has {} (in its geometry or dropped)",
                        held.size(), node_features.size()));
}

void checkNodeFiles(const Node& n, const Index& ix, Folder& folder, Defects& d) {
    std::set<uint32_t> features;
    std::set<int64_t> blocks_used;
    bool decoded_all = true;
    const auto n_textures = static_cast<int64_t>(ix.texture_block.size());
    for (const Layer& l : n.layers) {
        const std::string& uri = l.geometry_uri;
        TileMesh m;
        if (!folder.check(uri, l.geometry_bytes, d)) {
            decoded_all = false;
        } else if (Status st = decodeTileGlb(readBytes(folder.path(uri), 0, uint64_t(l.geometry_bytes)), n.centre, &m);
                   !st.ok()) {
            d.push_back(fmt::format("{}: {}", uri, st.error));
            decoded_all = false;
        } else {
            auto bad = [&](const std::string& what) { d.push_back(fmt::format("{}: {}", uri, what)); };
            const auto tris = static_cast<int64_t>(m.indices.size() / 3);
            if (tris != l.triangles) bad(fmt::format("{} triangles, tileset.json says {}", tris, l.triangles));
            if (m.feature_id.empty()) bad(fmt::format("no feature ids ({})", kTileFeatureIdAttribute));
            auto outside = [](const auto& v, int64_t lo, int64_t hi) {
                return std::find_if(v.begin(), v.end(), [&](auto x) { return x < lo || x >= hi; });
            };
            if (auto it = outside(m.feature_id, 0, ix.feature_count); it != m.feature_id.end())
                bad(fmt::format("feature id {}, there are {} features", *it, ix.feature_count));
            if (auto it = outside(m.texture_id, -1, n_textures); it != m.texture_id.end())
                bad(fmt::format("texture id {}, there are {} textures", *it, n_textures));
            if (auto it = outside(m.material_id, -1, ix.materials); it != m.material_id.end())
                bad(fmt::format("material id {}, there are {} materials", *it, ix.materials));
            bool textured = false;
            for (int32_t t : m.texture_id)
                if (t >= 0 && t < n_textures) {
                    textured = true;
                    blocks_used.insert(ix.texture_block[static_cast<size_t>(t)]);
                }
            if (n.leaf && textured && m.uv_original.empty()) bad("textured triangles but no \"original\" uv set");
            if (l.has_atlas && m.uv_atlas.empty()) bad("an atlas but no \"atlas\" uv set");
            features.insert(m.feature_id.begin(), m.feature_id.end());
        }
        if (!l.has_atlas) continue;
        const int channels = l.name == "alpha" ? 4 : 3;
        auto bad = [&](const std::string& what) { d.push_back(fmt::format("{}: {}", l.atlas_uri, what)); };
        if (l.atlas_format != (channels == 4 ? "BC3" : "BC1"))
            bad(fmt::format("format {} in the {} layer", l.atlas_format, l.name));
        if (l.atlas_w % 4 || l.atlas_h % 4 || l.atlas_w < 4 || l.atlas_h < 4 || l.atlas_w > ix.atlas_size_px ||
            l.atlas_h > ix.atlas_size_px)
            bad(fmt::format("{}x{} texels: not whole 4x4 blocks within build.atlas_size_px {}", l.atlas_w, l.atlas_h,
                            ix.atlas_size_px));
        if (l.atlas_mips != fullMipCount(static_cast<int>(l.atlas_w), static_cast<int>(l.atlas_h)))
            bad(fmt::format("{} mips, not the full chain", l.atlas_mips));
        if (folder.check(l.atlas_uri, l.atlas_bytes, d))
            checkDds(folder.path(l.atlas_uri), l.atlas_uri, 0, "", channels, l.atlas_w, l.atlas_h, l.atlas_mips,
                     static_cast<uint64_t>(l.atlas_bytes), d);
        for (const format::ComputedFileEntry& c : l.computed)
            if (!c.file.uri.empty() && folder.check(c.file.uri, static_cast<int64_t>(c.file.bytes), d))
                checkDds(folder.path(c.file.uri), c.file.uri, 0, "", 1, c.width_px, c.height_px, c.mips, c.file.bytes, d);
    }
    std::set<uint32_t> in_blockmap;
    if (n.blockmap) checkBlockMap(n, *n.blockmap, ix, folder, features, decoded_all, d, &in_blockmap);
    if (!decoded_all) return;  // the comparisons below need every layer
    auto bad = [&](const std::string& what) { d.push_back(fmt::format("{}: {}", n.where(), what)); };
    // A node `--blockmaps replace` left to its BlockMap has its buildings as features.
    const char* from = "its geometry";
    if (n.layers.empty() && n.blockmap) features = in_blockmap, from = "its BlockMap";
    if (static_cast<int64_t>(features.size()) != n.feature_count)
        bad(fmt::format("features.count {}, {} has {} feature ids", n.feature_count, from, features.size()));
    std::set<int64_t> tables;
    for (uint32_t f : features) tables.insert(static_cast<int64_t>(f) / ix.block_size);
    if (tables != std::set<int64_t>(n.feature_tables.begin(), n.feature_tables.end()))
        bad(fmt::format("features.tables are not the tables of {}'s feature ids", from));
    for (int64_t f : n.dropped)
        if (f >= 0 && features.count(static_cast<uint32_t>(f))) {
            bad(fmt::format("feature {} is listed as dropped but is in its geometry", f));
            break;
        }
    // A leaf lists the blocks of the originals it needs: never a block none of
    // its textures is in, and with build.originals "all" every one they are in.
    const std::set<int64_t> listed(n.texture_blocks.begin(), n.texture_blocks.end());
    for (int64_t b : blocks_used)
        if (ix.all_originals && n.leaf && b >= 0 && !listed.count(b)) {
            bad(fmt::format("its textures are in block {}, which texture_blocks does not list", b));
            break;
        }
    for (int64_t b : listed)
        if (!blocks_used.count(b)) {
            bad(fmt::format("texture_blocks lists block {}, which holds none of its textures", b));
            break;
        }
}

// Runs check(i, defects) for i in [0, n) on the arena; the defects come back in
// index order. `entry` names item i in tileset.json.
void forEach(tbb::task_arena& arena, size_t n, const std::function<std::string(size_t)>& entry,
             const std::function<void(size_t, Defects&)>& check, Defects& out) {
    std::vector<Defects> per(n);
    arena.execute([&] {
        tbb::parallel_for(size_t{0}, n, [&](size_t i) {
            try {
                check(i, per[i]);
            } catch (const std::exception& e) {  // BadEntry, or bad_alloc on absurd sizes: never out of the checker
                per[i].push_back(fmt::format("tileset.json: {}: not checked further: {}", entry(i), e.what()));
            }
        });
    });
    for (Defects& d : per) out.insert(out.end(), d.begin(), d.end());
}

// --- Texture blocks and feature tables ---------------------------------------

// One texture block: its file, then the DDS files of `members` inside it, back to back.
void checkBlock(const json& entry, const json& textures, const std::vector<size_t>& members, bool layout,
                Folder& folder, std::atomic<uint64_t>& bytes_total, Defects& d) {
    const std::string uri = text(entry, "uri");
    const int64_t size = count(entry, "bytes");
    bytes_total += static_cast<uint64_t>(size);
    if (!folder.check(uri, size, d)) return;
    std::vector<std::tuple<int64_t, int64_t, size_t>> spans;  // offset, bytes, texture
    for (size_t t : members) spans.emplace_back(count(textures[t], "offset"), count(textures[t], "bytes"), t);
    std::sort(spans.begin(), spans.end());
    int64_t end = 0;
    for (const auto& [offset, bytes, t] : spans) {
        const json& e = textures[t];
        const std::string what = fmt::format("texture {} (offset {}, {} bytes): ", t, offset, bytes);
        if (offset > size || bytes > size - offset) {
            d.push_back(fmt::format("{}: {}outside the block of {} bytes", uri, what, size));
            continue;
        }
        if (offset != end && layout)
            d.push_back(fmt::format("{}: {}{} at byte {}", uri, what, offset < end ? "overlaps" : "a gap", end));
        end = std::max(end, offset + bytes);
        checkDds(folder.path(uri), uri, static_cast<uint64_t>(offset), what, text(e, "format") == "BC3" ? 4 : 3,
                 count(e, "width"), count(e, "height"), count(e, "mips"), static_cast<uint64_t>(bytes), d);
    }
    if (end < size && layout) d.push_back(fmt::format("{}: bytes {}..{} belong to no texture", uri, end, size));
}

// A feature table's bounds file (format/feature_bounds.h): one 32-byte record
// per feature of the table, known flags, and a box (min <= max) wherever the
// record says the feature has geometry.
void checkBounds(const json& entry, int64_t features, Folder& folder, std::atomic<uint64_t>& bytes_total, Defects& d) {
    const std::string uri = text(entry, "uri");
    const int64_t size = count(entry, "bytes");
    bytes_total += static_cast<uint64_t>(size);
    if (!folder.check(uri, size, d)) return;
    if (size != features * static_cast<int64_t>(format::kFeatureBoundsBytes)) {
        d.push_back(fmt::format("{}: {} bytes, {} features need {}", uri, size, features,
                                features * static_cast<int64_t>(format::kFeatureBoundsBytes)));
        return;
    }
    std::ifstream f(folder.path(uri), std::ios::binary);
    std::vector<uint8_t> bytes(static_cast<size_t>(size));
    if (!f.read(reinterpret_cast<char*>(bytes.data()), size)) {
        d.push_back(fmt::format("{}: cannot read", uri));
        return;
    }
    std::vector<format::FeatureBoundsRecord> records;
    if (Status s = format::decodeFeatureBounds(bytes, uri, &records); !s.ok()) {
        d.push_back(s.error);
        return;
    }
    for (size_t i = 0; i < records.size(); ++i) {
        const format::FeatureBoundsRecord& r = records[i];
        if (!(r.flags & format::FeatureBoundsRecord::kHasGeometry)) continue;
        for (int a = 0; a < 3; ++a)
            if (!(r.min[a] <= r.max[a])) {  // also NaN
                d.push_back(fmt::format("{}: record {} has min {} above max {} on axis {}", uri, i, r.min[a], r.max[a], a));
                return;
            }
    }
}

// Feature table k: ids k * block_size on, as many as the count leaves for it.
void checkTable(const json& entry, size_t k, const Index& ix, Folder& folder, std::atomic<uint64_t>& bytes_total,
                Defects& d) {
    const std::string uri = text(entry, "uri");
    const int64_t size = count(entry, "bytes");
    bytes_total += static_cast<uint64_t>(size);
    if (const json* bounds = entry.is_object() && entry.contains("bounds") ? &entry.at("bounds") : nullptr) {
        const auto first = static_cast<int64_t>(k) * ix.block_size;
        checkBounds(*bounds, std::clamp<int64_t>(ix.feature_count - first, 0, ix.block_size), folder, bytes_total, d);
    }
    if (!folder.check(uri, size, d)) return;
    json t;
    try {
        std::ifstream f(folder.path(uri), std::ios::binary);
        t = json::parse(f);
    } catch (const std::exception& e) {
        d.push_back(fmt::format("{}: not valid JSON: {}", uri, e.what()));
        return;
    }
    try {
        const auto first = static_cast<int64_t>(k) * ix.block_size;
        const int64_t want = std::clamp<int64_t>(ix.feature_count - first, 0, ix.block_size);
        const json& list = arrayOf(t, "features");
        if (count(t, "first") != first || static_cast<int64_t>(list.size()) != want) {
            d.push_back(fmt::format("{}: holds {} features from id {}, expected {} from {}", uri, list.size(),
                                    count(t, "first"), want, first));
            return;
        }
        for (size_t i = 0; i < list.size(); ++i)
            if (const int64_t id = count(list[i], "id"); id != first + static_cast<int64_t>(i)) {
                d.push_back(fmt::format("{}: features[{}] has id {}, expected {}", uri, i, id, first + int64_t(i)));
                return;
            }
    } catch (const BadEntry& e) {
        d.push_back(fmt::format("{}: not a feature table: {}", uri, e.what()));
    }
}

// Levels and sums, from the index (the checks hold the index against the files).
void summarise(const std::vector<Node>& nodes, InspectResult& r) {
    for (const Node& n : nodes) {
        if (!n.usable) continue;
        const auto level = static_cast<size_t>(std::min<int64_t>(n.level, kMaxNesting));
        if (r.levels.size() <= level) r.levels.resize(level + 1);
        InspectLevel& L = r.levels[level];
        L.world_texel_min_m = L.nodes ? std::min(L.world_texel_min_m, n.world_texel_m) : n.world_texel_m;
        L.world_texel_max_m = std::max(L.world_texel_max_m, n.world_texel_m);
        L.min_distance_m = std::max(L.min_distance_m, n.min_distance_m);
        ++L.nodes;
        L.leaves += n.leaf ? 1 : 0;
        for (const Layer& l : n.layers) {
            L.triangles += static_cast<uint64_t>(l.triangles);
            L.bytes_geometry += static_cast<uint64_t>(l.geometry_bytes);
            L.bytes_atlases += l.has_atlas ? static_cast<uint64_t>(l.atlas_bytes) : 0;
            ++r.geometry_files;
            r.atlas_files += l.has_atlas ? 1 : 0;
            for (const format::ComputedFileEntry& c : l.computed)
                if (!c.file.uri.empty()) ++r.computed_files, r.bytes_computed += c.file.bytes;
        }
        if (n.blockmap) ++r.blockmap_files, r.bytes_blockmaps += n.blockmap->file.bytes;
    }
    for (const InspectLevel& L : r.levels) {
        r.nodes += L.nodes;
        r.leaves += L.leaves;
        r.triangles += L.triangles;
        r.bytes_geometry += L.bytes_geometry;
        r.bytes_atlases += L.bytes_atlases;
    }
}

}  // namespace

// The folder as the client reads it (format/tileset_index.h) must say what
// this checker found: a folder inspect passes and the client refuses, or
// reads differently, is a defect of one of the two readers.
void checkAgainstClientModel(const fs::path& folder, const InspectResult& r, Defects& d) {
    std::ifstream f(folder / "tileset.json", std::ios::binary);
    const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    format::TilesetIndex index;
    if (Status st = format::parseTilesetIndex(text, "tileset.json", &index); !st.ok()) {
        d.push_back(fmt::format("tileset.json: the client's reader refuses it: {}", st.error));
        return;
    }
    auto same = [&](const char* what, uint64_t client, uint64_t here) {
        if (client != here)
            d.push_back(fmt::format("tileset.json: the client's reader finds {} {}, inspect {}", client, what, here));
    };
    same("nodes", index.nodes.size(), r.nodes);
    same("texture entries", index.textures.size(), r.textures);
    same("texture blocks", index.texture_block_ids.size(), r.texture_blocks);
    same("features", index.feature_count, r.features);
    same("feature tables", index.feature_tables.size(), r.feature_tables);
    same("geometry bytes", index.bytes_by_kind[static_cast<int>(format::BlockKind::Geometry)], r.bytes_geometry);
    same("atlas bytes", index.bytes_by_kind[static_cast<int>(format::BlockKind::Atlas)], r.bytes_atlases);
    same("texture block bytes", index.bytes_by_kind[static_cast<int>(format::BlockKind::Textures)], r.bytes_textures);
}

InspectResult inspectTileFolder(const fs::path& folder, int threads) {
    InspectResult r;
    Defects& d = r.defects;
    Folder files(folder);
    json ts;
    std::error_code ec;
    if (!fs::exists(folder / "tileset.json", ec)) {
        d.push_back(fmt::format("tileset.json: missing in {}: not a cityatlas tile folder", folder.string()));
        return r;
    }
    if (!files.check("tileset.json", -1, d)) return r;
    try {
        std::ifstream f(folder / "tileset.json", std::ios::binary);
        ts = json::parse(f);
    } catch (const std::exception& e) {
        d.push_back(fmt::format("tileset.json: not valid JSON: {}", e.what()));
        return r;
    }
    if (boundDocument(ts) > kMaxNesting) {
        d.push_back(fmt::format("tileset.json: nested deeper than {} levels", kMaxNesting));
        return r;
    }
    validateSchema(ts, d);

    // The tables of the index; without them nothing else can be checked.
    Index ix;
    const json *ca = nullptr, *textures = nullptr, *blocks = nullptr, *tables = nullptr;
    try {
        ca = &member(member(ts, "extras"), "cityatlas");
        const json& build = member(*ca, "build");
        ix.focal_px = number(build, "focal_px");
        ix.corner_factor = number(build, "corner_factor");
        ix.d_min_m = number(build, "d_min_m");
        ix.atlas_size_px = count(build, "atlas_size_px");
        ix.all_originals = build.contains("originals") && build["originals"] == "all";
        if (build.contains("blockmaps") && build["blockmaps"].is_string()) ix.blockmaps = build["blockmaps"];
        ix.materials = static_cast<int64_t>(arrayOf(*ca, "materials").size());
        const json& features = member(*ca, "features");
        ix.feature_count = count(features, "count");
        ix.block_size = std::max<int64_t>(1, count(features, "block_size"));
        tables = &arrayOf(features, "tables");
        blocks = &arrayOf(*ca, "texture_blocks");
        textures = &arrayOf(*ca, "textures");
        ix.tables = tables->size();
        ix.blocks = blocks->size();
        if (!(ix.focal_px > 0 && ix.corner_factor > 0)) throw BadEntry("focal_px or corner_factor not positive");
        if (ca->contains("computed"))
            for (const json& c : arrayOf(*ca, "computed")) {
                r.computed.push_back(text(c, "name"));
                ix.computed_scale.push_back(std::max<int64_t>(1, count(c, "scale")));
                ix.computed_bytes.push_back(static_cast<uint64_t>(count(c, "bytes")));
                const json& st = member(c, "statistics");
                const json& range = member(c, "range");
                if (count(st, "texels") > 0) {
                    const double lo = number(st, "min"), mean = number(st, "mean"), hi = number(st, "max");
                    const double r0 = numberOf(range.at(0), "range"), r1 = numberOf(range.at(1), "range");
                    if (!(r0 <= lo && lo <= mean + 1e-9 && mean <= hi + 1e-9 && hi <= r1))
                        d.push_back(fmt::format("tileset.json: /extras/cityatlas/computed: {} statistics min {} mean {} max "
                                                "{} not ordered within its range [{}, {}]",
                                                text(c, "name"), lo, mean, hi, r0, r1));
                }
            }
    } catch (const BadEntry& e) {
        d.push_back(fmt::format("tileset.json: /extras/cityatlas unusable ({}); nothing further checked", e.what()));
        return r;
    }
    try {
        // Twice the root's, or the root's where its layers' error raised it above that.
        const double root_error = number(member(ts, "root"), "geometricError");
        const double root_base =
            number(member(member(member(ts, "root"), "extras"), "cityatlas"), "min_distance_m") / ix.focal_px;
        if (!near(number(ts, "geometricError"), std::max(2 * root_base, root_error)))
            d.push_back("tileset.json: /geometricError: not twice the root's min_distance_m / focal_px (nor the root's "
                        "where that is more)");
        // The root's transform is local_to_ecef (absent when not georeferenced); no other tile has one.
        const json& to_ecef = member(member(*ca, "georeference"), "local_to_ecef");
        const json& root = member(ts, "root");
        const bool has = root.contains("transform");
        if (to_ecef.is_null() ? has : !has || root["transform"] != to_ecef)
            d.push_back("tileset.json: /root/transform: not georeference.local_to_ecef");
    } catch (const BadEntry& e) {
        d.push_back(fmt::format("tileset.json: /: geometricError and transform not compared: {}", e.what()));
    }
    for (size_t t = 0; t < textures->size(); ++t) {
        int64_t b = -2;
        try {
            b = integer((*textures)[t], "block");
        } catch (const BadEntry&) {  // the schema error says why
        }
        ix.texture_block.push_back(b);
        if (b == -2)
            d.push_back(fmt::format("tileset.json: /extras/cityatlas/textures/{}: no usable block", t));
        else if (b >= static_cast<int64_t>(ix.blocks) || b < -1)
            d.push_back(fmt::format("tileset.json: /extras/cityatlas/textures/{}: block {} does not exist", t, b));
        try {
            const json& e = (*textures)[t];
            const std::string original = text(e, "original");
            if ((original == "written") != (b >= 0))
                d.push_back(fmt::format("tileset.json: /extras/cityatlas/textures/{}: original '{}' with block {}", t,
                                        original, b));
            r.textures_exact += original == "exact" ? 1 : 0;
            r.textures_unreadable += original == "unreadable" ? 1 : 0;
            r.bytes_originals_bc += atlas::bcBytesWithMips(static_cast<int>(count(e, "width")),
                                                           static_cast<int>(count(e, "height")),
                                                           text(e, "format") == "BC3" ? 4 : 3);
        } catch (const BadEntry&) {  // the schema error says why
        }
    }

    std::vector<Node> nodes;
    static const json kNoTile;
    readTree(ts.contains("root") ? static_cast<const json&>(ts["root"]) : kNoTile, "/root", -1, nodes, d);
    checkTree(nodes, ix, d);
    checkReplaced(nodes, ix, folder, d);
    std::map<std::string, int> uses;
    for (const Node& n : nodes)
        for (const Layer& l : n.layers)
            for (const std::string* u : {&l.geometry_uri, l.has_atlas ? &l.atlas_uri : nullptr})
                if (u && ++uses[*u] == 2) d.push_back(fmt::format("{}: named by more than one entry", *u));

    // Every node's files in parallel (Draco decoding is most of the time), then blocks and tables.
    tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
    forEach(
        arena, nodes.size(), [&](size_t i) { return nodes[i].pointer; },
        [&](size_t i, Defects& out) {
            if (nodes[i].usable) checkNodeFiles(nodes[i], ix, files, out);
        },
        d);
    std::vector<std::vector<size_t>> members(ix.blocks);
    for (size_t t = 0; t < ix.texture_block.size(); ++t)
        if (ix.texture_block[t] >= 0 && ix.texture_block[t] < static_cast<int64_t>(ix.blocks))
            members[static_cast<size_t>(ix.texture_block[t])].push_back(t);
    // With an unreadable texture entry the layout of the blocks cannot be compared.
    const bool layout = std::count(ix.texture_block.begin(), ix.texture_block.end(), int64_t{-2}) == 0;
    std::atomic<uint64_t> block_bytes{0}, table_bytes{0};
    forEach(
        arena, ix.blocks, [](size_t b) { return fmt::format("/extras/cityatlas/texture_blocks/{}", b); },
        [&](size_t b, Defects& out) {
            checkBlock((*blocks)[b], *textures, members[b], layout, files, block_bytes, out);
        },
        d);
    if (ix.tables != static_cast<size_t>((ix.feature_count + ix.block_size - 1) / ix.block_size))
        d.push_back(fmt::format("tileset.json: /extras/cityatlas/features: {} tables for {} features in blocks of {}",
                                ix.tables, ix.feature_count, ix.block_size));
    forEach(
        arena, ix.tables, [](size_t k) { return fmt::format("/extras/cityatlas/features/tables/{}", k); },
        [&](size_t k, Defects& out) { checkTable((*tables)[k], k, ix, files, table_bytes, out); }, d);

    summarise(nodes, r);
    r.bytes_textures = block_bytes;
    r.bytes_features = table_bytes;
    r.textures = ix.texture_block.size();
    r.texture_blocks = ix.blocks;
    r.feature_tables = ix.tables;
    r.features = static_cast<uint64_t>(ix.feature_count);
    try {
        const json& totals = member(*ca, "totals");
        const json& bytes = member(totals, "bytes");
        auto total = [&](const char* what, uint64_t found, int64_t claimed) {
            if (static_cast<int64_t>(found) != claimed)
                d.push_back(fmt::format("tileset.json: /extras/cityatlas/totals/{}: {}, the index adds up to {}", what,
                                        claimed, found));
        };
        total("nodes", nodes.size(), count(totals, "nodes"));
        // Sums over a tree with unreadable tiles would only repeat their defects.
        if (std::all_of(nodes.begin(), nodes.end(), [](const Node& n) { return n.usable; })) {
            total("leaves", r.leaves, count(totals, "leaves"));
            total("depth", r.levels.empty() ? 0 : r.levels.size() - 1, count(totals, "depth"));
            total("bytes/geometry", r.bytes_geometry, count(bytes, "geometry"));
            total("bytes/atlases", r.bytes_atlases, count(bytes, "atlases"));
        }
        total("bytes/textures", r.bytes_textures, count(bytes, "textures"));
        total("bytes/features", r.bytes_features, count(bytes, "features"));
        total("bytes/originals_as_bc", r.bytes_originals_bc, count(bytes, "originals_as_bc"));
        total("bytes/blockmaps", r.bytes_blockmaps, bytes.contains("blockmaps") ? count(bytes, "blockmaps") : 0);
        if (r.bytes_originals_bc > 0)
            r.texture_ratio = static_cast<double>(r.bytes_atlases + r.bytes_textures) / static_cast<double>(r.bytes_originals_bc);
        if (!near(number(totals, "texture_ratio"), r.texture_ratio))
            d.push_back(fmt::format("tileset.json: /extras/cityatlas/totals/texture_ratio: {}, the index gives {}",
                                    number(totals, "texture_ratio"), r.texture_ratio));
    } catch (const BadEntry& e) {
        d.push_back(fmt::format("tileset.json: /extras/cityatlas/totals: {}", e.what()));
    }
    if (d.empty()) checkAgainstClientModel(folder, r, d);
    r.files_checked = files.files_checked;
    return r;
}

}  // namespace cityatlas::tiles
