// SPDX-License-Identifier: GPL-3.0-or-later
#include "render/client/streaming_client.h"

#include <algorithm>
#include <chrono>
#include <thread>
#include <unordered_map>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "render/gl/gl_renderer.h"

namespace cityatlas::render {
namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// Nesting depth of arrays and objects, without recursion: json::dump recurses
// once per level, so a record nested 20000 deep would overflow the stack.
size_t nestingDepth(const nlohmann::json& j) {
    size_t deepest = 0;
    std::vector<std::pair<const nlohmann::json*, size_t>> todo{{&j, 1}};
    while (!todo.empty()) {
        const auto [v, depth] = todo.back();
        todo.pop_back();
        if (!v->is_structured()) continue;
        deepest = std::max(deepest, depth);
        for (const nlohmann::json& c : *v) todo.emplace_back(&c, depth + 1);
    }
    return deepest;
}
constexpr size_t kMaxRecordNesting = 64;

}  // namespace

const char* textureModeName(TextureMode mode) {
    switch (mode) {
        case TextureMode::AtlasTree: return "atlas";
        case TextureMode::Original: return "original";
        case TextureMode::Dummy: return "dummy";
    }
    return "?";
}

// GPU objects of resident blocks, and the lookup from a tileset texture to its GPU texture.
struct StreamingClient::Resident {
    std::vector<GpuMesh> meshes;        ///< per block (Geometry)
    std::vector<MeshData> cpu_meshes;   ///< per block (Geometry): positions, indices, feature ids for picking
    std::vector<GpuTexture> atlases;    ///< per block (Atlas, Computed)
    std::vector<GpuBlockMap> blockmaps;             ///< per block (BlockMap)
    std::vector<format::BlockMap> cpu_blockmaps;    ///< per block (BlockMap): what picking casts rays into (no colours)
    std::unordered_map<BlockId, std::vector<std::pair<int32_t, GpuTexture>>> textures;  ///< Textures blocks
    std::vector<const GpuTexture*> original;  ///< per tileset texture: resident or nullptr
    uint64_t gpu_bytes = 0;
};

std::unique_ptr<StreamingClient> StreamingClient::open(const std::string& base, const ClientOptions& options,
                                                       Status* status) {
    std::unique_ptr<StreamingClient> c(new StreamingClient());
    c->base_ = base;
    c->options_ = options;
    // The index over HTTP is tried again on a failure that a flaky server or
    // network explains (a 5xx, a reset, a cut or lying body that does not
    // parse): five attempts over about 4 s. A folder on disk is read once.
    const int attempts = isUrl(base) ? 5 : 1;
    for (int attempt = 1;; ++attempt) {
        std::string text;
        Status st = fetchTilesetText(base, &text);
        const bool permanent = !st.ok() && st.code != StatusCode::kIo;  // e.g. a 404: no tile folder there
        if (st.ok()) st = parseTilesetIndex(text, base, &c->index_);
        if (st.ok()) break;
        if (attempt >= attempts || permanent) {
            *status = st;
            return nullptr;
        }
        c->errors_.push_back(st.error);
        std::this_thread::sleep_for(std::chrono::milliseconds(250 << (attempt - 1)));
    }
    if (!options.selection.blockmaps && options.mode != TextureMode::Original) {
        int levels = 0;
        size_t nodes = 0;
        for (const TileNode& n : c->index_.nodes)
            if (n.blockmap_only) ++nodes, levels = std::max(levels, n.level + 1);
        if (nodes) {
            *status = Status::Usage(fmt::format("{}: built with --blockmaps replace: {} node(s) of levels 0-{} have "
                                                "their BlockMap alone, which BlockMaps off cannot draw; leave BlockMaps on",
                                                base, nodes, levels - 1));
            return nullptr;
        }
    }
    c->loadFeatureBounds();
    c->choosePreloadLevel();
    if (c->pinned_bytes_ > options.budget_bytes) {
        *status = Status::Io(fmt::format("{}: memory budget {} bytes is smaller than the feature bounds ({} bytes), which "
                                         "are always resident",
                                         base, options.budget_bytes, c->pinned_bytes_));
        return nullptr;
    }
    if (Status st = BlockManager::checkBudget(c->index_, options.budget_bytes - c->pinned_bytes_); !st.ok()) {
        *status = Status::Io(fmt::format("{}: {} (after the feature bounds' {} bytes)", base, st.error, c->pinned_bytes_));
        return nullptr;
    }
    c->manager_ = std::make_unique<BlockManager>(
        c->index_, BudgetParams{options.budget_bytes - c->pinned_bytes_, options.max_requests});
    c->loader_ = Loader::open(base, c->index_, options.loader, status);
    if (!c->loader_) return nullptr;
    c->resident_ = std::make_unique<Resident>();
    c->resident_->meshes.resize(c->index_.blocks.size());
    c->resident_->cpu_meshes.resize(c->index_.blocks.size());
    c->resident_->atlases.resize(c->index_.blocks.size());
    c->resident_->blockmaps.resize(c->index_.blocks.size());
    c->resident_->cpu_blockmaps.resize(c->index_.blocks.size());
    c->resident_->original.assign(c->index_.textures.size(), nullptr);
    c->drawn_.assign(c->index_.blocks.size(), 0);
    c->texture_use_.assign(c->index_.blocks.size(), TextureUse{});
    *status = Status::Ok();
    return c;
}

