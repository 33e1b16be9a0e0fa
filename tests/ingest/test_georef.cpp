// SPDX-License-Identifier: GPL-3.0-or-later
// Georeferencing (ingest/georef.h) checked against references that do not share
// its code path:
// * GeographicLib (Geocentric, LocalCartesian, UTMUPS/TransverseMercator: the
//   Krueger series, a different implementation from PROJ's Poder/Engsager);
// * PROJ's own API used plainly (proj_create_crs_to_crs, 2D source, no
//   promotion), the way any other program would use it;
// * closed-form estimates of the planar error (Earth curvature, UTM scale,
//   meridian convergence, arc-to-chord) computed here from the latitude alone.
// cs2cs, PROJ's command-line tool, is the reference in tests/cli/georef_cs2cs.sh.
#include "ingest/georef.h"

#include <gtest/gtest.h>

#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/TransverseMercator.hpp>
#include <GeographicLib/UTMUPS.hpp>
#include <proj.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <ostream>
#include <string>
#include <thread>
#include <vector>

namespace cityatlas {
namespace {

// Named tolerances (metres unless said otherwise).
constexpr double kMm = 1e-3;        // agreement of two exact computations of a position
constexpr double kAxisTol = 1e-12;  // unit length / orthogonality of the ENU axes
// toEnu vs local in an ENU frame (GRS80 vs WGS 84 ellipsoid: 1.6e-7 m at 10 km)
constexpr double kEnuIdentity_m = 1e-6;
constexpr double kDeg = std::numbers::pi / 180;

// WGS 84, for the closed-form estimates.
constexpr double kA = 6378137, kF = 1 / 298.257223563, kE2 = kF * (2 - kF), kK0 = 0.9996;

struct Georef {
    SourceCrs crs;
    std::unique_ptr<LocalFrame> frame;
    std::unique_ptr<LocalToEcef> map;
};

Status makeGeoref(const std::string& srs, const Vec3d& origin, Georef* g) {
    if (Status s = parseSrsName(srs, &g->crs); !s.ok()) return s;
    if (Status s = LocalFrame::create(g->crs, origin, &g->frame); !s.ok()) return s;
    return LocalToEcef::create(*g->frame, &g->map);
}

// ECEF straight from PROJ's API: proj_create_crs_to_crs(src, EPSG:4978) on the
// 2D source CRS, traditional GIS axis order. `source` in source CRS units.
Vec3d projEcef(const char* src, const Vec3d& source) {
    PJ_CONTEXT* ctx = proj_context_create();
    PJ* op = proj_create_crs_to_crs(ctx, src, "EPSG:4978", nullptr);
    PJ* norm = op ? proj_normalize_for_visualization(ctx, op) : nullptr;
    Vec3d out{std::numeric_limits<double>::quiet_NaN(), 0, 0};
    if (norm) {
        const PJ_COORD c = proj_trans(norm, PJ_FWD, proj_coord(source.x, source.y, source.z, 0));
        out = {c.xyz.x, c.xyz.y, c.xyz.z};
    }
    proj_destroy(norm);
    proj_destroy(op);
    proj_context_destroy(ctx);
    return out;
}

Vec3d column(const std::array<double, 16>& m, int j) { return {m[4 * j], m[4 * j + 1], m[4 * j + 2]}; }

// ---------------------------------------------------------------------------
// The ENU frame

struct FrameCase {
    const char* name;
    const char* srs;
    Vec3d origin;
};
const FrameCase kFrames[] = {
    {"berlin_utm33_etrs89", "EPSG:25833", {391779.259, 5820072.159, 34}},
    {"utm33s_south_of_equator", "EPSG:32733", {833000, 9900000, 0}},
    {"utm32n_north_of_equator", "EPSG:32632", {640000, 1000, 5}},
    {"berlin_wgs84_lonlat", "EPSG:4326", {13.405, 52.52, 34}},
    {"sydney_wgs84_lonlat", "EPSG:4326", {151.2, -33.9, 20}},
    {"near_north_pole", "EPSG:4326", {-120, 89.9, 0}},
    {"tokyo_jgd2011", "EPSG:6668", {139.767, 35.681, 40}},
};

void PrintTo(const FrameCase& c, std::ostream* os) { *os << c.name; }  // readable ctest names

class EnuFrame : public testing::TestWithParam<FrameCase> {};

TEST_P(EnuFrame, AxesAreOrthonormalRightHandedAndTheOriginColumnIsOriginEcef) {
    Georef g;
    Status s = makeGeoref(GetParam().srs, GetParam().origin, &g);
    ASSERT_TRUE(s.ok()) << s.error;
    EarthFrame earth;
    s = computeEarthFrame(*g.frame, &earth);
    ASSERT_TRUE(s.ok()) << s.error;
    const auto& m = earth.enu_to_ecef;
    const Vec3d e = column(m, 0), n = column(m, 1), u = column(m, 2);
    EXPECT_NEAR(length(e), 1, kAxisTol);
    EXPECT_NEAR(length(n), 1, kAxisTol);
    EXPECT_NEAR(length(u), 1, kAxisTol);
    EXPECT_LT(std::abs(dot(e, n)), kAxisTol);
    EXPECT_LT(std::abs(dot(e, u)), kAxisTol);
    EXPECT_LT(std::abs(dot(n, u)), kAxisTol);
    const Vec3d en = cross(e, n);
    EXPECT_LT(length(en - u), kAxisTol) << "e x n must be u (right-handed)";
    EXPECT_EQ(column(m, 3), earth.origin_ecef);
    EXPECT_EQ(m[3], 0);
    EXPECT_EQ(m[7], 0);
    EXPECT_EQ(m[11], 0);
    EXPECT_EQ(m[15], 1);
    EXPECT_EQ(earth.grid, g.crs.kind == SourceCrs::Kind::Projected);
    // Up is the WGS 84 normal: ECEF of (lat, lon, h) on WGS 84 is origin_ecef
    // (GeographicLib, independent of PROJ) ...
    double x, y, z;
    GeographicLib::Geocentric::WGS84().Forward(earth.origin_lat_deg, earth.origin_lon_deg, earth.origin_h_m, x, y, z);
    EXPECT_LT(length(Vec3d{x, y, z} - earth.origin_ecef), kMm);
    // ... and the rotation is GeographicLib's ENU -> ECEF rotation there
    // (row-major, ecef = rot * enu).
    std::vector<double> rot(9);
    GeographicLib::Geocentric::WGS84().Forward(earth.origin_lat_deg, earth.origin_lon_deg, earth.origin_h_m, x, y, z,
                                               rot);
    for (int row = 0; row < 3; ++row)
        for (int col = 0; col < 3; ++col) EXPECT_NEAR(m[4 * col + row], rot[3 * row + col], 1e-12);
    // The map and computeEarthFrame agree.
    EXPECT_EQ(g.map->earth().enu_to_ecef, earth.enu_to_ecef);
    Vec3d at_origin;
    ASSERT_TRUE(g.map->toEcef({0, 0, 0}, &at_origin));
    EXPECT_EQ(at_origin, earth.origin_ecef);
}

INSTANTIATE_TEST_SUITE_P(Frames, EnuFrame, testing::ValuesIn(kFrames),
                         [](const testing::TestParamInfo<FrameCase>& i) { return std::string(i.param.name); });

TEST(Georef, ReproducesTheGeographicLibReferenceValue) {
    // STACK.md: Geocentric::WGS84().Forward(52.52, 13.405, 34), equal to PROJ
    // EPSG:4978 to 1 mm.
    const Vec3d reference{3783265.180, 901649.797, 5038246.081};
    double x, y, z;
    GeographicLib::Geocentric::WGS84().Forward(52.52, 13.405, 34, x, y, z);
    EXPECT_LT(length(Vec3d{x, y, z} - reference), kMm);

    Georef lonlat;  // an ENU frame at exactly that point
    Status s = makeGeoref("EPSG:4326", {13.405, 52.52, 34}, &lonlat);
    ASSERT_TRUE(s.ok()) << s.error;
    EXPECT_LT(length(lonlat.map->earth().origin_ecef - reference), kMm);
    EXPECT_NEAR(lonlat.map->earth().origin_lat_deg, 52.52, 1e-12);
    EXPECT_NEAR(lonlat.map->earth().origin_lon_deg, 13.405, 1e-12);
    EXPECT_NEAR(lonlat.map->earth().origin_h_m, 34, 1e-9);

    Georef utm;  // the same place in ETRS89 / UTM 33N (STACK.md's PROJ probe)
    s = makeGeoref("EPSG:25833", {391779.259, 5820072.159, 34}, &utm);
    ASSERT_TRUE(s.ok()) << s.error;
    const EarthFrame& e = utm.map->earth();
    EXPECT_LT(length(e.origin_ecef - Vec3d{3783265.180, 901649.796, 5038246.081}), kMm);
    // Latitude and longitude through GeographicLib's own UTM (1e-8 deg ~ 1 mm).
    double lat, lon;
    GeographicLib::UTMUPS::Reverse(33, true, 391779.259, 5820072.159, lat, lon);
    EXPECT_NEAR(e.origin_lat_deg, lat, 1e-8);
    EXPECT_NEAR(e.origin_lon_deg, lon, 1e-8);
    EXPECT_NEAR(e.origin_h_m, 34, kMm);
    EXPECT_NE(e.operation.find("UTM zone 33N"), std::string::npos) << e.operation;
}

// ---------------------------------------------------------------------------
// toEcef against PROJ's API

TEST(Georef, Berlin25833MatchesProjApiWithin1mmAtTheOriginAnd1And10Km) {
    const Vec3d origin{391779.259, 5820072.159, 34};
    Georef g;
    Status s = makeGeoref("EPSG:25833", origin, &g);
    ASSERT_TRUE(s.ok()) << s.error;
    for (double d : {0.0, 1000.0, 10000.0})
        for (int deg = 0; deg < 360; deg += 45)
            for (double dz : {0.0, -30.0, 250.0}) {
                const Vec3d local{d * std::cos(deg * kDeg), d * std::sin(deg * kDeg), dz};
                Vec3d ecef;
                ASSERT_TRUE(g.map->toEcef(local, &ecef));
                const Vec3d ref = projEcef("EPSG:25833", origin + local);
                EXPECT_LT(length(ecef - ref), kMm) << "d=" << d << " dir=" << deg << " dz=" << dz;
            }
}

TEST(Georef, ExtremeAndEquatorialUtmMatchProjApi) {
    struct C {
        const char* srs;
        Vec3d origin;
    };
    for (const C& c :
         {C{"EPSG:32733", {833000, 9900000, 0}}, C{"EPSG:32632", {640000, 1000, 5}}, C{"EPSG:32632", {500000, 0, 0}}}) {
        Georef g;
        Status s = makeGeoref(c.srs, c.origin, &g);
        ASSERT_TRUE(s.ok()) << s.error;
        for (const Vec3d& local :
             {Vec3d{0, 0, 0}, Vec3d{1000, -1000, 3}, Vec3d{-10000, -5000, 40}, Vec3d{7000, 7000, 0}}) {
            Vec3d ecef;
            ASSERT_TRUE(g.map->toEcef(local, &ecef));
            EXPECT_LT(length(ecef - projEcef(c.srs, c.origin + local)), kMm)
                << c.srs << " " << local.x << "," << local.y;
        }
    }
}

// ---------------------------------------------------------------------------
// ENU frames

TEST(Georef, EnuFrameOnAWgs84CompatibleDatumHasIdentityToEnuAndNoPlanarError) {
    for (const FrameCase& c : {kFrames[3], kFrames[4], kFrames[5], kFrames[6]}) {
        Georef g;
        Status s = makeGeoref(c.srs, c.origin, &g);
        ASSERT_TRUE(s.ok()) << s.error;
        EXPECT_FALSE(g.map->grid());
        for (const Vec3d& local :
             {Vec3d{10000, 0, 0}, Vec3d{0, -10000, 0}, Vec3d{-7000, 7000, 150}, Vec3d{3, 4, -20}}) {
            Vec3d enu;
            ASSERT_TRUE(g.map->toEnu(local, &enu));
            EXPECT_LT(length(enu - local), kEnuIdentity_m) << c.name;
            double h, v;
            ASSERT_TRUE(g.map->planarError(local, &h, &v));
            EXPECT_LT(h, kEnuIdentity_m);
            EXPECT_LT(v, kEnuIdentity_m);
            // and enu_to_ecef maps the local point exactly
            Vec3d ecef;
            ASSERT_TRUE(g.map->toEcef(local, &ecef));
            EXPECT_LT(length(transformPoint(g.map->earth().enu_to_ecef, local) - ecef), kEnuIdentity_m);
        }
        // The tangent-linear map of an ENU frame is enu_to_ecef.
        const auto tl = tangentLinearLocalToEcef(*g.map);
        for (int i = 0; i < 12; ++i) EXPECT_NEAR(tl[i], g.map->earth().enu_to_ecef[i], 1e-9) << c.name << " " << i;
        for (int i = 12; i < 16; ++i) EXPECT_EQ(tl[i], g.map->earth().enu_to_ecef[i]);
        EXPECT_EQ(localToEcefMatrix(*g.map), g.map->earth().enu_to_ecef);
    }
}

TEST(Georef, EnuFrameOnTheTokyoDatumShowsTheTiltBetweenTheEllipsoids) {
    // Tokyo (Bessel) -> WGS 84 is a real shift: the local tangent frame on Bessel
    // is tilted against WGS 84's by some arc seconds, and toEnu says so. Measured:
    // 0.33 m horizontal, 0.46 m vertical at 10 km east.
    Georef g;
    Status s = makeGeoref("EPSG:4301", {139.767, 35.681, 40}, &g);
    ASSERT_TRUE(s.ok()) << s.error;
    double h, v;
    ASSERT_TRUE(g.map->planarError({10000, 0, 0}, &h, &v));
    EXPECT_GT(h + v, 0.1);
    EXPECT_LT(h + v, 2.0);  // < 40" of tilt
}

// ---------------------------------------------------------------------------
// Grid frames: tangent-linear map

TEST(Georef, TangentLinearMapHasTheGridScaleAndMeridianConvergence) {
    struct C {
        const char* srs;
        int zone;
        bool north;
        Vec3d origin;
    };
    for (const C& c :
         {C{"EPSG:25833", 33, true, {391779.259, 5820072.159, 34}}, C{"EPSG:32733", 33, false, {833000, 9900000, 0}},
          C{"EPSG:32633", 33, true, {200000, 5817000, 0}}, C{"EPSG:32632", 32, true, {640000, 1000, 5}}}) {
        Georef g;
        Status s = makeGeoref(c.srs, c.origin, &g);
        ASSERT_TRUE(s.ok()) << s.error;
        ASSERT_TRUE(g.map->grid());
        const auto tl = tangentLinearLocalToEcef(*g.map);
        EXPECT_EQ(localToEcefMatrix(*g.map), tl);
        EXPECT_EQ(column(tl, 3), g.map->earth().origin_ecef);
        // GeographicLib's UTM: scale k and convergence gamma at the origin.
        double lat, lon, x, y, gamma_deg, k;
        GeographicLib::UTMUPS::Reverse(c.zone, c.north, c.origin.x, c.origin.y, lat, lon);
        GeographicLib::TransverseMercator::UTM().Forward(6.0 * c.zone - 183, lat, lon, x, y, gamma_deg, k);
        // At ellipsoidal height h a grid metre is also stretched by 1 + h / N
        // (east-west) and 1 + h / M (north-south): 5 ppm at h = 34 m.
        const double sphi = std::sin(lat * kDeg), w = std::sqrt(1 - kE2 * sphi * sphi);
        const double n_radius = kA / w, m_radius = kA * (1 - kE2) / (w * w * w);
        const Vec3d je = column(tl, 0), jn = column(tl, 1), ju = column(tl, 2);
        EXPECT_NEAR(length(je) * k, 1 + c.origin.z / n_radius, 1e-9) << c.srs;
        EXPECT_NEAR(length(jn) * k, 1 + c.origin.z / m_radius, 1e-9) << c.srs;
        EXPECT_NEAR(length(ju), 1, 1e-9) << c.srs;
        EXPECT_LT(std::abs(dot(je, jn)) * k * k, 1e-9) << "conformal: the grid axes stay orthogonal";
        // The grid east axis is turned from true east by the convergence.
        const Vec3d east = column(g.map->earth().enu_to_ecef, 0), north = column(g.map->earth().enu_to_ecef, 1);
        const double angle = std::atan2(dot(je, north), dot(je, east));
        EXPECT_NEAR(std::abs(angle), std::abs(gamma_deg) * kDeg, 1e-8) << c.srs;
        EXPECT_LT(length(ju - column(g.map->earth().enu_to_ecef, 2)), 1e-9) << "up is the ellipsoid normal";
    }
}

// Residual of the tangent-linear map: curvature drop d^2 / (2 R) vertically,
// the arc-to-chord term ~ d^2 |x| / (2 R^2) horizontally.
TEST(Georef, TangentLinearResidualIsTheCurvatureDrop) {
    for (double easting : {500000.0, 200000.0}) {
        Georef g;
        Status s = makeGeoref("EPSG:32633", {easting, 5817000, 0}, &g);
        ASSERT_TRUE(s.ok()) << s.error;
        const auto tl = tangentLinearLocalToEcef(*g.map);
        const double lat = g.map->earth().origin_lat_deg * kDeg;
        const double w = std::sqrt(1 - kE2 * std::sin(lat) * std::sin(lat));
        const double r = kA * std::sqrt(1 - kE2) / (w * w);  // Gaussian mean radius sqrt(M N)
        for (double d : {1000.0, 10000.0})
            for (int deg = 0; deg < 360; deg += 45) {
                const Vec3d local{d * std::cos(deg * kDeg), d * std::sin(deg * kDeg), 0};
                Vec3d ecef;
                ASSERT_TRUE(g.map->toEcef(local, &ecef));
                const Vec3d diff = ecef - transformPoint(tl, local);
                const auto& m = g.map->earth().enu_to_ecef;
                const double up = dot(diff, column(m, 2));
                const double horizontal = std::hypot(dot(diff, column(m, 0)), dot(diff, column(m, 1)));
                EXPECT_NEAR(-up, d * d / (2 * r), 0.005 * d * d / (2 * r)) << easting << " " << d << " " << deg;
                const double x = easting - 500000;
                EXPECT_LT(horizontal, 1.2 * d * d * (std::abs(x) + d) / (2 * r * r) + kMm) << easting << " " << d;
            }
    }
}

// ---------------------------------------------------------------------------
// Planar error vs an independent estimate

struct PlanarCase {
    const char* name;
    const char* srs;
    int zone;
    bool north;
    double easting, northing;
};
const PlanarCase kPlanar[] = {
    {"central_meridian_52N", "EPSG:32633", 33, true, 500000, 5817000},
    {"300km_west_of_cm_52N", "EPSG:32633", 33, true, 200000, 5817000},
    {"300km_east_of_cm_52N", "EPSG:32633", 33, true, 800000, 5817000},
    {"central_meridian_equator", "EPSG:32632", 32, true, 500000, 1000},
    {"300km_west_of_cm_equator", "EPSG:32632", 32, true, 200000, 1000},
    {"utm33s_northing_9_9e6", "EPSG:32733", 33, false, 833000, 9900000},
};

void PrintTo(const PlanarCase& c, std::ostream* os) { *os << c.name; }

class PlanarError : public testing::TestWithParam<PlanarCase> {};

// The estimate, from the latitude and longitude of the origin only (through
// GeographicLib's UTM inverse; nothing of PROJ), for a grid displacement
// p = d (cos t, sin t, 0):
//  * the true (tangent-plane) vector is the grid vector scaled by 1/k, turned
//    by the grid -> true rotation D, and shortened from arc to chord:
//      enu ~ (s - s^3 / (6 R^2)) e^{i(t + D)},  s = d / k
//  * k: the UTM scale k0 (1 + x^2 / (2 R^2)) with x^2 averaged along the path
//    (x = distance from the central meridian): "k at that easting";
//  * D = gamma + delta: meridian convergence at the origin, gamma =
//    atan(tan(dlon) sin(lat)) (spherical), plus the arc-to-chord ("t - T")
//    correction delta = dy (2 x1 + x2) / (6 R^2) of surveying textbooks;
//  * horizontal error = |enu - p|; at the central meridian (gamma = delta = 0)
//    that is |1 - 1/k| d to first order, as the brief states it;
//  * vertical error = s^2 / (2 R_a): the Earth's curvature drop, R_a Euler's
//    radius of curvature in the azimuth of the displacement.
// R = sqrt(M N), the Gaussian mean radius at the origin's latitude.
TEST_P(PlanarError, MatchesCurvatureScaleAndConvergenceEstimate) {
    const PlanarCase& c = GetParam();
    Georef g;
    Status s = makeGeoref(c.srs, {c.easting, c.northing, 0}, &g);
    ASSERT_TRUE(s.ok()) << s.error;
    double lat_deg, lon_deg;
    GeographicLib::UTMUPS::Reverse(c.zone, c.north, c.easting, c.northing, lat_deg, lon_deg);
    const double lat = lat_deg * kDeg, dlon = (lon_deg - (6.0 * c.zone - 183)) * kDeg;
    const double w = std::sqrt(1 - kE2 * std::sin(lat) * std::sin(lat));
    const double m_radius = kA * (1 - kE2) / (w * w * w), n_radius = kA / w;
    const double r = std::sqrt(m_radius * n_radius);
    const double gamma = std::atan(std::tan(dlon) * std::sin(lat));

    std::printf("  %-26s lat %8.4f  gamma %+8.4f deg\n", c.name, lat_deg, gamma / kDeg);
    for (double d : {1000.0, 10000.0}) {
        double worst_h = 0, worst_v = 0, max_h = 0, max_v = 0;
        for (int deg = 0; deg < 360; deg += 45) {
            const double t = deg * kDeg;
            const Vec3d local{d * std::cos(t), d * std::sin(t), 0};
            double h, v;
            ASSERT_TRUE(g.map->planarError(local, &h, &v));

            const double x1 = (c.easting - 500000) / kK0, x2 = x1 + local.x / kK0;  // true-scale distances from the CM
            const double k = kK0 * (1 + (x1 * x1 + x1 * x2 + x2 * x2) / 3 / (2 * r * r));
            const double delta = (local.y / kK0) * (2 * x1 + x2) / (6 * r * r);
            const double dturn = gamma + delta;
            const double arc = d / k, chord = arc - arc * arc * arc / (6 * r * r);
            const double h_est = std::hypot(chord * std::cos(dturn) - d, chord * std::sin(dturn));
            const double azimuth = std::numbers::pi / 2 - t + gamma;
            const double r_a = 1 / (std::cos(azimuth) * std::cos(azimuth) / m_radius +
                                    std::sin(azimuth) * std::sin(azimuth) / n_radius);
            const double v_est = arc * arc / (2 * r_a);

            // Tolerances: the estimate neglects the ellipsoid's terms in k and
            // gamma (k is 1e-6 off at 300 km from the CM) and third-order
            // terms: 1e-6 of the distance + 1 mm horizontally (measured: <= 3.6
            // mm at 10 km); 1 mm vertically (measured: <= 0.06 mm).
            EXPECT_NEAR(h, h_est, 1e-6 * d + kMm) << c.name << " d=" << d << " dir=" << deg;
            EXPECT_NEAR(v, v_est, kMm) << c.name << " d=" << d << " dir=" << deg;
            if (gamma == 0 && c.easting == 500000) {  // the brief's first-order form at the central meridian
                EXPECT_NEAR(h, std::abs(1 - 1 / k) * d, 0.003 * h) << c.name << " d=" << d << " dir=" << deg;
            }
            worst_h = std::max(worst_h, std::abs(h - h_est));
            worst_v = std::max(worst_v, std::abs(v - v_est));
            max_h = std::max(max_h, h);
            max_v = std::max(max_v, v);
        }
        std::printf(
            "    d = %5.0f m: planar error up to %9.4f m horizontal, %7.4f m vertical;"
            " |estimate - actual| <= %.4f m, %.5f m\n",
            d, max_h, max_v, worst_h, worst_v);
    }
}

INSTANTIATE_TEST_SUITE_P(Towns, PlanarError, testing::ValuesIn(kPlanar),
                         [](const testing::TestParamInfo<PlanarCase>& i) { return std::string(i.param.name); });

// ---------------------------------------------------------------------------
// Heights and compound CRSs (see the header: no geoid of our own)

TEST(Georef, CompoundCrsWithoutItsGeoidGridFallsBackToEllipsoidalHeights) {
    // DHHN2016 needs GCG2016, which proj-data does not bundle: PROJ uses a
    // ballpark vertical transformation, i.e. the heights pass unchanged.
    Georef compound, plain;
    const Vec3d origin{391779.259, 5820072.159, 34};
    Status s = makeGeoref("urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::7837", origin, &compound);
    ASSERT_TRUE(s.ok()) << s.error;
    ASSERT_EQ(compound.crs.definition, "EPSG:25832+7837");
    s = makeGeoref("EPSG:25832", origin, &plain);
    ASSERT_TRUE(s.ok()) << s.error;
    EXPECT_NE(compound.map->earth().operation.find("ballpark"), std::string::npos) << compound.map->earth().operation;
    for (const Vec3d& local : {Vec3d{0, 0, 0}, Vec3d{5000, -3000, 60}}) {
        Vec3d a, b;
        ASSERT_TRUE(compound.map->toEcef(local, &a));
        ASSERT_TRUE(plain.map->toEcef(local, &b));
        EXPECT_LT(length(a - b), kMm);
    }
}

TEST(Georef, CompoundCrsWithItsGeoidGridGetsOrthometricHeightsConverted) {
    // EGM96 ships with proj-data: PROJ turns the height above the geoid into an
    // ellipsoidal one. EGM96's undulation at Berlin is about +39.5 m.
    Georef g;
    Status s = makeGeoref("urn:ogc:def:crs,crs:EPSG::4326,crs:EPSG::5773", {13.405, 52.52, 34}, &g);
    ASSERT_TRUE(s.ok()) << s.error;
    EXPECT_NE(g.map->earth().operation.find("EGM96"), std::string::npos) << g.map->earth().operation;
    const double undulation = g.map->earth().origin_h_m - 34;
    EXPECT_GT(undulation, 35);
    EXPECT_LT(undulation, 45);
}

TEST(Georef, LocalEngineeringCrsHasNoEarthFrame) {
    SourceCrs crs;
    ASSERT_TRUE(parseSrsName("#local-CRS-1", &crs).ok());
    std::unique_ptr<LocalFrame> frame;
    ASSERT_TRUE(LocalFrame::create(crs, {0, 0, 0}, &frame).ok());
    EarthFrame earth;
    EXPECT_FALSE(computeEarthFrame(*frame, &earth).ok());
    std::unique_ptr<LocalToEcef> map;
    const Status s = LocalToEcef::create(*frame, &map);
    EXPECT_FALSE(s.ok());
    EXPECT_NE(s.error.find("no link to the Earth"), std::string::npos) << s.error;
    EXPECT_EQ(map, nullptr);
}

TEST(Georef, NonFinitePointsFailWithoutPoisoningLaterCalls) {
    Georef g;
    Status s = makeGeoref("EPSG:25833", {391779.259, 5820072.159, 34}, &g);
    ASSERT_TRUE(s.ok()) << s.error;
    Vec3d ecef;
    EXPECT_FALSE(g.map->toEcef({std::numeric_limits<double>::quiet_NaN(), 0, 0}, &ecef));
    EXPECT_FALSE(std::isfinite(ecef.x));
    double h, v;
    EXPECT_FALSE(g.map->planarError({std::numeric_limits<double>::infinity(), 0, 0}, &h, &v));
    ASSERT_TRUE(g.map->toEcef({0, 0, 0}, &ecef));
    EXPECT_EQ(ecef, g.map->earth().origin_ecef);
}

// ---------------------------------------------------------------------------
// Threads and batches

TEST(Georef, ConcurrentCallsGiveTheSameBitsAsOneThread) {
    Georef g;
    Status s = makeGeoref("EPSG:25833", {391779.259, 5820072.159, 34}, &g);
    ASSERT_TRUE(s.ok()) << s.error;
    std::vector<Vec3d> points;
    for (int i = 0; i < 2000; ++i)
        points.push_back({std::fmod(i * 37.3, 20000) - 10000, std::fmod(i * 91.7, 20000) - 10000, i * 0.01});
    std::vector<Vec3d> serial(points.size());
    for (size_t i = 0; i < points.size(); ++i) ASSERT_TRUE(g.map->toEcef(points[i], &serial[i]));

    constexpr int kThreads = 8;
    std::vector<std::vector<Vec3d>> results(kThreads, std::vector<Vec3d>(points.size()));
    std::vector<int> failures(kThreads, 0);
    std::vector<std::thread> threads;
    for (int t = 0; t < kThreads; ++t)
        threads.emplace_back([&, t] {
            for (size_t i = 0; i < points.size(); ++i)
                if (!g.map->toEcef(points[(i + t * 250) % points.size()], &results[t][(i + t * 250) % points.size()]))
                    ++failures[t];
        });
    for (auto& th : threads) th.join();
    for (int t = 0; t < kThreads; ++t) {
        EXPECT_EQ(failures[t], 0);
        EXPECT_EQ(results[t], serial) << "thread " << t;
    }

    std::vector<Vec3d> batch(points.size());
    ASSERT_TRUE(g.map->toEcef(std::span<const Vec3d>(points), std::span<Vec3d>(batch)));
    EXPECT_EQ(batch, serial);
}

}  // namespace
}  // namespace cityatlas
