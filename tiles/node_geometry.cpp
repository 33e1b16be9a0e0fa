// SPDX-License-Identifier: GPL-3.0-or-later
#include "tiles/node_geometry.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <unordered_set>

#include "tiles/simplify.h"
#include "tiles/texture_tiles.h"

namespace cityatlas::tiles {
namespace {

// One vertex with every attribute; welding merges exact duplicates only.
struct Vertex {
    Vec3d position;
    Vec2d uv_original, uv_atlas;
    uint32_t feature = 0;
    int32_t texture = -1, material = -1;
    bool operator==(const Vertex&) const = default;
};

struct VertexHash {
    size_t operator()(const Vertex& v) const {
        auto mix = [](uint64_t h, double x) {
            const uint64_t b = std::bit_cast<uint64_t>(x == 0.0 ? 0.0 : x);  // +0 and -0 compare equal
            return (h ^ b) * 0x100000001B3ull + (h >> 29);
        };
        uint64_t h = 0xCBF29CE484222325ull;
        for (double x : {v.position.x, v.position.y, v.position.z, v.uv_original.x, v.uv_original.y, v.uv_atlas.x,
                         v.uv_atlas.y})
            h = mix(h, x);
        h = mix(h, static_cast<double>(v.feature));
        h = mix(h, static_cast<double>(v.texture) * 65536.0 + static_cast<double>(v.material));
        return static_cast<size_t>(h ^ (h >> 31));
    }
};

// Accumulates triangles into a welded TileMesh. The weld table is open
// addressing over vertex numbers (4 bytes a slot, at most half full) and
// compares against the mesh's own arrays: the merges near the root weld
// millions of vertices, and a node-based map cost ~100 bytes each on top.
class MeshBuilder {
public:
    explicit MeshBuilder(bool with_original_uv) : with_original_uv_(with_original_uv) {}

    void add(const std::array<Vertex, 3>& tri) {
        for (const Vertex& v : tri) mesh_.indices.push_back(index(v));
    }
    // Without the capacity push_back left (up to half of each array): a
    // node's mesh waits for its siblings' before its parent merges them.
    TileMesh take() {
        std::vector<uint32_t>().swap(slots_);
        mesh_.positions.shrink_to_fit();
        mesh_.uv_original.shrink_to_fit();
        mesh_.uv_atlas.shrink_to_fit();
        mesh_.feature_id.shrink_to_fit();
        mesh_.indices.shrink_to_fit();
        mesh_.texture_id.shrink_to_fit();
        mesh_.material_id.shrink_to_fit();
        return std::move(mesh_);
    }

private:
    static constexpr uint32_t kEmpty = UINT32_MAX;

    Vertex stored(uint32_t i) const {
        Vertex v;
        v.position = mesh_.positions[i];
        if (with_original_uv_) v.uv_original = mesh_.uv_original[i];
        v.uv_atlas = mesh_.uv_atlas[i];
        v.feature = mesh_.feature_id[i];
        v.texture = mesh_.texture_id[i];
        v.material = mesh_.material_id[i];
        return v;
    }
    void grow() {
        std::vector<uint32_t> old;
        old.swap(slots_);
        slots_.assign(std::max<size_t>(64, old.size() * 2), kEmpty);
        for (uint32_t i : old)
            if (i != kEmpty) slots_[free_slot(VertexHash{}(stored(i)))] = i;
    }
    size_t free_slot(size_t h) const {
        const size_t mask = slots_.size() - 1;
        for (size_t k = h & mask;; k = (k + 1) & mask)
            if (slots_[k] == kEmpty) return k;
    }
    uint32_t index(Vertex v) {
        if (!with_original_uv_) v.uv_original = {};  // not stored, so not part of the key
        if (2 * (mesh_.positions.size() + 1) > slots_.size()) grow();
        const size_t mask = slots_.size() - 1;
        size_t k = VertexHash{}(v) & mask;
        for (; slots_[k] != kEmpty; k = (k + 1) & mask)
            if (stored(slots_[k]) == v) return slots_[k];
        const auto i = static_cast<uint32_t>(mesh_.positions.size());
        slots_[k] = i;
        mesh_.positions.push_back(v.position);
        mesh_.uv_atlas.push_back(v.uv_atlas);
        if (with_original_uv_) mesh_.uv_original.push_back(v.uv_original);
        mesh_.feature_id.push_back(v.feature);
        mesh_.texture_id.push_back(v.texture);
        mesh_.material_id.push_back(v.material);
        return i;
    }