StreamingClient::~StreamingClient() {
    loader_.reset();  // stop the threads before the GL objects go
    if (gl_ && resident_) {
        for (BlockId b = 0; b < index_.blocks.size(); ++b) release(b);
    }
}

Status StreamingClient::initGl() {
    Status st;
    RendererOptions ro;
    ro.max_anisotropy = options_.max_anisotropy;
    ro.force_cpu_decode = options_.cpu_decode;
    gl_ = GlRenderer::create(index_.materials, ro, &st);
    return gl_ ? Status::Ok() : st;
}

const LoaderStats StreamingClient::loaderStats() const { return loader_->stats(); }

bool StreamingClient::usesCpuDecode() const { return gl_ && gl_->decodesOnCpu(); }

void StreamingClient::setBudget(uint64_t bytes) {
    options_.budget_bytes = bytes;
    manager_->setBudget(bytes > pinned_bytes_ ? bytes - pinned_bytes_ : 0);
    choosePreloadLevel();
}

void StreamingClient::choosePreloadLevel() {
    // The deepest level L <= preload_levels whose nodes' stand-ins (their
    // BlockMaps, or geometry and atlases) fit a quarter of the budget
    // (levels grow monotonically in bytes).
    std::vector<uint64_t> by_level;
    for (const TileNode& n : index_.nodes) {
        if (by_level.size() <= static_cast<size_t>(n.level)) by_level.resize(static_cast<size_t>(n.level) + 1, 0);
        forEachStandInBlock(n, options_.selection.blockmaps,
                            [&](BlockId b) { by_level[static_cast<size_t>(n.level)] += index_.blocks[b].bytes; });
    }
    preload_level_ = -1;
    uint64_t sum = 0;
    for (int L = 0; L <= options_.preload_levels && static_cast<size_t>(L) < by_level.size(); ++L) {
        sum += by_level[static_cast<size_t>(L)];
        if (sum > options_.budget_bytes / 4) break;
        preload_level_ = L;
    }
}

void StreamingClient::loadFeatureBounds() {
    // No more records than the tables listed can hold, whatever the index's count says.
    const size_t block = static_cast<size_t>(std::max(1, index_.feature_block_size));
    feature_bounds_.assign(std::min<uint64_t>(index_.feature_count, uint64_t{index_.feature_tables.size()} * block),
                           format::FeatureBoundsRecord{});
    for (size_t k = 0; k < index_.feature_tables.size(); ++k) {
        const FeatureTableInfo& t = index_.feature_tables[k];
        if (t.bounds_uri.empty()) continue;
        std::string bytes;
        std::vector<format::FeatureBoundsRecord> records;
        Status st = fetchText(base_, t.bounds_uri, &bytes);
        if (st.ok() && bytes.size() != t.bounds_bytes)
            st = Status::Io(fmt::format("{}: {} bytes, the index says {}", t.bounds_uri, bytes.size(), t.bounds_bytes));
        if (st.ok())
            st = format::decodeFeatureBounds(
                std::span(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()), t.bounds_uri, &records);
        const size_t first = k * block;
        const size_t want = first < feature_bounds_.size() ? std::min(block, feature_bounds_.size() - first) : 0;
        if (st.ok() && records.size() != want)
            st = Status::Io(fmt::format("{}: {} records, table {} holds {} features", t.bounds_uri, records.size(), k, want));
        if (!st.ok()) {
            errors_.push_back(st.error);
            continue;
        }
        std::copy(records.begin(), records.end(), feature_bounds_.begin() + static_cast<std::ptrdiff_t>(first));
        pinned_bytes_ += t.bounds_bytes;
    }
}

