// SPDX-License-Identifier: GPL-3.0-or-later
// The party-wall index (ingest/footprints/party_walls.h) against the rule it
// implements, checked by brute force over every pair of edges.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "ingest/footprints/party_walls.h"

using namespace cityatlas;
using footprints::Footprint2d;
using footprints::PartyWallIndex;
using footprints::WallBottoms;

namespace {

struct Building {
    std::vector<Footprint2d> parts;
    double base_z = 0, eave_z = 10;
};

Footprint2d rect(double x0, double y0, double x1, double y1) {
    Footprint2d f;
    f.outer = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};  // counter-clockwise
    return f;
}

const std::vector<Vec2d>& ring(const Footprint2d& p, size_t k) { return k == 0 ? p.outer : p.holes[k - 1]; }

struct Result {
    std::vector<WallBottoms> bottoms;
    uint64_t pairs = 0;
};

Result indexed(const std::vector<Building>& city) {
    PartyWallIndex index;
    for (const Building& b : city) index.add(b.parts, b.eave_z);
    index.finish();
    Result r;
    for (size_t i = 0; i < city.size(); ++i)
        r.bottoms.push_back(index.wallBottoms(static_cast<uint32_t>(i), city[i].parts, city[i].base_z, city[i].eave_z, &r.pairs));
    return r;
}

// The rule, by brute force: every edge in reading order (building, part,
// ring, edge); an edge whose snapped endpoints an earlier edge already had is
// left as it is; otherwise, when the earliest edge running the other way
// belongs to another building, its wall starts at the lower eave (not below
// its own base), and the pair counts once.
Result bruteForce(const std::vector<Building>& city) {
    struct E {
        size_t b, p, k, e;
        long long ax, ay, bx, by;
    };
    auto q = [](double v) { return std::llround(v / PartyWallIndex::kSnap_m); };
    std::vector<E> all;
    Result r;
    for (size_t b = 0; b < city.size(); ++b) {
        WallBottoms w(city[b].parts.size());
        for (size_t p = 0; p < city[b].parts.size(); ++p) {
            const Footprint2d& part = city[b].parts[p];
            w[p].resize(1 + part.holes.size());
            for (size_t k = 0; k <= part.holes.size(); ++k) {
                const auto& rg = ring(part, k);
                w[p][k].assign(rg.size(), city[b].base_z);
                for (size_t e = 0; e < rg.size(); ++e) {
                    const Vec2d& a = rg[e];
                    const Vec2d& c = rg[(e + 1) % rg.size()];
                    all.push_back({b, p, k, e, q(a.x), q(a.y), q(c.x), q(c.y)});
                }
            }
        }
        r.bottoms.push_back(std::move(w));
    }
    for (size_t i = 0; i < all.size(); ++i) {
        const E& me = all[i];
        bool first = true;
        for (size_t j = 0; j < i && first; ++j)
            first = !(all[j].ax == me.ax && all[j].ay == me.ay && all[j].bx == me.bx && all[j].by == me.by);
        if (!first) continue;
        for (const E& other : all) {
            if (!(other.ax == me.bx && other.ay == me.by && other.bx == me.ax && other.by == me.ay)) continue;
            if (other.b != me.b) {
                const Building& x = city[me.b];
                r.bottoms[me.b][me.p][me.k][me.e] = std::max(x.base_z, std::min(x.eave_z, city[other.b].eave_z));
                if (me.b < other.b) ++r.pairs;
            }
            break;  // the earliest such edge decides
        }
    }
    return r;
}

}  // namespace

TEST(PartyWalls, ARowOfThreeRaisesEachSharedWallToTheLowerEave) {
    // a | b | c along x, eaves 6, 15 and 9; c stands on a base of 12 (a
    // slope): its shared wall cannot start below it.
    std::vector<Building> city = {{{rect(0, 0, 10, 10)}, 0, 6}, {{rect(10, 0, 20, 10)}, 0, 15}, {{rect(20, 0, 30, 10)}, 12, 19}};
    const Result r = indexed(city);
    EXPECT_EQ(r.pairs, 2u);
    // Edges of rect: 0 bottom, 1 right, 2 top, 3 left.
    EXPECT_EQ(r.bottoms[0][0][0], (std::vector<double>{0, 6, 0, 0}));    // a: the right wall is b's
    EXPECT_EQ(r.bottoms[1][0][0], (std::vector<double>{0, 15, 0, 6}));   // b: up to c's 19 (cut at its own 15), from a's 6
    EXPECT_EQ(r.bottoms[2][0][0], (std::vector<double>{12, 12, 12, 15}));  // c: min(19, 15) on its left
}