    bool with_original_uv_;
    TileMesh mesh_;
    std::vector<uint32_t> slots_;  // vertex numbers; kEmpty where free
};

Vertex vertexOf(const TileMesh& m, uint32_t i) {
    Vertex v;
    v.position = m.positions[i];
    if (!m.uv_original.empty()) v.uv_original = m.uv_original[i];
    v.uv_atlas = m.uv_atlas[i];
    v.feature = m.feature_id[i];
    v.texture = m.texture_id[i];
    v.material = m.material_id[i];
    return v;
}

// What a merge to simplify holds while it runs, per triangle merged: the
// merged mesh, the simplifier's arrays, two meshoptimizer runs side by side,
// the compacted result and its encoding (heaptrack, the 100,000-building
// town's root at the default d_min: ~1 GB for ~2.1 M triangles merged).
constexpr size_t kMergeBytesPerTriangle = 480;
// Such merges run side by side only while their estimates add up to at most
// this; a larger one runs alone. Near the top of a large city several are
// ready at once (400,000 buildings at the default d_min: the level-1 merges,
// ~2 M triangles each: two at once took the merge to 1.54-1.73 GB).
constexpr size_t kMergeBudgetBytes = size_t{1} << 30;
// The cap on one merge (node_geometry.h): 2^21 triangles take ~1.0 GB
// (0.94 GiB) at the estimate above, within the gate's budget.
constexpr size_t kMergeBudgetsAtMost = 64;
constexpr size_t kMergeTrianglesAtMost = size_t{1} << 21;

size_t incomingTriangles(const std::array<std::unique_ptr<NodeGeometry>, 4>& children) {
    size_t n = 0;
    for (const auto& c : children)
        if (c) n += c->mesh.indices.size() / 3;
    return n;
}

// Whole buildings to leave out of a merge of these children above `cap`
// triangles, before it is built: smallest first, whatever their size
// (featuresToLeaveOut without a size limit). A triangle is its first
// corner's feature's, as in the simplifier; extents over every corner.
std::unordered_set<uint32_t> featuresOverTheCap(const std::array<std::unique_ptr<NodeGeometry>, 4>& children,
                                                size_t cap, double* largest_diagonal_m) {
    std::unordered_map<uint32_t, Box3d> extent;
    std::unordered_map<uint32_t, size_t> drawn;
    for (const auto& c : children) {
        if (!c) continue;
        const TileMesh& m = c->mesh;
        for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
            ++drawn[m.feature_id[m.indices[t]]];
            for (size_t k = 0; k < 3; ++k) extent[m.feature_id[m.indices[t + k]]].extend(m.positions[m.indices[t + k]]);
        }
    }
    return featuresToLeaveOut(extent, drawn, std::numeric_limits<double>::infinity(), cap, largest_diagonal_m);
}

// Only referenced vertices, in first-reference order.
TileMesh compactMesh(const TileMesh& in, const std::vector<uint32_t>& indices) {
    MeshBuilder b(!in.uv_original.empty());
    for (size_t t = 0; t + 2 < indices.size(); t += 3)
        b.add({vertexOf(in, indices[t]), vertexOf(in, indices[t + 1]), vertexOf(in, indices[t + 2])});
    return b.take();
}

}  // namespace