SelectionParams StreamingClient::selectionNow() const {
    SelectionParams p = options_.selection;
    if (options_.textures_by_view) p.texture_use = &texture_use_;
    if (options_.tau_speed_mps > 0) p.tau *= std::max(1.0, speed_mps_ / options_.tau_speed_mps);
    p.computed = options_.mode == TextureMode::AtlasTree && options_.computed_style.mode != ComputedMode::Photo
                     ? options_.computed
                     : -1;
    return p;
}

double StreamingClient::now() const {
    return frame_time_s_ >= 0 ? frame_time_s_ : std::chrono::duration<double>(Clock::now() - opened_).count();
}

bool StreamingClient::related(int32_t a, int32_t b) const {
    auto above = [&](int32_t lower, int32_t upper) {  // upper is lower or one of its ancestors
        for (int32_t n = lower; n >= 0; n = index_.nodes[static_cast<size_t>(n)].parent)
            if (n == upper) return true;
        return false;
    };
    return above(a, b) || above(b, a);
}

std::vector<StreamingClient::Fade> StreamingClient::crossFades(const Selection& sel) {
    std::vector<Fade> out;
    const double t = now(), fade = options_.fade_s;
    std::map<int32_t, Shown> shown;
    auto same = [](const Shown& s, const DrawItem& d) { return s.mode == d.mode; };
    if (fade > 0) {
        // Drawn now: continuing (same node, same mode), or new; a new one
        // fades in when it replaces something shown before (an ancestor, a
        // descendant or the same node in the other mode), else it appears.
        std::vector<int32_t> replaced;
        for (const DrawItem& d : sel.draws) {
            Shown s{d.mode, -1e300};
            if (const auto it = shown_.find(d.node); it != shown_.end() && same(it->second, d)) {
                s.since = it->second.since;
            } else {
                for (const auto& entry : shown_) {
                    const int32_t node = entry.first;
                    const DrawMode was = entry.second.mode;
                    const auto now_there = std::find_if(sel.draws.begin(), sel.draws.end(), [&](const DrawItem& x) {
                        return x.node == node && x.mode == was;
                    });
                    if (now_there == sel.draws.end() && related(node, d.node)) {
                        s.since = t;
                        replaced.push_back(node);
                    }
                }
            }
            shown[d.node] = s;
            if (t - s.since < fade) out.push_back({d, static_cast<float>((t - s.since) / fade), false});
        }
        // What was replaced now starts fading out; earlier ones go on until done.
        for (const int32_t node : replaced) {
            if (std::any_of(fading_out_.begin(), fading_out_.end(), [&](const Fade& f) { return f.item.node == node; })) continue;
            DrawItem item;
            item.node = node;
            item.mode = shown_.at(node).mode;
            fading_out_.push_back({item, 0.0F, true, t});
        }
        const auto resident = [&](BlockId b) { return manager_->resident(b); };
        std::vector<Fade> still;
        for (Fade& f : fading_out_) {
            const bool drawn_now = shown.count(f.item.node) && shown[f.item.node].mode == f.item.mode;
            // Only what is still resident: a fade never holds a block the budget let go.
            const TileNode& n = index_.nodes[static_cast<size_t>(f.item.node)];
            const bool still_resident = f.item.mode == DrawMode::BlockMap ? n.blockmap != kNoBlock && resident(n.blockmap)
                                                                          : nodeDrawable(index_, f.item.node, resident);
            if (t - f.started >= fade || drawn_now || !still_resident) continue;
            f.progress = static_cast<float>((t - f.started) / fade);
            still.push_back(f);
            out.push_back(f);
        }
        fading_out_ = std::move(still);
    } else {
        fading_out_.clear();
        for (const DrawItem& d : sel.draws) shown[d.node] = {d.mode, -1e300};
    }
    shown_ = std::move(shown);
    return out;
}

