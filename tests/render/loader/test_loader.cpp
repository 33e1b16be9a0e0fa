// SPDX-License-Identifier: GPL-3.0-or-later
// The block decoder on every block of a built town and on damaged bytes; the
// loader over files and over HTTP from an in-process cpp-httplib server that
// misbehaves on purpose (503 then 200, 404, short bodies, hanging answers),
// counting connections to see keep-alive at work.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <thread>

#include <httplib.h>

#include "render/client/streaming_client.h"
#include "render/core/block_manager.h"
#include "render/core/selection.h"
#include "render/loader/block_decoder.h"
#include "render/loader/byte_cache.h"
#include "render/loader/loader.h"
#include "tests/render/core/scripted_tree.h"
#include "tests/render/town_fixture.h"
#include "tiles/texture_codec.h"

namespace cityatlas::render {
namespace {
namespace fs = std::filesystem;

std::vector<uint8_t> readBytes(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

const TilesetIndex& townIndex() {
    static const TilesetIndex ix = [] {
        TilesetIndex i;
        EXPECT_TRUE(parseTilesetIndex(test::builtTown().text, "tileset.json", &i).ok());
        return i;
    }();
    return ix;
}

fs::path tilesDir() { return test::builtTown().dir / "tiles"; }

std::vector<LoadResult> loadAll(Loader& loader, size_t count, double timeout_s = 60) {
    std::vector<LoadResult> out;
    const auto t0 = std::chrono::steady_clock::now();
    while (out.size() < count &&
           std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < timeout_s) {
        loader.waitForAny(0.1);
        for (LoadResult& r : loader.poll()) out.push_back(std::move(r));
    }
    return out;
}

// The RAM level (byte_cache.h): least recently in an ideal set goes first,
// ties take the larger block id, nothing larger than the budget is kept, and
// the bytes come back as they went in.
TEST(ByteCache, EvictsTheLeastRecentlyInAnIdealSetFirstWithinItsBudget) {
    ByteCache c(100);
    auto bytes = [](uint8_t fill, size_t n) { return std::vector<uint8_t>(n, fill); };
    c.put(1, bytes(1, 40));
    c.put(2, bytes(2, 40));
    c.touch({1}, 1);                 // 1 was in the ideal set at frame 1, 2 only at frame 0
    c.put(3, bytes(3, 40));          // stamped 1; 2 goes
    EXPECT_TRUE(c.holds(1));
    EXPECT_FALSE(c.holds(2));
    EXPECT_TRUE(c.holds(3));
    EXPECT_EQ(c.bytes(), 80u);
    c.put(4, bytes(4, 40));          // 1 and 3 both stamped 1: the larger id, 3, goes
    EXPECT_TRUE(c.holds(1));
    EXPECT_FALSE(c.holds(3));
    EXPECT_TRUE(c.holds(4));
    std::vector<uint8_t> out;
    ASSERT_TRUE(c.get(4, &out));
    EXPECT_EQ(out, bytes(4, 40));
    EXPECT_FALSE(c.get(2, &out));
    EXPECT_EQ(c.hits(), 1u);
    c.put(5, bytes(5, 101));         // larger than the whole budget: not kept, nothing evicted
    EXPECT_FALSE(c.holds(5));
    EXPECT_EQ(c.bytes(), 80u);
    ByteCache off(0);
    off.put(1, bytes(1, 1));
    EXPECT_FALSE(off.holds(1));

    // Random puts, touches and gets against a plain model of the sizes held.
    std::mt19937 rng(4);
    ByteCache r(1000);
    for (int step = 0; step < 20000; ++step) {
        const BlockId id = rng() % 64;
        switch (rng() % 3) {
            case 0: r.put(id, bytes(static_cast<uint8_t>(id), 1 + rng() % 300)); break;
            case 1: r.touch({id, static_cast<BlockId>(rng() % 64)}, static_cast<uint64_t>(step)); break;
            default:
                if (r.get(id, &out)) {
                    ASSERT_TRUE(std::all_of(out.begin(), out.end(), [&](uint8_t b) { return b == id; }));
                }
        }
        ASSERT_LE(r.bytes(), 1000u) << "step " << step;
        uint64_t held = 0;
        for (BlockId b = 0; b < 64; ++b)
            if (r.holds(b) && r.get(b, &out)) held += out.size();
        ASSERT_EQ(held, r.bytes()) << "step " << step;
    }
}

// The spec's H1: on 100 random paths over the built town (smooth stretches
// and teleports, cameras anywhere from street level to far above) with a GPU
// budget of 1/20 of the folder and a RAM level of twice that, fed and
// stamped as the loader and client do (bytes in when a load finishes, the
// ideal set stamped each frame, RAM asked first): every frame keeps resident
// + requested within the GPU budget and the RAM level within its own.
TEST(ByteCache, HundredRandomPathsKeepTheGpuAndRamBudgets) {
    const TilesetIndex& ix = townIndex();
    const Box3d box = ix.nodes[0].bounds;
    const Vec3d size = box.max - box.min;
    const uint64_t budget = std::max<uint64_t>(ix.bytes_total / 20, 1);
    ASSERT_TRUE(BlockManager::checkBudget(ix, budget).ok()) << "the root must fit 1/20 of the folder";
    std::mt19937 rng(18);
    std::uniform_real_distribution<double> u(0, 1);
    uint64_t frames = 0, ram_hits = 0, fetched = 0;
    for (int path = 0; path < 100; ++path) {
        BlockManager m(ix, {budget, 8});
        ByteCache ram(2 * budget);
        std::set<BlockId> in_flight;
        auto spot = [&] {
            return Vec3d{box.min.x + (1.4 * u(rng) - 0.2) * size.x, box.min.y + (1.4 * u(rng) - 0.2) * size.y,
                         box.min.z + 1.7 + std::pow(u(rng), 3) * 3 * std::max(size.x, size.y)};
        };
        Vec3d from = spot(), to = spot();
        for (int frame = 0; frame < 60; ++frame, ++frames) {
            if (frame % 15 == 0) from = to, to = spot();  // a new stretch; a teleport when it is the first frame
            const double t = (frame % 15) / 15.0;
            Camera cam = test::unitCamera(from + t * (to - from), normalized(Vec3d{u(rng) - 0.5, u(rng) - 0.5, -0.3 * u(rng)}));
            const BlockActions a = m.update(classifyBlocks(ix, cam, {}));
            ram.touch(m.idealSet(), static_cast<uint64_t>(frames) + 1);
            for (const BlockId b : a.cancel) in_flight.erase(b);
            for (const BlockId b : a.request) in_flight.insert(b);
            const BudgetStats& st = m.stats();
            ASSERT_LE(st.resident_bytes + st.requested_bytes, budget) << "path " << path << " frame " << frame;
            // Some loads finish: from RAM when it holds them, else fetched (and kept).
            std::vector<BlockId> pending(in_flight.begin(), in_flight.end());
            std::shuffle(pending.begin(), pending.end(), rng);
            for (size_t i = 0; i < pending.size() && i < 1 + rng() % 6; ++i) {
                const BlockId b = pending[i];
                std::vector<uint8_t> bytes;
                if (ram.get(b, &bytes)) {
                    ++ram_hits;
                    ASSERT_EQ(bytes.size(), ix.blocks[b].bytes);
                } else {
                    fetched += ix.blocks[b].bytes;
                    ram.put(b, std::vector<uint8_t>(ix.blocks[b].bytes, 7));
                }
                m.finished(b, true);
                in_flight.erase(b);
                ASSERT_LE(ram.bytes(), ram.budget()) << "path " << path << " frame " << frame;
            }
            ASSERT_LE(m.stats().resident_bytes, budget);
        }
    }
    std::printf("  %llu frames on 100 paths at budget/20 (%llu bytes): %llu RAM hits, %llu bytes fetched\n",
                static_cast<unsigned long long>(frames), static_cast<unsigned long long>(budget),
                static_cast<unsigned long long>(ram_hits), static_cast<unsigned long long>(fetched));
    EXPECT_GT(ram_hits, 0u) << "the paths never came back to anything";
}

TEST(BlockDecoder, EveryBlockOfATownDecodes) {
    const TilesetIndex& ix = townIndex();
    ASSERT_FALSE(ix.blocks.empty());
    size_t textures_seen = 0;
    for (BlockId b = 0; b < ix.blocks.size(); ++b) {
        const BlockInfo& info = ix.blocks[b];
        DecodedBlock d;
        const Status st = decodeBlock(ix, b, readBytes(tilesDir() / info.uri), &d);
        ASSERT_TRUE(st.ok()) << st.error;
        EXPECT_EQ(d.bytes_read, info.bytes);
        if (info.kind == BlockKind::Geometry) {
            const MeshData& m = d.mesh;
            const NodeLayer& l = ix.nodes[static_cast<size_t>(info.node)].layers[static_cast<size_t>(info.layer)];
            EXPECT_EQ(m.indices.size(), 3u * l.triangles) << info.uri;
            const size_t n = m.positions.size() / 3;
            EXPECT_EQ(m.feature_id.size(), n);
            for (const uint32_t i : m.indices) ASSERT_LT(i, n);
            if (!m.texture_id.empty()) {
                // Ranges: ascending textures, back to back, covering every index once, one texture each.
                uint32_t next = 0;
                int32_t last = -2;
                for (const MeshData::TextureRange& r : m.texture_ranges) {
                    EXPECT_EQ(r.first_index, next);
                    EXPECT_GT(r.texture, last);
                    last = r.texture;
                    // Its box is exactly its triangles' (the vertices as drawn, float).
                    Box3d box;
                    for (uint32_t k = r.first_index; k < r.first_index + r.index_count; ++k) {
                        ASSERT_EQ(m.texture_id[m.indices[k]], r.texture) << info.uri;
                        const uint32_t v = m.indices[k];
                        box.extend({m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]});
                    }
                    EXPECT_EQ(r.bounds.min.x, box.min.x);
                    EXPECT_EQ(r.bounds.min.y, box.min.y);
                    EXPECT_EQ(r.bounds.min.z, box.min.z);
                    EXPECT_EQ(r.bounds.max.x, box.max.x);
                    EXPECT_EQ(r.bounds.max.y, box.max.y);
                    EXPECT_EQ(r.bounds.max.z, box.max.z);
                    next += r.index_count;
                }
                EXPECT_EQ(next, m.indices.size());
                EXPECT_EQ(m.uv_original.size(), 2 * n);
            }
        } else if (info.kind == BlockKind::Atlas) {
            uint64_t sum = 0;
            for (const CompressedTexture::Level& lv : d.atlas.levels) {
                EXPECT_EQ(lv.offset, sum);
                EXPECT_EQ(lv.bytes, tiles::bcBlockBytes(lv.width, lv.height, d.atlas.channels));
                sum += lv.bytes;
            }
            EXPECT_EQ(sum, d.atlas.data.size());
            EXPECT_EQ(d.atlas.data.size() + 128, info.bytes);
        } else {
            size_t expected = 0;
            for (const TextureInfo& t : ix.textures) expected += t.block == info.texture_block ? 1 : 0;
            EXPECT_EQ(d.textures.size(), expected);
            for (const auto& [t, tex] : d.textures) {
                EXPECT_EQ(ix.textures[static_cast<size_t>(t)].block, info.texture_block);
                EXPECT_EQ(tex.width, ix.textures[static_cast<size_t>(t)].width);
            }
            textures_seen += d.textures.size();
        }
    }
    size_t written = 0;
    for (const TextureInfo& t : ix.textures) written += t.block >= 0 ? 1 : 0;
    EXPECT_EQ(textures_seen, written);
}

// A folder with BlockMaps: the index lists each as a block of its node (its
// box holds the node's, its distance the node's), and each decodes; a file
// naming a building the folder does not have is refused in one line naming it
// (its ids reach the id buffer and the lenses' per-building tables).
TEST(BlockDecoder, BlockMapsAreBlocksOfTheirNodesAndDecode) {
    const test::BuiltTown& town = test::builtTownWithBlockMaps();
    TilesetIndex ix;
    ASSERT_TRUE(parseTilesetIndex(town.text, "tileset.json", &ix).ok());
    const TileNode& root = ix.nodes[0];
    ASSERT_NE(root.blockmap, kNoBlock) << "the root has no BlockMap";
    uint64_t bytes = 0;
    size_t count = 0;
    for (const TileNode& n : ix.nodes) {
        if (n.blockmap == kNoBlock) continue;
        ++count;
        const BlockInfo& info = ix.blocks[n.blockmap];
        EXPECT_EQ(info.kind, BlockKind::BlockMap);
        EXPECT_EQ(info.node, n.id);
        EXPECT_EQ(info.uri, "blockmap/" + std::to_string(n.id) + ".bin");
        EXPECT_EQ(n.blockmap_min_distance_m, n.min_distance_m);
        EXPECT_LE(n.blockmap_bounds.min.x, n.bounds.min.x + 1e-9);
        EXPECT_LE(n.blockmap_bounds.min.y, n.bounds.min.y + 1e-9);
        EXPECT_GE(n.blockmap_bounds.max.x, n.bounds.max.x - 1e-9);
        EXPECT_GE(n.blockmap_bounds.max.y, n.bounds.max.y - 1e-9);
        bytes += info.bytes;
        DecodedBlock d;
        const Status st = decodeBlock(ix, n.blockmap, readBytes(town.dir / "tiles" / info.uri), &d);
        ASSERT_TRUE(st.ok()) << st.error;
        EXPECT_EQ(d.kind, BlockKind::BlockMap);
        // Its box as the index has it.
        EXPECT_NEAR(d.blockmap.origin.x, n.blockmap_bounds.min.x, 1e-9);
        EXPECT_NEAR(d.blockmap.origin.x + d.blockmap.nx * d.blockmap.cell_m, n.blockmap_bounds.max.x, 1e-6);
        EXPECT_NEAR(d.blockmap.z_hi, n.blockmap_bounds.max.z, 1e-9);
        EXPECT_FALSE(d.blockmap.roof.empty());
    }
    EXPECT_EQ(ix.bytes_by_kind[static_cast<int>(BlockKind::BlockMap)], bytes);
    std::printf("%zu BlockMap block(s), %llu bytes\n", count, static_cast<unsigned long long>(bytes));
    // A folder claiming fewer buildings than the BlockMap names.
    TilesetIndex fewer = ix;
    fewer.feature_count = 1;
    DecodedBlock d;
    const Status st = decodeBlock(fewer, root.blockmap, readBytes(town.dir / "tiles" / ix.blocks[root.blockmap].uri), &d);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error.find("blockmap/0.bin"), std::string::npos) << st.error;
    EXPECT_NE(st.error.find("the folder has 1 buildings"), std::string::npos) << st.error;
}

TEST(BlockDecoder, DamagedBytesAreRefusedNamingTheFile) {
    const TilesetIndex& ix = townIndex();
    const NodeLayer& root = ix.nodes[0].layers[0];
    const std::string atlas_uri = ix.blocks[root.atlas].uri, geometry_uri = ix.blocks[root.geometry].uri;
    std::vector<uint8_t> dds = readBytes(tilesDir() / atlas_uri);
    std::vector<uint8_t> glb = readBytes(tilesDir() / geometry_uri);
    DecodedBlock d;
    auto refuses = [&](BlockId id, std::vector<uint8_t> bytes, const std::string& what, const std::string& expect) {
        const Status st = decodeBlock(ix, id, bytes, &d);
        EXPECT_FALSE(st.ok()) << what;
        EXPECT_NE(st.error.find(ix.blocks[id].uri), std::string::npos) << what << ": " << st.error;
        EXPECT_NE(st.error.find(expect), std::string::npos) << what << ": " << st.error;
    };
    std::vector<uint8_t> bad = dds;
    bad[0] = 'X';
    refuses(root.atlas, bad, "magic", "DDS");
    bad = dds;
    std::copy_n("DXT5", 4, bad.begin() + 84);  // a BC3 header on a BC1 atlas: the sizes no longer add up
    refuses(root.atlas, bad, "fourcc", "bytes");
    bad.assign(dds.begin(), dds.begin() + static_cast<long>(dds.size() / 2));
    refuses(root.atlas, bad, "truncated", "tileset.json says");
    bad = glb;
    for (size_t i = 40; i < bad.size(); i += 7) bad[i] ^= 0x5A;
    refuses(root.geometry, bad, "scrambled glb", "");
}

TEST(Loader, FilesLoadAsDecodedAndMissingOnesAreNotFound) {
    const TilesetIndex& ix = townIndex();
    Status st;
    auto loader = Loader::open(tilesDir().string(), ix, {}, &st);
    ASSERT_TRUE(loader) << st.error;
    for (BlockId b = 0; b < ix.blocks.size(); ++b) loader->request(b);
    loader->request(0);  // idempotent while pending
    const std::vector<LoadResult> results = loadAll(*loader, ix.blocks.size());
    ASSERT_EQ(results.size(), ix.blocks.size());
    std::set<BlockId> seen;
    for (const LoadResult& r : results) {
        EXPECT_EQ(r.error, LoadError::None) << r.message;
        EXPECT_TRUE(seen.insert(r.id).second) << "delivered twice: " << r.id;
        if (r.block.kind == BlockKind::Atlas) {
            DecodedBlock direct;
            ASSERT_TRUE(decodeBlock(ix, r.id, readBytes(tilesDir() / ix.blocks[r.id].uri), &direct).ok());
            EXPECT_EQ(direct.atlas.data, r.block.atlas.data);
        }
    }
    EXPECT_EQ(loader->stats().completed, ix.blocks.size());
    EXPECT_EQ(loader->pending(), 0u);

    // A folder with a block missing.
    const fs::path copy = cityatlas::test::scratchPath("render_loader", "missing");
    fs::copy(tilesDir(), copy, fs::copy_options::recursive);
    const BlockId gone = ix.nodes[0].layers[0].atlas;
    fs::remove(copy / ix.blocks[gone].uri);
    auto l2 = Loader::open(copy.string(), ix, {}, &st);
    l2->request(gone);
    const std::vector<LoadResult> r2 = loadAll(*l2, 1);
    ASSERT_EQ(r2.size(), 1u);
    EXPECT_EQ(r2[0].error, LoadError::NotFound);
    EXPECT_NE(r2[0].message.find(ix.blocks[gone].uri), std::string::npos) << r2[0].message;
    // Cancelled requests deliver nothing, even when their work had finished.
    l2->request(ix.nodes[0].layers[0].geometry);
    l2->cancel(ix.nodes[0].layers[0].geometry);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    EXPECT_TRUE(l2->poll().empty());
    EXPECT_EQ(l2->pending(), 0u);
}

// An HTTP server over the town's folder whose answers the test scripts per path.
struct Behaviour {
    int fail_first = 0;      ///< answer 503 this many times, then the file
    int status = 200;        ///< answer this status instead of the file (404, ...)
    bool short_body = false; ///< send half of the file with a Content-Length for half (tileset.json knows better)
    int delay_ms = 0;        ///< wait before answering
};

class TestServer {
public:
    TestServer() {
        server_.Get(".*", [this](const httplib::Request& req, httplib::Response& res) {
            Behaviour b;
            int attempt = 0;
            {
                std::lock_guard lock(mutex_);
                ports_.insert(req.remote_port);
                ++requests_;
                attempt = ++attempts_[req.path];
                if (const auto it = behaviours_.find(req.path); it != behaviours_.end()) b = it->second;
            }
            if (b.delay_ms) std::this_thread::sleep_for(std::chrono::milliseconds(b.delay_ms));
            if (attempt <= b.fail_first) {
                res.status = 503;
                return;
            }
            if (b.status != 200) {
                res.status = b.status;
                return;
            }
            const std::vector<uint8_t> bytes = readBytes(tilesDir() / req.path.substr(1));
            if (bytes.empty()) {
                res.status = 404;
                return;
            }
            const size_t n = b.short_body ? bytes.size() / 2 : bytes.size();
            res.set_content(reinterpret_cast<const char*>(bytes.data()), n, "application/octet-stream");
        });
        // httplib closes a connection after 5 requests by default; a tile server keeps it open.
        server_.set_keep_alive_max_count(100000);
        // Without TCP_NODELAY, headers and body in two writes wait on delayed ACKs (40 ms each).
        server_.set_tcp_nodelay(true);
        port_ = server_.bind_to_any_port("127.0.0.1");
        thread_ = std::thread([this] { server_.listen_after_bind(); });
        while (!server_.is_running()) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ~TestServer() {
        server_.stop();
        thread_.join();
    }
    std::string url() const { return "http://127.0.0.1:" + std::to_string(port_) + "/"; }
    void set(const std::string& uri, Behaviour b) {
        std::lock_guard lock(mutex_);
        behaviours_["/" + uri] = b;
    }
    int attempts(const std::string& uri) {
        std::lock_guard lock(mutex_);
        return attempts_["/" + uri];
    }
    size_t connections() {
        std::lock_guard lock(mutex_);
        return ports_.size();
    }
    size_t requests() {
        std::lock_guard lock(mutex_);
        return requests_;
    }

private:
    httplib::Server server_;
    std::thread thread_;
    int port_ = 0;
    std::mutex mutex_;
    std::map<std::string, Behaviour> behaviours_;
    std::map<std::string, int> attempts_;
    std::set<int> ports_;
    size_t requests_ = 0;
};

TEST(Loader, HttpLoadsEverythingOverFewConnections) {
    TestServer server;
    const TilesetIndex& ix = townIndex();
    std::string text;
    ASSERT_TRUE(fetchTilesetText(server.url(), &text).ok());
    EXPECT_EQ(text, test::builtTown().text);
    LoaderOptions o;
    o.max_connections = 4;
    Status st;
    auto loader = Loader::open(server.url(), ix, o, &st);
    ASSERT_TRUE(loader) << st.error;
    for (BlockId b = 0; b < ix.blocks.size(); ++b) loader->request(b);
    const std::vector<LoadResult> results = loadAll(*loader, ix.blocks.size());
    ASSERT_EQ(results.size(), ix.blocks.size());
    for (const LoadResult& r : results) EXPECT_EQ(r.error, LoadError::None) << r.message;
    // Keep-alive: connections reused, at most the configured number open at once.
    EXPECT_GE(server.requests(), ix.blocks.size());
    // One connection for tileset.json, at most 4 for the blocks.
    EXPECT_LE(server.connections(), 5u) << server.requests() << " requests";
    EXPECT_EQ(loader->stats().bytes_fetched, ix.bytes_total);
}

TEST(Loader, HttpRetriesOn503AndTimeoutsButNotOn404) {
    TestServer server;
    const TilesetIndex& ix = townIndex();
    const NodeLayer& root = ix.nodes[0].layers[0];
    const BlockId flaky = root.atlas, missing = root.geometry;
    const BlockId shortened = ix.nodes[1].layers[0].atlas, slow = ix.nodes[1].layers[0].geometry;
    server.set(ix.blocks[flaky].uri, {2, 200, false, 0});
    server.set(ix.blocks[missing].uri, {0, 404, false, 0});
    server.set(ix.blocks[shortened].uri, {0, 200, true, 0});
    server.set(ix.blocks[slow].uri, {0, 200, false, 1500});
    LoaderOptions o;
    o.retries = 2;
    o.retry_backoff_s = 0.05;
    o.timeout_s = 0.4;
    Status st;
    auto loader = Loader::open(server.url(), ix, o, &st);
    ASSERT_TRUE(loader) << st.error;
    for (const BlockId b : {flaky, missing, shortened, slow}) loader->request(b);
    std::map<BlockId, LoadResult> by_id;
    for (LoadResult& r : loadAll(*loader, 4, 30)) by_id[r.id] = std::move(r);
    ASSERT_EQ(by_id.size(), 4u);
    EXPECT_EQ(by_id[flaky].error, LoadError::None) << by_id[flaky].message;
    EXPECT_EQ(by_id[flaky].attempts, 3);
    EXPECT_EQ(server.attempts(ix.blocks[flaky].uri), 3);
    EXPECT_EQ(by_id[missing].error, LoadError::NotFound);
    EXPECT_EQ(server.attempts(ix.blocks[missing].uri), 1) << "a 404 is not retried";
    EXPECT_NE(by_id[missing].message.find("HTTP 404"), std::string::npos) << by_id[missing].message;
    EXPECT_EQ(by_id[shortened].error, LoadError::Truncated) << by_id[shortened].message;
    EXPECT_EQ(by_id[shortened].attempts, 3);
    EXPECT_EQ(by_id[slow].error, LoadError::Timeout) << by_id[slow].message;
    EXPECT_EQ(by_id[slow].attempts, 3);
    EXPECT_GE(loader->stats().retries, 6u);
    EXPECT_EQ(loader->stats().errors_by_kind[static_cast<size_t>(LoadError::NotFound)], 1u);
}

TEST(Loader, CancellingATransferInFlightDeliversNothingAndTheLoaderGoesOn) {
    TestServer server;
    const TilesetIndex& ix = townIndex();
    const BlockId slow = ix.nodes[0].layers[0].atlas, next = ix.nodes[0].layers[0].geometry;
    server.set(ix.blocks[slow].uri, {0, 200, false, 800});
    Status st;
    auto loader = Loader::open(server.url(), ix, {}, &st);
    ASSERT_TRUE(loader) << st.error;
    loader->request(slow);
    std::this_thread::sleep_for(std::chrono::milliseconds(200));  // the transfer is in flight now
    loader->cancel(slow);
    loader->request(next);
    const std::vector<LoadResult> results = loadAll(*loader, 1, 10);
    ASSERT_EQ(results.size(), 1u);
    EXPECT_EQ(results[0].id, next);
    std::this_thread::sleep_for(std::chrono::milliseconds(900));
    EXPECT_TRUE(loader->poll().empty()) << "the cancelled block arrived anyway";
    // Destruction with a hanging transfer returns promptly.
    server.set(ix.blocks[next].uri, {0, 200, false, 5000});
    loader->request(slow);
    const auto t0 = std::chrono::steady_clock::now();
    loader.reset();
    // Well under the 5 s the server would hang: the transfer was aborted, not waited for.
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 4.5);
}

TEST(Loader, ADeadServerIsOneClearLine) {
    std::string text;
    const Status st = fetchTilesetText("http://127.0.0.1:9/tiles/", &text);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error.find("http://127.0.0.1:9/tiles/tileset.json: cannot fetch"), std::string::npos) << st.error;
    EXPECT_EQ(st.error.find('\n'), std::string::npos);
    const Status folder = fetchTilesetText("/no/such/folder", &text);
    EXPECT_NE(folder.error.find("no such folder"), std::string::npos) << folder.error;
}