NodeGeometry leafGeometry(const Scene& scene, const atlas::AtlasTree& tree, int32_t node, atlas::Layer layer,
                          const TextureIndex& texture_index, bool split) {
    const atlas::AtlasNode& n = tree.nodes[static_cast<size_t>(node)];
    const atlas::NodeLayer& nl = n.layers[static_cast<size_t>(layer)];
    const atlas::TriangleRange range = nl.range;
    MeshBuilder b(true);
    std::vector<TilePiece> pieces;
    for (uint32_t i = range.first; i < range.first + range.count; ++i) {
        const atlas::TreeTriangle& tt = tree.triangles[i];
        const Triangle& t = tt.tri;
        const bool textured = t.texture >= 0;
        auto atlasUv = [&](int k) {
            return nl.localFromRoot(tt.atlas_uv[static_cast<size_t>(k)], n.level, tree.params.atlas_size_px);
        };
        // A split texture (texture_blocks.h): the triangle cut at its tile
        // lines, each piece naming its tile in the tile's own coordinates.
        // (A triangle repeating it over two periods or more keeps the whole texture, below.)
        pieces.clear();
        if (const TileGrid grid = textured ? splitGridOf(scene.textures[static_cast<size_t>(t.texture)],
                                                         tree.params.atlas_size_px, split)
                                           : TileGrid{};
            grid.count() > 0 &&
            clipToTiles(grid, {ClipVertex{t.position_local[0], t.uv[0], atlasUv(0)}, ClipVertex{t.position_local[1], t.uv[1], atlasUv(1)},
                               ClipVertex{t.position_local[2], t.uv[2], atlasUv(2)}},
                        &pieces)) {
            for (const TilePiece& p : pieces) {
                std::array<Vertex, 3> tri;
                for (size_t k = 0; k < 3; ++k) {
                    tri[k].position = p.corners[k].position;
                    tri[k].feature = t.feature;
                    tri[k].material = -1;
                    tri[k].texture = texture_index[static_cast<size_t>(t.texture)] + 1 + p.tile;
                    tri[k].uv_original = p.corners[k].uv;
                    tri[k].uv_atlas = p.corners[k].uv_atlas;
                }
                b.add(tri);
            }
            continue;
        }
        // Whole periods of a repeating texture change nothing under GL_REPEAT;
        // shifting each triangle's uvs next to 0 keeps the quantization range
        // at the largest triangle's span instead of the largest repeat count.
        Vec2d shift;
        if (textured && scene.textures[static_cast<size_t>(t.texture)].wrap == WrapMode::Wrap) {
            shift = {std::floor(std::min({t.uv[0].x, t.uv[1].x, t.uv[2].x})),
                     std::floor(std::min({t.uv[0].y, t.uv[1].y, t.uv[2].y}))};
        }
        std::array<Vertex, 3> tri;
        for (int k = 0; k < 3; ++k) {
            Vertex& v = tri[static_cast<size_t>(k)];
            v.position = t.position_local[static_cast<size_t>(k)];
            v.feature = t.feature;
            // The material colours untextured surfaces only (Scene::Triangle); a
            // textured vertex says -1, so a renderer needs no texture id to choose.
            v.material = textured ? -1 : t.material;
            if (textured) {
                v.texture = texture_index[static_cast<size_t>(t.texture)];
                v.uv_original = {t.uv[static_cast<size_t>(k)].x - shift.x, t.uv[static_cast<size_t>(k)].y - shift.y};
                v.uv_atlas = atlasUv(k);
            }
        }
        b.add(tri);
    }
    NodeGeometry g;
    g.mesh = b.take();
    g.triangles_source = range.count;
    return g;
}

size_t mergeMaxTriangles(size_t budget) {
    return std::max(budget, std::min(budget * kMergeBudgetsAtMost, kMergeTrianglesAtMost));
}

size_t mergeEstimateBytes(const std::array<std::unique_ptr<NodeGeometry>, 4>& children, size_t budget) {
    const size_t incoming = incomingTriangles(children);
    return incoming <= budget ? 0 : std::min(incoming, mergeMaxTriangles(budget)) * kMergeBytesPerTriangle;
}

MemoryGate& mergeGate() {
    static MemoryGate gate(kMergeBudgetBytes);
    return gate;
}

