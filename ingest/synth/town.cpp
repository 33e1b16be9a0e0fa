// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/synth/town.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "ingest/triangulate.h"

namespace cityatlas::synth {

std::string_view shapeName(FootprintShape s) {
    switch (s) {
        case FootprintShape::Rectangle: return "rectangle";
        case FootprintShape::LShape: return "l_shape";
        case FootprintShape::UShape: return "u_shape";
        case FootprintShape::Courtyard: return "courtyard";
    }
    return "rectangle";
}

std::string_view roofTypeName(RoofType r) {
    switch (r) {
        case RoofType::Flat: return "flat";
        case RoofType::Gable: return "gable";
        case RoofType::Hip: return "hip";
        case RoofType::Pyramid: return "pyramid";
    }
    return "flat";
}

std::string_view roofTypeCityGmlCode(RoofType r) {
    switch (r) {
        case RoofType::Flat: return "1000";
        case RoofType::Gable: return "1030";
        case RoofType::Hip: return "1040";
        case RoofType::Pyramid: return "1070";
    }
    return "1000";
}

std::string_view roofTypeOsmName(RoofType r) {
    switch (r) {
        case RoofType::Flat: return "flat";
        case RoofType::Gable: return "gabled";
        case RoofType::Hip: return "hipped";
        case RoofType::Pyramid: return "pyramidal";
    }
    return "flat";
}

namespace {

// Layout constants, in metres. Multiples of 1.25 m keep footprints on the
// exact grid described in town.h.
constexpr int kLotsX = 3, kLotsY = 2;
constexpr double kLot = 30, kStreet = 15;
constexpr double kBlockW = kLotsX * kLot, kBlockH = kLotsY * kLot;
// One paving tile covers this many metres: a 28 m roof repeats it ~1100 times,
// the "high repeat count" case the atlas must handle at no extra cost.
constexpr double kPavingRepeat = 0.025;

// Building-local plan coordinates are integers in eighths of a metre, so the
// rotations below are exact integer arithmetic.
constexpr int64_t kEighths = 8;
struct PlanPoint {
    int64_t x = 0, y = 0;  // eighths of a metre
};
struct Rotation {
    int64_t c = 5, s = 0;  // cosine and sine times 5
};
constexpr Rotation kRotations[] = {{5, 0}, {0, 5}, {4, 3}, {3, 4}};

// splitmix64: tiny, well-mixed and identical on every platform (std::
// distributions are not specified bit-exactly across standard libraries).
struct Rng {
    uint64_t state;
    uint64_t next() {
        uint64_t z = (state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    int uniform(int lo, int hi) {  // inclusive
        return lo + static_cast<int>(next() % static_cast<uint64_t>(hi - lo + 1));
    }
    bool chance(int percent) { return uniform(0, 99) < percent; }
};

// 1.25 m steps in eighths.
constexpr int64_t kStep = 10;

struct PlanFootprint {
    std::vector<PlanPoint> outer;               // counter-clockwise
    std::vector<std::vector<PlanPoint>> holes;  // clockwise
    int64_t w = 0, d = 0;                        // bounding box, eighths
};

PlanFootprint makeFootprint(FootprintShape shape, Rng& rng) {
    PlanFootprint f;
    // Half sizes are multiples of 0.625 m (5 eighths).
    auto steps = [&](int lo, int hi) { return rng.uniform(lo, hi) * kStep; };
    switch (shape) {
        case FootprintShape::Rectangle: {
            f.w = steps(8, 16);
            f.d = steps(7, static_cast<int>(f.w / kStep));  // w >= d: ridges run along x
            break;
        }
        case FootprintShape::LShape:
        case FootprintShape::UShape:
            f.w = steps(10, 16);
            f.d = steps(10, 16);
            break;
        case FootprintShape::Courtyard:
            f.w = steps(13, 16);
            f.d = steps(13, 16);
            break;
    }
    const int64_t hw = f.w / 2, hd = f.d / 2;
    switch (shape) {
        case FootprintShape::Rectangle:
        case FootprintShape::Courtyard:
            f.outer = {{-hw, -hd}, {hw, -hd}, {hw, hd}, {-hw, hd}};
            if (shape == FootprintShape::Courtyard) {
                const int64_t t = steps(3, 4);  // wing depth 3.75 .. 5 m
                f.holes.push_back({{-hw + t, -hd + t}, {-hw + t, hd - t}, {hw - t, hd - t}, {hw - t, -hd + t}});
            }
            break;
        case FootprintShape::LShape: {
            // Cut the north-east corner away.
            const int64_t a = steps(4, static_cast<int>(f.w / kStep) - 4);
            const int64_t b = steps(4, static_cast<int>(f.d / kStep) - 4);
            f.outer = {{-hw, -hd}, {hw, -hd}, {hw, hd - b}, {hw - a, hd - b}, {hw - a, hd}, {-hw, hd}};
            break;
        }
        case FootprintShape::UShape: {
            // A notch opening to the north, with wings at least 3.75 m wide.
            const int w_steps = static_cast<int>(f.w / kStep);
            const int notch = rng.uniform(2, w_steps - 6);
            const int64_t x1 = -hw + steps(3, w_steps - notch - 3);
            const int64_t x2 = x1 + notch * kStep;
            const int64_t b = steps(3, static_cast<int>(f.d / kStep) - 4);
            f.outer = {{-hw, -hd}, {hw, -hd}, {hw, hd}, {x2, hd}, {x2, hd - b}, {x1, hd - b}, {x1, hd}, {-hw, hd}};
            break;
        }
    }
    return f;
}

// Shoelace area in square eighths (exact integer), positive for counter-clockwise.
int64_t twiceSignedArea(const std::vector<PlanPoint>& ring) {
    int64_t a = 0;
    for (size_t i = 0; i < ring.size(); ++i) {
        const PlanPoint& p = ring[i];
        const PlanPoint& q = ring[(i + 1) % ring.size()];
        a += p.x * q.y - q.x * p.y;
    }
    return a;
}

// Places building-local geometry in the town: rotate (exactly), then move to
// the lot centre and lift onto the terrain.
struct Placement {
    Rotation rot;
    PlanPoint centre;  // lot centre in eighths, local frame
    double base_z = 0;
    Vec2d plan(PlanPoint p) const {
        // Footprint coordinates are multiples of 5 eighths, so division by 5 is exact.
        const int64_t x = (rot.c * p.x - rot.s * p.y) / 5 + centre.x;
        const int64_t y = (rot.s * p.x + rot.c * p.y) / 5 + centre.y;
        return {static_cast<double>(x) / kEighths, static_cast<double>(y) / kEighths};
    }
    Vec3d at(PlanPoint p, double z_above_base) const {
        Vec2d q = plan(p);
        return {q.x, q.y, base_z + z_above_base};
    }
};

class BuildingBuilder {
public:
    BuildingBuilder(SynthBuilding& b, const Placement& place) : b_(b), place_(place) {}

    SynthSurface& add(SurfaceSemantic sem, const char* kind) {
        SynthSurface s;
        s.semantic = sem;
        s.gml_id = fmt::format("{}_{}{}", b_.gml_id, kind, counter_++);
        b_.surfaces.push_back(std::move(s));
        return b_.surfaces.back();
    }

    // Walls along every footprint ring; facade texture continues around each
    // ring (u = distance along the ring / projection width, v = height / eave).
    // `gable_top` optionally raises the midpoint of edges that end a gable.
    void walls(const PlanFootprint& f, double gable_rise) {
        auto ringWalls = [&](const std::vector<PlanPoint>& ring) {
            double along_m = 0;
            for (size_t i = 0; i < ring.size(); ++i) {
                const PlanPoint p = ring[i], q = ring[(i + 1) % ring.size()];
                const double len_m =
                    std::sqrt(static_cast<double>((q.x - p.x) * (q.x - p.x) + (q.y - p.y) * (q.y - p.y))) / kEighths;
                SynthSurface& s = add(SurfaceSemantic::Wall, "wall");
                const double H = b_.eave_height_m, pw = b_.projection_width_m;
                const double u0 = along_m / pw, u1 = (along_m + len_m) / pw;
                std::vector<Vec3d> pts{place_.at(p, 0), place_.at(q, 0), place_.at(q, H)};
                std::vector<Vec2d> uv{{u0, 0}, {u1, 0}, {u1, 1}};
                // Gable ends are the edges perpendicular to the ridge (x = const).
                if (gable_rise > 0 && p.x == q.x) {
                    const PlanPoint mid{p.x, (p.y + q.y) / 2};
                    pts.push_back(place_.at(mid, H + gable_rise));
                    uv.push_back({(u0 + u1) / 2, (H + gable_rise) / H});
                }
                pts.push_back(place_.at(p, H));
                uv.push_back({u0, 1});
                s.rings.push_back(std::move(pts));
                s.uv.push_back(std::move(uv));
                s.texture = b_.facade_texture;
                along_m += len_m;
            }
        };
        ringWalls(f.outer);
        for (const auto& hole : f.holes) ringWalls(hole);
    }

    // Horizontal footprint polygon at height z; flipped faces downward.
    SynthSurface& footprintPolygon(const PlanFootprint& f, double z, SurfaceSemantic sem, const char* kind,
                                   bool flipped) {
        SynthSurface& s = add(sem, kind);
        auto ring3 = [&](const std::vector<PlanPoint>& ring) {
            std::vector<Vec3d> pts;
            for (const PlanPoint& p : ring) pts.push_back(place_.at(p, z));
            if (flipped) std::reverse(pts.begin(), pts.end());
            return pts;
        };
        s.rings.push_back(ring3(f.outer));
        for (const auto& hole : f.holes) s.rings.push_back(ring3(hole));
        return s;
    }

    void polygon(SurfaceSemantic sem, const char* kind, std::vector<Vec3d> pts, int32_t material) {
        SynthSurface& s = add(sem, kind);
        s.rings.push_back(std::move(pts));
        s.material = material;
    }

private:
    SynthBuilding& b_;
    const Placement& place_;
    int counter_ = 0;
};

// Material palette (linear RGB).
enum MaterialIndex : int32_t { kRedTiles, kSlate, kGravel, kGroundSlab, kMaterialCount };

std::vector<Material> makeMaterials() {
    std::vector<Material> m(kMaterialCount);
    m[kRedTiles].diffuse = {0.60f, 0.22f, 0.15f};
    m[kSlate].diffuse = {0.30f, 0.30f, 0.33f};
    m[kGravel].diffuse = {0.55f, 0.55f, 0.50f};
    m[kGroundSlab].diffuse = {0.35f, 0.30f, 0.25f};
    return m;
}

SynthBuilding makeBuilding(const TownSettings& settings, uint32_t number, PlanPoint lot_centre, Town& town) {
    Rng rng{settings.seed * 0x100000001B3ull ^ (static_cast<uint64_t>(number) * 0xD6E8FEB86659FD93ull)};
    SynthBuilding b;
    b.number = number;
    b.gml_id = fmt::format("bldg_{:06d}", number);

    const int shape_roll = rng.uniform(0, 99);
    b.shape = shape_roll < 40 ? FootprintShape::Rectangle
            : shape_roll < 60 ? FootprintShape::LShape
            : shape_roll < 80 ? FootprintShape::UShape
                              : FootprintShape::Courtyard;
    const PlanFootprint f = makeFootprint(b.shape, rng);
    const Rotation rot = kRotations[rng.uniform(0, 3)];

    static constexpr double kStoreyHeights[] = {2.75, 3.0, 3.25, 3.5};
    b.storeys = rng.chance(70) ? rng.uniform(2, 5) : rng.uniform(6, 12);
    b.storey_height_m = kStoreyHeights[rng.uniform(0, 3)];
    b.eave_height_m = b.storeys * b.storey_height_m;
    // The facade texture is square and spans the wall height, so it is
    // undistorted when its projection width equals the eave height.
    b.projection_width_m = b.eave_height_m;

    // Draw the roof even for LOD1 so a seed gives the same footprints at both LODs.
    RoofType roof = static_cast<RoofType>(rng.uniform(0, 3));
    const int pitch_quarters = rng.uniform(2, 4);  // roof rise = half depth * 2/4 .. 4/4
    if (b.shape != FootprintShape::Rectangle || settings.lod == 1) roof = RoofType::Flat;
    if (roof == RoofType::Hip && f.w == f.d) roof = RoofType::Pyramid;  // a hip with no ridge
    b.roof = roof;
    const double half_depth_m = static_cast<double>(f.d / 2) / kEighths;
    const double rise = roof == RoofType::Flat ? 0.0 : half_depth_m * pitch_quarters / 4.0;
    b.ridge_height_m = b.eave_height_m + rise;

    // Gentle terrain: a tilted plane, rounded down to 1/8 m.
    const double cx = static_cast<double>(lot_centre.x) / kEighths, cy = static_cast<double>(lot_centre.y) / kEighths;
    b.base_height_m = std::floor((0.01 * cx + 0.005 * cy + 8.0) * 8.0) / 8.0;

    Placement place{rot, lot_centre, b.base_height_m};
    for (const PlanPoint& p : f.outer) b.outer.push_back(place.plan(p));
    for (const auto& hole : f.holes) {
        b.holes.emplace_back();
        for (const PlanPoint& p : hole) b.holes.back().push_back(place.plan(p));
    }
    int64_t area2 = twiceSignedArea(f.outer);
    for (const auto& hole : f.holes) area2 += twiceSignedArea(hole);  // holes are clockwise: negative
    b.footprint_area_m2 = static_cast<double>(area2) / 2.0 / (kEighths * kEighths);

    // Textures: one unique facade per building (every 7th with translucent
    // glass, i.e. RGBA); paving on every other flat roof.
    SynthTexture facade;
    facade.kind = SynthTexture::Kind::Facade;
    facade.relative_path = fmt::format("textures/facade_{:06d}.png", number);
    facade.size_px = settings.texture_size_px;
    facade.channels = number % 7 == 0 ? 4 : 3;
    facade.building_number = number;
    facade.storeys = b.storeys;
    facade.window_columns = std::max(1, static_cast<int>(std::lround(b.projection_width_m / 3.0)));
    facade.seed = rng.next();
    town.textures.push_back(facade);
    b.facade_texture = static_cast<int32_t>(town.textures.size() - 1);
    if (roof == RoofType::Flat && number % 2 == 0) b.roof_texture = 0;  // paving is texture 0

    BuildingBuilder build(b, place);
    const double H = b.eave_height_m;
    build.walls(f, roof == RoofType::Gable ? rise : 0.0);

    const int64_t hw = f.w / 2, hd = f.d / 2;
    const PlanPoint A{-hw, -hd}, B{hw, -hd}, C{hw, hd}, D{-hw, hd};
    const int32_t roof_colour = number % 3 == 0 ? kSlate : kRedTiles;
    switch (roof) {
        case RoofType::Flat: {
            SynthSurface& s = build.footprintPolygon(f, H, SurfaceSemantic::Roof, "roof", false);
            if (b.roof_texture >= 0) {
                s.texture = b.roof_texture;
                // Paving in world units from the roof's lowest corner, so the
                // pattern is continuous and the repeat count is large.
                double min_x = 1e300, min_y = 1e300;
                for (const auto& ring : s.rings)
                    for (const Vec3d& p : ring) min_x = std::min(min_x, p.x), min_y = std::min(min_y, p.y);
                for (const auto& ring : s.rings) {
                    s.uv.emplace_back();
                    for (const Vec3d& p : ring)
                        s.uv.back().push_back({(p.x - min_x) / kPavingRepeat, (p.y - min_y) / kPavingRepeat});
                }
            } else {
                s.material = kGravel;
            }
            break;
        }
        case RoofType::Gable: {
            const PlanPoint R1{-hw, 0}, R2{hw, 0};
            build.polygon(SurfaceSemantic::Roof, "roof",
                          {place.at(A, H), place.at(B, H), place.at(R2, H + rise), place.at(R1, H + rise)}, roof_colour);
            build.polygon(SurfaceSemantic::Roof, "roof",
                          {place.at(C, H), place.at(D, H), place.at(R1, H + rise), place.at(R2, H + rise)}, roof_colour);
            break;
        }
        case RoofType::Hip: {
            const PlanPoint R1{-hw + hd, 0}, R2{hw - hd, 0};
            build.polygon(SurfaceSemantic::Roof, "roof",
                          {place.at(A, H), place.at(B, H), place.at(R2, H + rise), place.at(R1, H + rise)}, roof_colour);
            build.polygon(SurfaceSemantic::Roof, "roof",
                          {place.at(C, H), place.at(D, H), place.at(R1, H + rise), place.at(R2, H + rise)}, roof_colour);
            build.polygon(SurfaceSemantic::Roof, "roof", {place.at(B, H), place.at(C, H), place.at(R2, H + rise)},
                          roof_colour);
            build.polygon(SurfaceSemantic::Roof, "roof", {place.at(D, H), place.at(A, H), place.at(R1, H + rise)},
                          roof_colour);
            break;
        }
        case RoofType::Pyramid: {
            const PlanPoint P{0, 0};
            const PlanPoint corners[] = {A, B, C, D};
            for (int i = 0; i < 4; ++i)
                build.polygon(SurfaceSemantic::Roof, "roof",
                              {place.at(corners[i], H), place.at(corners[(i + 1) % 4], H), place.at(P, H + rise)},
                              roof_colour);
            break;
        }
    }
    build.footprintPolygon(f, 0, SurfaceSemantic::Ground, "ground", true).material = kGroundSlab;
    return b;
}

// Every roof polygon gets the orthophoto instead of paving or a colour.
void coverRoofsWithOrthophoto(Town& town) {
    town.orthophoto = orthophotoGrid(town);
    SynthTexture photo;
    photo.kind = SynthTexture::Kind::Orthophoto;
    photo.relative_path = "textures/orthophoto.png";
    photo.channels = 3;
    town.textures.push_back(photo);
    town.orthophoto_texture = static_cast<int32_t>(town.textures.size() - 1);
    const Vec3d o = town.settings.origin_source;
    for (SynthBuilding& b : town.buildings) {
        b.roof_texture = town.orthophoto_texture;
        for (SynthSurface& s : b.surfaces) {
            if (s.semantic != SurfaceSemantic::Roof) continue;
            s.texture = town.orthophoto_texture;
            s.material = -1;
            s.uv.clear();
            for (const auto& ring : s.rings) {
                s.uv.emplace_back();
                for (const Vec3d& p : ring) s.uv.back().push_back(town.orthophoto.uv(p.x + o.x, p.y + o.y));
            }
        }
    }
}

}  // namespace

Town generateTown(const TownSettings& settings) {
    if (settings.buildings == 0) throw std::invalid_argument("a town needs at least one building");
    if (settings.lod != 1 && settings.lod != 2) throw std::invalid_argument("lod must be 1 or 2");
    Town town;
    town.settings = settings;
    town.materials = makeMaterials();
    town.paving_repeat_m = kPavingRepeat;

    SynthTexture paving;
    paving.kind = SynthTexture::Kind::Paving;
    paving.relative_path = "textures/paving.png";
    paving.size_px = settings.texture_size_px;
    paving.channels = 3;
    paving.seed = settings.seed;
    town.textures.push_back(paving);

    // A near-square grid of blocks, centred on the local origin.
    const uint32_t lots_per_block = kLotsX * kLotsY;
    const uint32_t blocks = (settings.buildings + lots_per_block - 1) / lots_per_block;
    const auto cols = static_cast<uint32_t>(std::ceil(std::sqrt(static_cast<double>(blocks))));
    const uint32_t rows = (blocks + cols - 1) / cols;
    const double pitch_x = kBlockW + kStreet, pitch_y = kBlockH + kStreet;
    const double town_w = cols * pitch_x - kStreet, town_h = rows * pitch_y - kStreet;

    town.buildings.reserve(settings.buildings);
    for (uint32_t i = 0; i < settings.buildings; ++i) {
        const uint32_t block = i / lots_per_block, lot = i % lots_per_block;
        const double x = -town_w / 2 + (block % cols) * pitch_x + (lot % kLotsX) * kLot + kLot / 2;
        const double y = -town_h / 2 + (block / cols) * pitch_y + (lot / kLotsX) * kLot + kLot / 2;
        const PlanPoint centre{static_cast<int64_t>(std::llround(x * kEighths)),
                               static_cast<int64_t>(std::llround(y * kEighths))};
        town.buildings.push_back(makeBuilding(settings, i + 1, centre, town));
    }
    if (settings.orthophoto != OrthophotoMode::None) coverRoofsWithOrthophoto(town);
    return town;
}

Scene townToScene(const Town& town, const std::filesystem::path& output_dir) {
    Scene scene;
    scene.georef.source_crs = fmt::format("EPSG:{}", town.settings.crs_epsg);
    scene.georef.origin_source = town.settings.origin_source;
    scene.materials = town.materials;
    for (const SynthTexture& t : town.textures) {
        TextureRef ref;
        ref.path = (output_dir / t.relative_path).lexically_normal().string();
        ref.width_px = ref.height_px = t.size_px;
        ref.channels = t.channels;
        ref.wrap = WrapMode::Wrap;
        if (t.kind == SynthTexture::Kind::Orthophoto) {
            ref.width_px = town.orthophoto.width_px, ref.height_px = town.orthophoto.height_px;
            ref.wrap = WrapMode::None;
        }
        scene.textures.push_back(ref);
    }
    for (const SynthBuilding& b : town.buildings) {
        Feature feature;
        feature.gml_id = b.gml_id;
        feature.name = fmt::format("Building {}", b.number);
        feature.measured_height_m = b.ridge_height_m;
        feature.roof_type = std::string(roofTypeCityGmlCode(b.roof));
        feature.attributes["footprint_shape"] = std::string(shapeName(b.shape));
        feature.attributes["storeys"] = std::to_string(b.storeys);
        const auto feature_index = static_cast<uint32_t>(scene.features.size());
        scene.features.push_back(std::move(feature));

        for (const SynthSurface& s : b.surfaces) {
            PolygonRings rings;
            std::vector<Vec2d> uv_flat;
            std::vector<Vec3d> pos_flat;
            for (size_t r = 0; r < s.rings.size(); ++r) {
                rings.rings.emplace_back(s.rings[r]);
                pos_flat.insert(pos_flat.end(), s.rings[r].begin(), s.rings[r].end());
                if (!s.uv.empty()) uv_flat.insert(uv_flat.end(), s.uv[r].begin(), s.uv[r].end());
            }
            const PolygonTriangulation tri = triangulatePolygon(rings);
            for (const auto& idx : tri.triangles) {
                Triangle t;
                for (int k = 0; k < 3; ++k) {
                    t.position_local[k] = pos_flat[idx[k]];
                    if (!uv_flat.empty()) t.uv[k] = uv_flat[idx[k]];
                }
                t.texture = s.texture;
                t.material = s.texture >= 0 ? -1 : s.material;
                t.feature = feature_index;
                t.semantic = s.semantic;
                scene.triangles.push_back(t);
            }
        }
    }
    return scene;
}

}  // namespace cityatlas::synth