// Found with fuzz_feature_table: a feature record nested 20000 deep crashed
// `view` (json::dump, which shows the record, recurses once per level).
TEST(StreamingClient, DeeplyNestedFeatureRecordIsOneLineNotAStackOverflow) {
    const fs::path dir = fs::path(testing::TempDir()) / "cityatlas_deep_feature";
    fs::remove_all(dir);
    fs::create_directories(dir / "features");
    std::string table = R"({"first": 0, "features": [{"id": 0, "x": )" + std::string(20000, '[') +
                        std::string(20000, ']') + R"(}, {"id": 1, "name": "fine"}]})";
    std::ofstream(dir / "features" / "0.json", std::ios::binary) << table;
    std::ofstream(dir / "tileset.json") << R"({"asset": {"version": "1.1"}, "extras": {"cityatlas": {
      "format_version": 1,
      "build": {"d_min_m": 300, "atlas_size_px": 256, "screen_width_px": 1920, "screen_height_px": 1080,
                "vertical_fov_deg": 60, "focal_px": 935.3, "corner_factor": 1.44, "tau": 1},
      "georeference": {}, "materials": [], "texture_blocks": [], "textures": [],
      "features": {"count": 2, "block_size": 4096, "tables": [{"uri": "features/0.json", "bytes": 1}]}}},
      "root": {"boundingVolume": {"box": [0, 0, 5, 10, 0, 0, 0, 10, 0, 0, 0, 5]},
        "extras": {"cityatlas": {"id": 0, "min_distance_m": 300, "world_texel_m": 0.3, "centre": [0, 0, 5],
          "layers": {"opaque": {"triangles": 2, "geometric_error_m": 0, "position_error_mm": 1,
                                "geometry": {"uri": "geometry/opaque/0.glb", "bytes": 1000}, "atlas": null}}}}}})";
    Status st;
    ClientOptions options;
    options.loader.decode_threads = 1;
    const auto client = StreamingClient::open(dir.string(), options, &st);
    ASSERT_TRUE(client) << st.error;
    std::string record;
    st = client->featureRecord(0, &record);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error.find("features/0.json: feature 0 is nested deeper than 64 levels"), std::string::npos) << st.error;
    ASSERT_TRUE(client->featureRecord(1, &record).ok());
    EXPECT_NE(record.find("fine"), std::string::npos) << record;
    fs::remove_all(dir);
}

}  // namespace
}  // namespace cityatlas::render