Classification StreamingClient::classify(const Camera& camera) const {
    if (options_.mode != TextureMode::Original) {
        Classification c = classifyBlocks(index_, camera, selectionNow());
        if (options_.lookahead_s > 0 && speed_mps_ > 0) {
            // Where the camera will be: each block keeps the better of its two priorities.
            Camera ahead = camera;
            ahead.position = camera.position + options_.lookahead_s * velocity_;
            const Classification later = classifyBlocks(index_, ahead, selectionNow());
            for (BlockId b = 0; b < index_.blocks.size(); ++b)
                if (before(later.priority[b], b, c.priority[b], b)) c.priority[b] = later.priority[b];
            orderCandidates(index_, &c);
        }
        if (!speedLimited() && preload_level_ < 0) return c;
        // Moving fast: what is on screen now, at the atlas levels, and nothing else.
        if (speedLimited())
            for (BlockId b = 0; b < index_.blocks.size(); ++b)
                if (index_.blocks[b].kind == BlockKind::Textures || c.priority[b].usage != Usage::Needed)
                    c.priority[b].usage = Usage::Unused;
        // Preloaded levels lead, coarsest first, wherever the camera is.
        for (const TileNode& n : index_.nodes)
            if (n.level <= preload_level_)
                forEachStandInBlock(n, options_.selection.blockmaps,
                                    [&](BlockId b) { c.priority[b] = {Usage::Needed, -1.0, n.level}; });
        orderCandidates(index_, &c);
        return c;
    }
    // The reference: every leaf's geometry, atlas (the fallback for an unreadable
    // original) and original textures, nearest first; the root stays pinned.
    Classification c;
    c.priority.assign(index_.blocks.size(), BlockPriority{Usage::Unused, 1e300, 1 << 20});
    for (const TileNode& n : index_.nodes) {
        const bool root = n.id == 0;
        if (!n.leaf() && !root) continue;
        const double d = distanceToBox(camera.position, n.bounds);
        for (const NodeLayer& l : n.layers) {
            if (!l.present) continue;
            c.priority[l.geometry] = {Usage::Needed, d, n.level};
            if (l.atlas != kNoBlock) c.priority[l.atlas] = {Usage::Needed, d, n.level};
        }
        for (const BlockId b : n.texture_blocks) {
            BlockPriority& p = c.priority[b];
            if (p.usage == Usage::Unused || d < p.key) p = {Usage::Needed, d, n.level + 1};
        }
    }
    orderCandidates(index_, &c);
    return c;
}

void StreamingClient::plan(const Camera& camera) {
    const BlockActions actions = manager_->update(classify(camera));
    for (const BlockId b : actions.cancel) loader_->cancel(b);
    for (const BlockId b : actions.evict) {
        // Fetched and let go without ever being drawn: bandwidth spent for nothing.
        if (!drawn_[b]) wasted_bytes_ += index_.blocks[b].bytes;
        drawn_[b] = 0;
        release(b);
    }
    for (const BlockId b : actions.request) {
        loader_->request(b);
        ++requests_[static_cast<size_t>(index_.blocks[b].kind)];
    }
    // The RAM level's least-recently-used stamps move when the ideal set
    // does: stamping an unchanged set again changes no order, but costs a
    // lookup per block under the loader's lock at every plan (a teleport's
    // wait plans hundreds of times: +0.3 s to 0.45 s of loading, measured).
    if (options_.loader.ram_budget_bytes > 0 && manager_->idealSet() != touched_ideal_) {
        touched_ideal_ = manager_->idealSet();
        loader_->touch(touched_ideal_, ++plans_);
    }
}

void StreamingClient::takeResults() {
    for (LoadResult& r : loader_->poll()) arrived_.push_back(std::move(r));
}