TEST(PartyWalls, AnEdgeMetTwiceIsTheFirstOnesAndEndpointsMatchToAMillimetre) {
    // b repeats a's right edge (an overlapping duplicate); c touches a from
    // the right, its corners 0.4 mm off (same millimetre: shared); d has the
    // same part twice, against e.
    std::vector<Building> city = {{{rect(0, 0, 10, 10)}, 0, 8},
                                  {{rect(5, 0, 10, 10)}, 0, 4},
                                  {{rect(10.0004, -0.0004, 20, 10.0004)}, 0, 20},
                                  {{rect(30, 0, 40, 10), rect(30, 0, 40, 10)}, 0, 8},
                                  {{rect(40, 0, 50, 10)}, 0, 3}};
    const Result r = indexed(city);
    const Result truth = bruteForce(city);
    EXPECT_EQ(r.bottoms, truth.bottoms);
    EXPECT_EQ(r.pairs, truth.pairs);
    EXPECT_EQ(r.bottoms[0][0][0][1], 8) << "a's right wall is shared with c (eave 20): raised to a's own eave";
    EXPECT_EQ(r.bottoms[1][0][0][1], 0) << "b's right edge is a's, met first there: b's wall stays whole";
    EXPECT_EQ(r.bottoms[2][0][0][3], 8) << "c's left wall starts at a's eave";
    EXPECT_EQ(r.bottoms[3][0][0][1], 3) << "d's first part against e";
    EXPECT_EQ(r.bottoms[3][1][0][1], 0) << "d's second part repeats the edge: left whole";
}

TEST(PartyWalls, RandomBlocksAgreeWithBruteForce) {
    // Rectangles on a 1 m lattice, so that many edges coincide; some with a
    // courtyard, some of two parts, some repeated; random bases and eaves.
    std::mt19937 rng(17);
    std::uniform_int_distribution<int> cell(0, 8), size(1, 3), pick(0, 9);
    std::uniform_real_distribution<double> z(0, 30);
    uint64_t pairs = 0;
    for (int round = 0; round < 40; ++round) {
        std::vector<Building> city;
        for (int i = 0; i < 30; ++i) {
            Building b;
            const double x = cell(rng), y = cell(rng), w = size(rng), h = size(rng);
            b.parts.push_back(rect(x, y, x + w, y + h));
            if (pick(rng) == 0 && w > 2 && h > 2) b.parts[0].holes.push_back({{x + 1, y + 1}, {x + 1, y + 2}, {x + 2, y + 2}, {x + 2, y + 1}});
            if (pick(rng) == 1) b.parts.push_back(rect(x + w, y, x + w + 1, y + 1));
            b.base_z = z(rng);
            b.eave_z = b.base_z + z(rng);
            if (pick(rng) == 2 && !city.empty()) b.parts = city[static_cast<size_t>(pick(rng)) % city.size()].parts;
            city.push_back(std::move(b));
        }
        const Result r = indexed(city), truth = bruteForce(city);
        ASSERT_EQ(r.bottoms, truth.bottoms) << "round " << round;
        ASSERT_EQ(r.pairs, truth.pairs) << "round " << round;
        pairs += truth.pairs;
    }
    EXPECT_GT(pairs, 200u) << "the lattice makes neighbours";
}

TEST(PartyWalls, CornersBeyondTheIndexedRangeAreBuiltFromTheirBase) {
    // 3,000 km from the local origin (beyond an int32 of millimetres): not
    // indexed, so never raised, and nothing overflows.
    std::vector<Building> city = {{{rect(3e6, 0, 3e6 + 10, 10)}, 1, 6}, {{rect(3e6 + 10, 0, 3e6 + 20, 10)}, 2, 15},
                                  {{rect(0, 0, 10, 10)}, 0, 6}, {{rect(10, 0, 20, 10)}, 0, 15}};
    const Result r = indexed(city);
    EXPECT_EQ(r.bottoms[0][0][0], (std::vector<double>{1, 1, 1, 1}));
    EXPECT_EQ(r.bottoms[1][0][0], (std::vector<double>{2, 2, 2, 2}));
    EXPECT_EQ(r.bottoms[3][0][0][3], 6) << "the pair near the origin still is one";
    EXPECT_EQ(r.pairs, 1u);
}
