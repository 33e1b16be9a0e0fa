// SPDX-License-Identifier: GPL-3.0-or-later
#include "render/core/selection.h"

#include <algorithm>
#include <cmath>
#include <tuple>

namespace cityatlas::render {
namespace {

double farthestCorner(const Vec3d& p, const Box3d& b) {
    const double dx = std::max(std::abs(p.x - b.min.x), std::abs(p.x - b.max.x));
    const double dy = std::max(std::abs(p.y - b.min.y), std::abs(p.y - b.max.y));
    const double dz = std::max(std::abs(p.z - b.min.z), std::abs(p.z - b.max.z));
    return std::sqrt(dx * dx + dy * dy + dz * dz);
}

// The sort key within a usage category.
double priorityKey(const Box3d& bounds, double distance, const Camera& camera, PriorityMode mode) {
    if (mode == PriorityMode::Distance) return distance;
    const Vec3d centre = 0.5 * (bounds.min + bounds.max);
    const Vec3d to = centre - camera.position;
    const double l = length(to);
    if (l < 1e-9) return 0;
    const double cosine = dot((1.0 / l) * to, normalized(camera.direction));
    return distance * (1.0 - cosine);
}

// The node is drawn by its BlockMap at distance d (scale: distanceScale).
bool atBlockMapDistance(const TileNode& n, const SelectionParams& params, double d, double scale) {
    return drawsBlockMap(n, params.blockmaps) && d >= n.blockmap_min_distance_m * scale;
}

// A leaf's texture blocks with the box each is sampled over; false while
// that is not known (a layer's geometry not decoded yet).
bool leafBlockBoxes(const TileNode& n, const SelectionParams& params, std::vector<BlockBox>* out) {
    out->clear();
    if (params.texture_use == nullptr) return false;
    for (const NodeLayer& l : n.layers) {
        if (!l.present) continue;
        if (l.geometry >= params.texture_use->size() || !(*params.texture_use)[l.geometry].known) return false;
        for (const BlockBox& b : (*params.texture_use)[l.geometry].boxes) {
            // Only the blocks tileset.json lists for the leaf, whatever the mesh says.
            if (std::find(n.texture_blocks.begin(), n.texture_blocks.end(), b.block) == n.texture_blocks.end()) continue;
            const auto same = std::find_if(out->begin(), out->end(), [&](const BlockBox& o) { return o.block == b.block; });
            if (same == out->end()) {
                out->push_back(b);
            } else {
                same->bounds.extend(b.bounds.min);
                same->bounds.extend(b.bounds.max);
            }
        }
    }
    return true;
}

// How a leaf drawn with originals uses a texture block sampled over `box`,
// `threshold` being the leaf's scaled min distance: Needed on screen and
// closer than it (the atlas is not sharp enough there), Parent needed up to
// twice it (the next octave, prefetched as an inner node's children are),
// Culled off screen, Unused beyond.
Usage blockUse(const Box3d& box, const Frustum& frustum, const Vec3d& eye, double threshold, double* distance) {
    *distance = distanceToBox(eye, box);
    if (outsideFrustum(frustum, box)) return Usage::Culled;
    if (*distance < threshold) return Usage::Needed;
    return *distance < 2 * threshold ? Usage::ParentNeeded : Usage::Unused;
}

}  // namespace

const char* usageName(Usage usage) {
    switch (usage) {
        case Usage::Needed: return "needed";
        case Usage::Culled: return "culled";
        case Usage::ParentNeeded: return "parent_needed";
        case Usage::Unused: return "unused";
    }
    return "?";
}

const char* priorityModeName(PriorityMode mode) { return mode == PriorityMode::ViewWeighted ? "view" : "distance"; }

double distanceScale(const BuildInfo& build, const Camera& camera, const SelectionParams& params) {
    const double viewport = camera.focalPx() * camera.cornerFactor();
    const double assumed = build.focal_px * build.corner_factor;
    return viewport / assumed * build.tau / params.tau;
}

bool before(const BlockPriority& pa, BlockId a, const BlockPriority& pb, BlockId b) {
    return std::tie(pa.usage, pa.key, pa.level, a) < std::tie(pb.usage, pb.key, pb.level, b);
}

Classification classifyBlocks(const TilesetIndex& index, const Camera& camera, const SelectionParams& params) {
    Classification c;
    c.priority.assign(index.blocks.size(), BlockPriority{});
    if (index.nodes.empty()) return c;
    const Frustum frustum = frustumOf(camera);
    const double scale = distanceScale(index.build, camera, params);

    std::vector<double> distance(index.nodes.size());
    std::vector<double> key(index.nodes.size());
    for (size_t i = 0; i < index.nodes.size(); ++i) {
        distance[i] = distanceToBox(camera.position, index.nodes[i].bounds);
        key[i] = priorityKey(index.nodes[i].bounds, distance[i], camera, params.priority);
    }
    // Highest-priority wins when a block qualifies several times (a texture
    // block shared by leaves): usage first, then key, then level.
    auto mark = [&](BlockId b, Usage usage, double k, int level) {
        BlockPriority& p = c.priority[b];
        const BlockPriority q{usage, k, level};
        if (std::tie(q.usage, q.key, q.level) < std::tie(p.usage, p.key, p.level)) p = q;
    };
    // Every block starts Unused with its node's key, so eviction has an order too.
    for (BlockPriority& p : c.priority) p = {Usage::Unused, 1e300, 1 << 20};
    for (size_t i = 0; i < index.nodes.size(); ++i) {
        const TileNode& n = index.nodes[i];
        forEachNodeBlock(n, [&](BlockId b) { mark(b, Usage::Unused, key[i], n.level); }, params.computed);
        for (const BlockId b : n.texture_blocks) mark(b, Usage::Unused, key[i], n.level + 1);
        if (n.blockmap != kNoBlock) mark(n.blockmap, Usage::Unused, key[i], n.level);
    }

    auto markNode = [&](int32_t id, Usage usage) {
        const TileNode& n = index.nodes[static_cast<size_t>(id)];
        forEachNodeBlock(n, [&](BlockId b) { mark(b, usage, key[static_cast<size_t>(id)], n.level); }, params.computed);
    };
    auto markStandIn = [&](int32_t id, Usage usage) {
        const TileNode& n = index.nodes[static_cast<size_t>(id)];
        forEachStandInBlock(
            n, params.blockmaps, [&](BlockId b) { mark(b, usage, key[static_cast<size_t>(id)], n.level); }, params.computed);
    };
    // A leaf's originals: where it is known which blocks its triangles
    // sample where, each block by its own box (`prefetch_only`: the leaf is
    // sharp, only the next octave is prefetched); else every block as the leaf.
    std::vector<BlockBox> boxes;
    auto markTextures = [&](int32_t id, Usage usage, bool prefetch_only) {
        const TileNode& n = index.nodes[static_cast<size_t>(id)];
        if (!leafBlockBoxes(n, params, &boxes)) {
            for (const BlockId b : n.texture_blocks) mark(b, usage, key[static_cast<size_t>(id)], n.level + 1);
            return;
        }
        for (const BlockBox& bb : boxes) {
            double d = 0;
            const Usage u = blockUse(bb.bounds, frustum, camera.position, n.min_distance_m * scale, &d);
            if (u == Usage::Unused || (prefetch_only && u != Usage::ParentNeeded)) continue;
            mark(bb.block, u, priorityKey(bb.bounds, d, camera, params.priority), n.level + 1);
        }
    };

    // The rendering traversal, as if every block were resident.
    std::vector<int32_t> stack{0};
    if (outsideFrustum(frustum, index.nodes[0].bounds)) stack.clear();
    while (!stack.empty()) {
        const int32_t id = stack.back();
        stack.pop_back();
        const TileNode& n = index.nodes[static_cast<size_t>(id)];
        ++c.nodes_needed;
        const double d = distance[static_cast<size_t>(id)];
        // A node without an atlas is never sharp: closer than its BlockMap's distance, its children are.
        const bool sharp = !n.blockmap_only && d >= n.min_distance_m * scale;
        if (atBlockMapDistance(n, params, d, scale)) {
            // Drawn by its BlockMap: the next step is prefetched as it would be drawn.
            mark(n.blockmap, Usage::Needed, key[static_cast<size_t>(id)], n.level);
            for (const int32_t ch : n.children) {
                markStandIn(ch, Usage::ParentNeeded);
                ++c.nodes_parent_needed;
            }
            continue;
        }
        // An inner node refined past keeps its BlockMap as the fallback; a
        // leaf is drawn with its own geometry whatever its distance.
        if (sharp || n.leaf())
            markNode(id, Usage::Needed);
        else
            markStandIn(id, Usage::Needed);
        if (sharp) {
            // Drawn with its own atlas: the next refinement step is prefetched.
            // A leaf's next step is its originals, one octave of distance
            // away as an inner node's children are: prefetched within twice
            // its min distance, not from anywhere (a high camera over a town
            // of sharp leaves would fetch every original in view:
            // papers/004's height rule).
            if (n.leaf()) {
                if (params.originals && distance[static_cast<size_t>(id)] < 2 * n.min_distance_m * scale)
                    markTextures(id, Usage::ParentNeeded, true);
            } else {
                for (const int32_t ch : n.children) {
                    markStandIn(ch, Usage::ParentNeeded);
                    ++c.nodes_parent_needed;
                }
            }
            continue;
        }
        if (n.leaf()) {
            if (params.originals) markTextures(id, Usage::Needed, false);
            continue;
        }
        std::vector<int32_t> visible, culled;
        for (const int32_t ch : n.children)
            (outsideFrustum(frustum, index.nodes[static_cast<size_t>(ch)].bounds) ? culled : visible).push_back(ch);
        if (!visible.empty()) {
            for (const int32_t ch : culled) {
                markStandIn(ch, Usage::Culled);
                ++c.nodes_culled;
            }
        }
        for (auto it = visible.rbegin(); it != visible.rend(); ++it) stack.push_back(*it);
    }

    orderCandidates(index, &c);
    return c;
}

void orderCandidates(const TilesetIndex& index, Classification* c) {
    c->candidates.clear();
    if (index.nodes.empty()) return;
    std::vector<BlockId> root_blocks;
    forEachRootBlock(index, [&](BlockId b) { root_blocks.push_back(b); });
    // And the root's BlockMap where the selection uses it (Unused: BlockMaps off).
    if (const BlockId b = index.nodes[0].blockmap;
        b != kNoBlock && !index.nodes[0].blockmap_only && c->priority[b].usage != Usage::Unused)
        root_blocks.push_back(b);
    std::sort(root_blocks.begin(), root_blocks.end());
    for (BlockId b = 0; b < index.blocks.size(); ++b)
        if (c->priority[b].usage != Usage::Unused && !std::binary_search(root_blocks.begin(), root_blocks.end(), b))
            c->candidates.push_back(b);
    std::sort(c->candidates.begin(), c->candidates.end(),
              [&](BlockId a, BlockId b) { return before(c->priority[a], a, c->priority[b], b); });
    c->candidates.insert(c->candidates.begin(), root_blocks.begin(), root_blocks.end());
}

bool nodeDrawable(const TilesetIndex& index, int32_t node, const std::function<bool(BlockId)>& resident) {
    const TileNode& n = index.nodes[static_cast<size_t>(node)];
    if (n.blockmap_only) return false;  // no geometry: only its BlockMap draws it
    bool all = true;
    forEachNodeBlock(n, [&](BlockId b) { all = all && resident(b); });
    return all;
}

bool refinementPossible(const TilesetIndex& index, int32_t node, const Frustum& frustum,
                        const std::function<bool(BlockId)>& resident, bool blockmaps) {
    const TileNode& n = index.nodes[static_cast<size_t>(node)];
    if (n.leaf()) {
        return std::all_of(n.texture_blocks.begin(), n.texture_blocks.end(), [&](BlockId b) { return resident(b); });
    }
    for (const int32_t ch : n.children) {
        const TileNode& c = index.nodes[static_cast<size_t>(ch)];
        if (drawsBlockMap(c, blockmaps) && resident(c.blockmap)) continue;
        if (!nodeDrawable(index, ch, resident) && !outsideFrustum(frustum, c.bounds)) return false;
    }
    return true;
}

namespace {
// A leaf's refinement with what the camera sees of its texture blocks: only
// those Needed (blockUse) must be resident; the others' triangles draw with
// the atlas, which is sharp enough there or off screen.
bool leafRefinementPossible(const TilesetIndex& index, const TileNode& n, const Frustum& frustum, const Vec3d& eye,
                            double threshold, const SelectionParams& params,
                            const std::function<bool(BlockId)>& resident) {
    std::vector<BlockBox> boxes;
    if (!leafBlockBoxes(n, params, &boxes)) return refinementPossible(index, n.id, frustum, resident, params.blockmaps);
    return std::all_of(boxes.begin(), boxes.end(), [&](const BlockBox& bb) {
        double d = 0;
        return blockUse(bb.bounds, frustum, eye, threshold, &d) != Usage::Needed || resident(bb.block);
    });
}
}  // namespace

Selection selectDraws(const TilesetIndex& index, const Camera& camera, const SelectionParams& params,
                      const std::function<bool(BlockId)>& resident) {
    Selection s;
    if (index.nodes.empty()) return s;
    const auto blockMapResident = [&](const TileNode& n) { return drawsBlockMap(n, params.blockmaps) && resident(n.blockmap); };
    if (!nodeDrawable(index, 0, resident) && !blockMapResident(index.nodes[0])) {
        s.root_missing = true;
        return s;
    }
    const Frustum frustum = frustumOf(camera);
    const double scale = distanceScale(index.build, camera, params);
    s.nearest_m = 1e300;
    auto emit = [&](const TileNode& n, DrawMode mode, bool coarse, double d) {
        s.draws.push_back({n.id, mode, coarse, d});
        s.coarse_draws += coarse ? 1 : 0;
        // A BlockMap holds its buildings in full: its box may reach past the node's.
        const Box3d& box = mode == DrawMode::BlockMap ? n.blockmap_bounds : n.bounds;
        s.nearest_m = std::min(s.nearest_m, distanceToBox(camera.position, box));
        s.farthest_m = std::max(s.farthest_m, farthestCorner(camera.position, box));
    };
    std::vector<int32_t> stack{0};
    while (!stack.empty()) {
        const int32_t id = stack.back();
        stack.pop_back();
        const TileNode& n = index.nodes[static_cast<size_t>(id)];
        ++s.nodes_visited;
        if (outsideFrustum(frustum, n.bounds)) {
            ++s.nodes_culled;
            continue;
        }
        const double d = distanceToBox(camera.position, n.bounds);
        if (atBlockMapDistance(n, params, d, scale) && resident(n.blockmap)) {
            emit(n, DrawMode::BlockMap, false, d);
            continue;
        }
        bool use_atlas = !n.blockmap_only && d >= n.min_distance_m * scale;
        bool coarse = false;
        // The atlas is the finest there is: originals off, or none listed (it holds every texture exactly).
        if (!use_atlas && n.leaf() && (!params.originals || n.texture_blocks.empty())) use_atlas = true;
        const auto possible = [&] {
            return n.leaf() ? leafRefinementPossible(index, n, frustum, camera.position, n.min_distance_m * scale,
                                                     params, resident)
                            : refinementPossible(index, id, frustum, resident, params.blockmaps);
        };
        if (!use_atlas && !possible()) {
            use_atlas = true;
            coarse = true;
        }
        if (use_atlas || n.leaf()) {
            // Drawable by its BlockMap alone (its parent counted on that): the
            // BlockMap, coarse when the camera is closer than its distance.
            if (!nodeDrawable(index, id, resident) && blockMapResident(n))
                emit(n, DrawMode::BlockMap, !atBlockMapDistance(n, params, d, scale), d);
            else
                emit(n, use_atlas ? DrawMode::Atlas : DrawMode::Originals, coarse, d);
            continue;
        }
        for (auto it = n.children.rbegin(); it != n.children.rend(); ++it) stack.push_back(*it);
    }
    if (s.draws.empty()) s.nearest_m = 0;
    return s;
}

}  // namespace cityatlas::render