uint32_t StreamingClient::upload(double budget_ms, double* spent_ms) {
    const auto t0 = Clock::now();
    uint32_t done = 0;
    size_t i = 0;
    for (; i < arrived_.size(); ++i) {
        if (done > 0 && msSince(t0) >= budget_ms) break;
        LoadResult& r = arrived_[i];
        if (manager_->state(r.id) != BlockState::Requested) continue;  // cancelled or evicted meanwhile
        bool ok = r.error == LoadError::None;
        Status st;
        if (ok) {
            switch (r.block.kind) {
                case BlockKind::Geometry: {
                    GpuMesh m = gl_->upload(r.block.mesh, &st);
                    ok = st.ok();
                    if (ok) {
                        resident_->gpu_bytes += m.gpu_bytes;
                        resident_->meshes[r.id] = std::move(m);
                        noteTextureUse(r.id, r.block.mesh);
                        // What picking needs stays on the CPU; the uvs go.
                        MeshData& cpu = resident_->cpu_meshes[r.id];
                        cpu.positions = std::move(r.block.mesh.positions);
                        cpu.indices = std::move(r.block.mesh.indices);
                        cpu.feature_id = std::move(r.block.mesh.feature_id);
                    }
                    break;
                }
                case BlockKind::Atlas:
                case BlockKind::Computed: {
                    GpuTexture t = gl_->upload(r.block.atlas, false, &st);
                    ok = st.ok();
                    if (ok) {
                        resident_->gpu_bytes += t.gpu_bytes;
                        resident_->atlases[r.id] = t;
                    }
                    break;
                }
                case BlockKind::BlockMap: {
                    if (!blockmap_pass_) blockmap_pass_ = BlockMapPass::create(&st);
                    if (!blockmap_pass_) {
                        ok = false;
                        break;
                    }
                    format::BlockMap& bm = r.block.blockmap;
                    GpuBlockMap g = blockmap_pass_->upload(bm, bm.roof, bm.walls, &st);
                    ok = st.ok() && g.valid();
                    if (ok) {
                        resident_->gpu_bytes += g.gpu_bytes;
                        resident_->blockmaps[r.id] = g;
                        bm.roof = {};
                        bm.walls = {};
                        resident_->cpu_blockmaps[r.id] = std::move(bm);
                    }
                    break;
                }
                case BlockKind::Textures: {
                    std::vector<std::pair<int32_t, GpuTexture>>& list = resident_->textures[r.id];
                    for (const auto& [texture, data] : r.block.textures) {
                        GpuTexture t = gl_->upload(data, index_.textures[static_cast<size_t>(texture)].wrap, &st);
                        if (!st.ok()) break;
                        resident_->gpu_bytes += t.gpu_bytes;
                        list.emplace_back(texture, t);
                    }
                    ok = st.ok();
                    if (ok) {
                        for (const auto& [texture, t] : list) resident_->original[static_cast<size_t>(texture)] = &t;
                    } else {
                        release(r.id);
                    }
                    break;
                }
            }
            if (!ok) r.message = fmt::format("{}: {}", index_.blocks[r.id].uri, st.error);
        }
        if (!ok) errors_.push_back(r.message.empty() ? index_.blocks[r.id].uri + ": " + loadErrorName(r.error) : r.message);
        // Only the server's or the network's trouble is worth another try later.
        const bool transient = r.error == LoadError::Http || r.error == LoadError::Network ||
                               r.error == LoadError::Timeout || r.error == LoadError::Truncated;
        manager_->finished(r.id, ok, transient);
        ++done;
    }
    arrived_.erase(arrived_.begin(), arrived_.begin() + static_cast<std::ptrdiff_t>(i));
    if (spent_ms) *spent_ms = msSince(t0);
    return done;
}

void StreamingClient::noteTextureUse(BlockId geometry, const MeshData& mesh) {
    const BlockInfo& info = index_.blocks[geometry];
    if (info.node < 0 || !index_.nodes[static_cast<size_t>(info.node)].leaf()) return;
    const TileNode& n = index_.nodes[static_cast<size_t>(info.node)];
    TextureUse& use = texture_use_[geometry];
    use = TextureUse{};
    for (const MeshData::TextureRange& range : mesh.texture_ranges) {
        if (range.texture < 0 || static_cast<size_t>(range.texture) >= index_.textures.size() || range.bounds.empty()) continue;
        const int32_t k = index_.textures[static_cast<size_t>(range.texture)].block;
        if (k < 0 || static_cast<size_t>(k) >= index_.texture_block_ids.size()) continue;
        const BlockId block = index_.texture_block_ids[static_cast<size_t>(k)];
        const Box3d box{n.centre + range.bounds.min, n.centre + range.bounds.max};
        const auto same = std::find_if(use.boxes.begin(), use.boxes.end(), [&](const BlockBox& b) { return b.block == block; });
        if (same == use.boxes.end()) {
            use.boxes.push_back({block, box});
        } else {
            same->bounds.extend(box.min);
            same->bounds.extend(box.max);
        }
    }
    use.known = true;
}

void StreamingClient::release(BlockId id) {
    Resident& r = *resident_;
    if (r.meshes[id].valid()) {
        r.gpu_bytes -= std::min(r.gpu_bytes, r.meshes[id].gpu_bytes);
        gl_->release(&r.meshes[id]);
        r.meshes[id] = GpuMesh{};
        r.cpu_meshes[id] = MeshData{};
    }
    if (r.blockmaps[id].valid()) {
        r.gpu_bytes -= std::min(r.gpu_bytes, r.blockmaps[id].gpu_bytes);
        blockmap_pass_->release(&r.blockmaps[id]);
        r.cpu_blockmaps[id] = format::BlockMap{};
    }
    if (r.atlases[id].valid()) {
        r.gpu_bytes -= std::min(r.gpu_bytes, r.atlases[id].gpu_bytes);
        gl_->release(&r.atlases[id]);
        r.atlases[id] = GpuTexture{};
    }
    if (const auto it = r.textures.find(id); it != r.textures.end()) {
        for (auto& [texture, t] : it->second) {
            r.gpu_bytes -= std::min(r.gpu_bytes, t.gpu_bytes);
            r.original[static_cast<size_t>(texture)] = nullptr;
            gl_->release(&t);
        }
        r.textures.erase(it);
    }
}