NodeGeometry innerGeometry(const atlas::AtlasTree& tree, int32_t node, atlas::Layer layer,
                           std::array<std::unique_ptr<NodeGeometry>, 4> children, size_t budget, double world_texel_m) {
    const atlas::AtlasNode& n = tree.nodes[static_cast<size_t>(node)];
    NodeGeometry g;
    std::unordered_set<uint32_t> left_out;
    double left_out_diagonal_m = 0;
    if (incomingTriangles(children) > mergeMaxTriangles(budget))
        left_out = featuresOverTheCap(children, mergeMaxTriangles(budget), &left_out_diagonal_m);
    g.left_out_over_cap = left_out.size();
    MeshBuilder b(false);
    double child_error = 0;
    size_t merged = 0;
    for (size_t q = 0; q < 4; ++q) {
        const NodeGeometry* c = children[q].get();
        if (c == nullptr || c->empty()) continue;
        const atlas::AtlasNode& cn = tree.nodes[static_cast<size_t>(n.children[q])];
        const atlas::NodeLayer& pl = n.layers[static_cast<size_t>(layer)];
        const atlas::NodeLayer& cl = cn.layers[static_cast<size_t>(layer)];
        g.triangles_source += c->triangles_source;
        child_error = std::max(child_error, c->geometric_error_m);
        // child texel = root * A * 2^(k+1) - offset_c, so the parent's texel is
        // (child texel + offset_c) / 2 - offset_p (atlas/atlas_tree.h).
        auto toParent = [&](const Vec2d& uv) {
            const double cx = uv.x * cl.width + static_cast<double>(cl.offset[0]);
            const double cy = uv.y * cl.height + static_cast<double>(cl.offset[1]);
            return Vec2d{(cx * 0.5 - static_cast<double>(pl.offset[0])) / pl.width,
                         (cy * 0.5 - static_cast<double>(pl.offset[1])) / pl.height};
        };
        const TileMesh& m = c->mesh;
        for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
            if (!left_out.empty() && left_out.count(m.feature_id[m.indices[t]])) continue;
            ++merged;
            std::array<Vertex, 3> tri;
            for (size_t k = 0; k < 3; ++k) {
                tri[k] = vertexOf(m, m.indices[t + k]);
                tri[k].uv_original = {};
                if (tri[k].texture >= 0) tri[k].uv_atlas = toParent(tri[k].uv_atlas);
            }
            b.add(tri);
        }
        children[q].reset();
    }
    g.mesh = b.take();
    // A building left out over the cap is missing here: its error is its size.
    g.geometric_error_m = std::max(child_error, left_out_diagonal_m);
    if (merged <= budget || g.mesh.indices.empty()) return g;

    // The mesh's own arrays are lent to the simplifier, not copied (the
    // merges near the root are the build's largest meshes), and come back.
    SimplifyInput in;
    in.positions = std::move(g.mesh.positions);
    in.indices = std::move(g.mesh.indices);
    in.feature_id = std::move(g.mesh.feature_id);
    in.keep_attribute_seams = true;  // corners keep their atlas uvs and ids
    // Above the budget, buildings smaller than a texel go (below a pixel
    // wherever this node is drawn), smallest first.
    in.drop_features_below_m = world_texel_m;
    const double bound = std::max(0.0, world_texel_m - child_error);
    const SimplifyResult r = simplifyMesh(in, budget, bound);
    g.mesh.positions = std::move(in.positions);
    g.mesh.indices = std::move(in.indices);
    g.mesh.feature_id = std::move(in.feature_id);
    if (r.triangles_out < r.triangles_in) {
        g.mesh = compactMesh(g.mesh, r.indices);
        g.simplified = true;
    }
    // A left-out building's error is its size; the drawn ones' add up along the path.
    g.geometric_error_m = std::max({child_error + r.geometric_error_m, r.left_out_diagonal_m, left_out_diagonal_m});
    return g;
}

std::vector<uint32_t> distinctFeatures(const TileMesh& mesh) {
    std::vector<uint32_t> f;
    f.reserve(mesh.indices.size());
    for (uint32_t i : mesh.indices) f.push_back(mesh.feature_id[i]);
    std::sort(f.begin(), f.end());
    f.erase(std::unique(f.begin(), f.end()), f.end());
    return f;
}

}  // namespace cityatlas::tiles