Selection StreamingClient::selectForMode(const Camera& camera) const {
    const auto resident = [&](BlockId b) { return manager_->resident(b); };
    if (options_.mode != TextureMode::Original) return selectDraws(index_, camera, selectionNow(), resident);
    // Every leaf in view with its originals, as far as it is loaded.
    Selection s;
    const Frustum frustum = frustumOf(camera);
    s.nearest_m = 1e300;
    for (const TileNode& n : index_.nodes) {
        if (!n.leaf()) continue;
        ++s.nodes_visited;
        if (outsideFrustum(frustum, n.bounds)) {
            ++s.nodes_culled;
            continue;
        }
        if (!nodeDrawable(index_, n.id, resident)) continue;
        const double d = distanceToBox(camera.position, n.bounds);
        s.draws.push_back({n.id, DrawMode::Originals, false, d});
        s.nearest_m = std::min(s.nearest_m, d);
        const double far = length(Vec3d{std::max(std::abs(camera.position.x - n.bounds.min.x), std::abs(camera.position.x - n.bounds.max.x)),
                                        std::max(std::abs(camera.position.y - n.bounds.min.y), std::abs(camera.position.y - n.bounds.max.y)),
                                        std::max(std::abs(camera.position.z - n.bounds.min.z), std::abs(camera.position.z - n.bounds.max.z))});
        s.farthest_m = std::max(s.farthest_m, far);
    }
    if (s.draws.empty()) s.nearest_m = 0;
    return s;
}

bool StreamingClient::waitForIdealSet(const Camera& camera, double timeout_s) {
    const auto t0 = Clock::now();
    for (;;) {
        takeResults();
        upload(1e9, nullptr);
        plan(camera);
        if (manager_->idealComplete() && arrived_.empty()) return true;
        if (msSince(t0) > timeout_s * 1000) return false;
        loader_->waitForAny(0.05);
    }
}

void StreamingClient::idle(const Camera& camera, double seconds) {
    const auto t0 = Clock::now();
    for (;;) {
        const double left_ms = seconds * 1000 - msSince(t0);
        if (left_ms <= 0) return;
        takeResults();
        if (!arrived_.empty()) {
            upload(std::min(left_ms, options_.upload_ms_per_frame), nullptr);
            plan(camera);
            continue;
        }
        if (manager_->idealComplete()) {
            std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(left_ms));
            return;
        }
        loader_->waitForAny(std::min(left_ms, 20.0) / 1000);
    }
}

Status StreamingClient::waitForRoot(const Camera& camera, double timeout_s) {
    const auto t0 = Clock::now();
    for (;;) {
        takeResults();
        upload(1e9, nullptr);
        plan(camera);
        // A transient failure (the loader's retries ran out on a flaky
        // server) is tried again after its cool-down while time is left;
        // only a permanent one (a 404, bytes that do not decode) ends the wait.
        bool all = true, failed = false;
        forEachRootBlock(index_, [&](BlockId b) {
            all = all && manager_->resident(b);
            failed = failed || manager_->failedForGood(b);
        });
        if (all) return Status::Ok();
        if (failed)  // the failure just taken is the latest error
            return Status::Io(fmt::format("{}: the root's blocks cannot be loaded{}", base_,
                                          errors_.empty() ? "" : ": " + errors_.back()));
        if (msSince(t0) > timeout_s * 1000)
            return Status::Io(fmt::format("{}: the root's blocks did not load within {} s{}", base_, timeout_s,
                                          errors_.empty() ? "" : ": " + errors_.front()));
        loader_->waitForAny(0.05);
    }
}

FrameRecord StreamingClient::frame(const Camera& camera_in) {
    FrameRecord rec;
    const auto t0 = Clock::now();
    takeResults();
    rec.uploads = upload(options_.upload_ms_per_frame, &rec.upload_ms);
    plan(camera_in);
    const Selection sel = selectForMode(camera_in);

    // Near and far from the drawn boxes keep the depth buffer's resolution where the geometry is.
    Camera camera = camera_in;
    camera.near_m = std::clamp(0.5 * sel.nearest_m, 0.1, 1e4);
    camera.far_m = std::max(sel.farthest_m * 1.01, camera.near_m * 10);
    // The lenses' per-building state for this camera, uploaded when it changed.
    if (lens_.active() || lens_uploaded_) {
        LensStyle style = lens_.active() ? lensStyle(lens_, feature_bounds_, camera.position, camera.up) : LensStyle{};
        for (uint32_t f = 0; f < style.style.size(); ++f)
            if (style.style[f] != LensStyle::kNormal && !lens_.solo) rec.lens_occluder_ids.push_back(f);
        rec.lens_occluders = static_cast<uint32_t>(
            std::count_if(style.style.begin(), style.style.end(), [&](uint8_t s) { return s != LensStyle::kNormal; }));
        if (!lens_uploaded_ || !(style == last_lens_)) {
            gl_->setLens(style);
            last_lens_ = std::move(style);
        }
        lens_uploaded_ = lens_.active();
    }
    gl_->beginFrame(camera, {0.55F, 0.70F, 0.90F, 1.0F});
    gl_->setComputed(options_.computed_style);
    const int computed = selectionNow().computed;
    const Resident& r = *resident_;
    const auto original = [&](int32_t t) -> const GpuTexture* {
        return t >= 0 && static_cast<size_t>(t) < r.original.size() ? r.original[static_cast<size_t>(t)] : nullptr;
    };
    const BlockMapLens blockmap_lens = gl_->blockMapLens();
    // `fade`, `fade_t`: the cross-fade's screen door (GlRenderer::setFade), meshes and BlockMaps alike.
    auto drawItem = [&](const DrawItem& d, int fade, float fade_t) {
        const TileNode& n = index_.nodes[static_cast<size_t>(d.node)];
        if (d.mode == DrawMode::BlockMap) {
            // Drawn now (ray-cast, depth written): the meshes queued for
            // endFrame are depth-tested against it.
            drawn_[n.blockmap] = 1;
            blockmap_pass_->draw(r.blockmaps[n.blockmap], camera, &blockmap_lens, fade, fade_t);
            return;
        }
        gl_->setFade(fade, fade_t);
        for (const NodeLayer& l : n.layers) {
            if (!l.present) continue;
            drawn_[l.geometry] = 1;
            if (l.atlas != kNoBlock) drawn_[l.atlas] = 1;
        }
        if (d.mode == DrawMode::Originals)
            for (const BlockId b : n.texture_blocks)
                if (manager_->resident(b)) drawn_[b] = 1;
        for (int li = 0; li < kLayerCount; ++li) {
            const NodeLayer& l = n.layers[static_cast<size_t>(li)];
            if (!l.present) continue;
            const GpuMesh& mesh = r.meshes[l.geometry];
            if (!mesh.valid()) continue;
            const GpuTexture* atlas = l.atlas != kNoBlock && r.atlases[l.atlas].valid() ? &r.atlases[l.atlas] : nullptr;
            // The shown computed texture, where resident; the photo stands in until it is.
            const GpuTexture* shown = nullptr;
            if (computed >= 0 && static_cast<size_t>(computed) < l.computed.size() &&
                l.computed[static_cast<size_t>(computed)] != kNoBlock) {
                const BlockId cb = l.computed[static_cast<size_t>(computed)];
                if (r.atlases[cb].valid()) {
                    shown = &r.atlases[cb];
                    drawn_[cb] = 1;
                } else {
                    ++computed_missing_;
                }
            }
            if (options_.mode == TextureMode::Dummy) {
                gl_->drawDummy(mesh, n.centre, li);
            } else if (d.mode == DrawMode::Originals) {
                gl_->drawOriginals(mesh, original, atlas, n.centre, li, shown);
            } else {
                gl_->drawAtlas(mesh, atlas, n.centre, li, shown);
            }
        }
    };
    // Smooth refinement: what replaces a node fades in over the node fading
    // out (complementary screen-door masks), for options_.fade_s.
    computed_missing_ = 0;
    const std::vector<Fade> fades = crossFades(sel);
    for (const Fade& f : fades) {
        if (!f.out) continue;
        drawItem(f.item, 2, f.progress);
        ++rec.fading;
    }
    for (const DrawItem& d : sel.draws) {
        const TileNode& n = index_.nodes[static_cast<size_t>(d.node)];
        const auto in = std::find_if(fades.begin(), fades.end(), [&](const Fade& f) { return !f.out && f.item.node == d.node; });
        rec.fading += in != fades.end() ? 1 : 0;
        drawItem(d, in != fades.end() ? 1 : 0, in != fades.end() ? in->progress : 0.0F);
        (d.mode == DrawMode::Originals  ? rec.nodes_originals
         : d.mode == DrawMode::BlockMap ? rec.nodes_blockmap
                                        : rec.nodes_atlas) += 1;
        rec.nodes_coarse += d.coarse ? 1 : 0;
        if (d.coarse && (rec.coarse_level_min < 0 || n.level < rec.coarse_level_min)) rec.coarse_level_min = n.level;
    }
    gl_->setFade(0, 0);
    last_drawn_ = sel.draws;
    const FrameStats fs = gl_->endFrame();
    if (edges_.enabled && edge_target_ != nullptr)
        if (Status es = gl_->applyEdges(*edge_target_, edges_); !es.ok()) {
            errors_.push_back(es.error);
            edges_.enabled = false;
        }
    gl_->finish();
    rec.frame_ms = msSince(t0);
    rec.draw_calls = fs.draw_calls;
    rec.texture_binds = fs.texture_binds;
    rec.triangles = fs.triangles;
    rec.root_missing = sel.root_missing;
    rec.computed_missing_draws = computed_missing_;
    const BudgetStats& b = manager_->stats();
    rec.resident_bytes = b.resident_bytes;
    rec.requested_bytes = b.requested_bytes;
    rec.budget_bytes = options_.budget_bytes;
    rec.pinned_bytes = pinned_bytes_;
    rec.gpu_bytes = r.gpu_bytes;
    const LoaderStats ls = loader_->stats();
    rec.bytes_loaded = ls.bytes_fetched - bytes_fetched_seen_;
    bytes_fetched_seen_ = ls.bytes_fetched;
    rec.ram_hits = ls.ram_hits - ram_hits_seen_;
    ram_hits_seen_ = ls.ram_hits;
    rec.ram_bytes = ls.ram_bytes;
    rec.ram_budget_bytes = options_.loader.ram_budget_bytes;
    rec.ideal_bytes = b.ideal_bytes;
    rec.needed_bytes = b.needed_bytes;
    rec.speed_mps = speed_mps_;
    rec.wasted_bytes = wasted_bytes_;
    rec.speed_limited = speedLimited();
    rec.requests = requests_;
    requests_ = {};
    for (const BlockId id : manager_->idealSet()) ++rec.ideal_blocks_by_kind[static_cast<size_t>(index_.blocks[id].kind)];
    rec.requests_in_flight = b.requested_blocks;
    rec.ideal_blocks = b.ideal_blocks;
    rec.ideal_missing = b.ideal_missing;
    rec.needed_missing = b.needed_missing;
    rec.ideal_cut = b.ideal_cut;
    rec.errors = errors_.size();
    rec.failed_blocks = manager_->stats().failed_blocks;
    rec.evictions = b.evictions;
    rec.cancellations = b.cancellations;
    return rec;
}

PickHit StreamingClient::pick(const Camera& camera, double px, double py) const {
    std::vector<PickMesh> meshes;
    std::vector<PickBlockMap> blockmaps;
    for (const DrawItem& d : last_drawn_) {
        const TileNode& n = index_.nodes[static_cast<size_t>(d.node)];
        if (d.mode == DrawMode::BlockMap) {
            if (manager_->resident(n.blockmap)) blockmaps.push_back({d.node, &resident_->cpu_blockmaps[n.blockmap]});
            continue;
        }
        for (const NodeLayer& l : n.layers)
            if (l.present && manager_->resident(l.geometry))
                meshes.push_back({d.node, &resident_->cpu_meshes[l.geometry], n.centre});
    }
    return pickRay(camera.position, pixelRay(camera, px, py), meshes, blockmaps);
}

Status StreamingClient::featureRecord(uint32_t feature, std::string* json_text) {
    if (feature >= index_.feature_count || index_.feature_block_size <= 0)
        return Status::Io(fmt::format("feature {} is not in the tileset", feature));
    const size_t table = feature / static_cast<uint32_t>(index_.feature_block_size);
    if (table >= index_.feature_tables.size()) return Status::Io(fmt::format("feature {}: no feature table", feature));
    auto it = feature_tables_.find(table);
    if (it == feature_tables_.end()) {
        std::string text;
        if (Status st = fetchText(base_, index_.feature_tables[table].uri, &text); !st.ok()) return st;
        it = feature_tables_.emplace(table, std::move(text)).first;
    }
    try {
        const nlohmann::json doc = nlohmann::json::parse(it->second);
        for (const nlohmann::json& f : doc.at("features"))
            if (f.value("id", -1LL) == static_cast<long long>(feature)) {
                if (nestingDepth(f) > kMaxRecordNesting)
                    return Status::Invalid(fmt::format("{}: feature {} is nested deeper than {} levels",
                                                       index_.feature_tables[table].uri, feature, kMaxRecordNesting));
                *json_text = f.dump(1);
                return Status::Ok();
            }
    } catch (const nlohmann::json::exception& e) {
        return Status::Io(fmt::format("{}: {}", index_.feature_tables[table].uri, e.what()));
    }
    return Status::Io(fmt::format("{}: feature {} not listed", index_.feature_tables[table].uri, feature));
}

}  // namespace cityatlas::render
