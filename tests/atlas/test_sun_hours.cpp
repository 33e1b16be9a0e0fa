// SPDX-License-Identifier: GPL-3.0-or-later
// Sun hours (atlas/sun_hours.h; issue 19): the sun's position against
// published almanac values, and the fraction of daylight a surface receives
// against closed forms:
// - Berlin (52.52 N, 13.405 E), 21 June 2026: solar noon at 11:08 UTC
//   (13:08 CEST in the almanacs) at an altitude of 60.9 degrees
//   (90 - 52.52 + 23.44), due south;
// - an unobstructed horizontal roof receives every daylight step: 1;
// - an unobstructed north-facing wall: on a day of declination d > 0 at
//   latitude p the sun stands north of the wall's plane while the hour angle
//   is beyond acos(tan d / tan p), within the day's acos(-tan p tan d); the
//   year's fraction is the sum of those spans over the sum of the days
//   (none on days with d <= 0);
// - a slab in front of a south wall blocks what the geometry says it blocks.
#include "atlas/sun_hours.h"

#include <gtest/gtest.h>
#include <libnova/julian_day.h>
#include <libnova/solar.h>

#include <cmath>

namespace cityatlas::atlas {
namespace {

double degrees(double r) { return r * 180.0 / M_PI; }

TEST(SunHours, BerlinSolarNoonAtTheSolsticeMatchesTheAlmanac) {
    ln_date day{2026, 6, 21, 0, 0, 0.0};
    const double jd0 = ln_get_julian_day(&day);
    double best_alt = -1, best_minute = 0;
    Vec3d best_dir;
    for (int minute = 0; minute < 24 * 60; ++minute) {
        const Vec3d s = sunDirectionEnu(52.52, 13.405, jd0 + minute / 1440.0);
        EXPECT_NEAR(length(s), 1, 1e-12);
        const double alt = degrees(std::asin(s.z));
        if (alt > best_alt) best_alt = alt, best_minute = minute, best_dir = s;
    }
    std::printf("  noon at %02d:%02d UTC, altitude %.3f deg\n", static_cast<int>(best_minute) / 60,
                static_cast<int>(best_minute) % 60, best_alt);
    EXPECT_NEAR(best_minute, 11 * 60 + 8, 3);
    EXPECT_NEAR(best_alt, 90 - 52.52 + 23.44, 0.1);
    EXPECT_LT(best_dir.y, 0);                       // south
    EXPECT_NEAR(best_dir.x / -best_dir.y, 0, 0.01);  // due south, within the minute's turn
    // Morning in the east, evening in the west (three hours either side of noon).
    EXPECT_GT(sunDirectionEnu(52.52, 13.405, jd0 + (best_minute - 180) / 1440.0).x, 0.5);
    EXPECT_LT(sunDirectionEnu(52.52, 13.405, jd0 + (best_minute + 180) / 1440.0).x, -0.5);
}

TEST(SunHours, UnobstructedRoofGetsEveryDaylightStep) {
    const auto caster = RayCaster::build({});
    const auto sun = daylightSunDirections({52.52, 13.405, 2025, 12, 15});
    ASSERT_GT(sun.size(), 400u);  // about 12 h a day on average, 4 steps an hour
    ASSERT_LT(sun.size(), 800u);
    for (const Vec3d& s : sun) ASSERT_GT(s.z, 0);
    EXPECT_EQ(sunHoursFraction(*caster, {0, 0, 10}, {0, 0, 1}, sun), 1.0);
    EXPECT_EQ(sunHoursFraction(*caster, {0, 0, 10}, {0, 0, -1}, sun), 0.0);  // facing down
}

TEST(SunHours, NorthFacingWallGetsTheClosedFormFraction) {
    const double lat = 52.52, lon = 13.405;
    SunSchedule schedule{lat, lon, 2025, 12, 1};  // one-minute steps: the sampling error stays below 0.003
    const auto caster = RayCaster::build({});
    const double got = sunHoursFraction(*caster, {0, 0, 5}, {0, 1, 0}, daylightSunDirections(schedule));
    // The closed form, with each day's declination at its noon.
    const double p = lat * M_PI / 180.0;
    double north = 0, day = 0;
    for (int m = 1; m <= 12; ++m) {
        ln_date noon{2025, m, 15, 12, 0, 0.0};
        ln_equ_posn equ{};
        ln_get_solar_equ_coords(ln_get_julian_day(&noon), &equ);
        const double d = equ.dec * M_PI / 180.0;
        const double h0 = std::acos(std::clamp(-std::tan(p) * std::tan(d), -1.0, 1.0));
        day += 2 * h0;
        if (d > 0) north += 2 * (h0 - std::acos(std::clamp(std::tan(d) / std::tan(p), -1.0, 1.0)));
    }
    std::printf("  north wall at %.2f N: %.4f of daylight, closed form %.4f\n", lat, got, north / day);
    EXPECT_GT(north / day, 0.05);
    EXPECT_NEAR(got, north / day, 0.003);
}

// A south wall at y = 0 facing -y, a 20 m slab 10 m in front of it (its top
// at z = 20, from y = -10 to -11, x from -500 to 500): a point at height z
// sees the sun only where tan(altitude) * (horizontal run to the slab along
// the sun's azimuth) exceeds the slab's rise over it; counted here directly.
TEST(SunHours, ASlabBlocksWhatTheGeometrySays) {
    std::vector<std::array<Vec3d, 3>> tris;
    const Vec3d a{-500, -10, 0}, b{500, -10, 0}, c{500, -10, 20}, d{-500, -10, 20};
    tris.push_back({a, b, c});
    tris.push_back({a, c, d});
    const auto caster = RayCaster::build(tris);
    const auto sun = daylightSunDirections({52.52, 13.405, 2025, 12, 15});
    for (double z : {2.0, 10.0, 19.0}) {
        const Vec3d origin{0, 0.0 - 0.01, z};  // the 1 cm offset the function applies
        size_t expected = 0;
        for (const Vec3d& s : sun) {
            if (s.y >= 0) continue;  // behind the wall
            const double t = (-10 - origin.y) / s.y;  // ray parameter at the slab's plane
            const double x = origin.x + t * s.x, h = origin.z + t * s.z;
            const bool blocked = x > -500 && x < 500 && h < 20;
            expected += !blocked;
        }
        const double got = sunHoursFraction(*caster, {0, 0, z}, {0, -1, 0}, sun);
        std::printf("  south wall at z %.0f m: %.4f\n", z, got);
        EXPECT_NEAR(got, static_cast<double>(expected) / sun.size(), 1e-12);
    }
}

}  // namespace
}  // namespace cityatlas::atlas

namespace cityatlas::atlas {
namespace {

// A soft shadow (SunDisc): a 2 degree sun due south at 30 degrees over a
// long east-west wall 20 m high; a ground point x metres north of the wall's
// foot sees the wall's top at beta = atan(20 / x). With d = (beta - 30) / 2
// (degrees; the disc is small enough to be flat), the visible part of the
// disc is the segment above the line: (acos d - d sqrt(1 - d^2)) / pi, all
// of it for d <= -1 and none for d >= 1 (exactly: every sample is then on
// one side).
TEST(SunHours, SoftShadowOfAWallEdgeIsTheDiscSegment) {
    std::vector<std::array<Vec3d, 3>> tris;
    const Vec3d a{-2000, 0, 0}, b{2000, 0, 0}, c{2000, 0, 20}, d{-2000, 0, 20};
    tris.push_back({a, b, c});
    tris.push_back({a, c, d});
    const auto caster = RayCaster::build(tris);
    SunDisc disc;
    disc.azimuth_deg = 180, disc.elevation_deg = 30, disc.radius_deg = 2, disc.samples = 256;
    const auto dirs = sunDiscDirections(disc);
    ASSERT_EQ(dirs.size(), 256u);
    for (const Vec3d& s : dirs) {
        EXPECT_NEAR(length(s), 1, 1e-12);
        const double angle = std::acos(std::clamp(dot(s, dirs.front()), -1.0, 1.0)) * 180 / M_PI;
        EXPECT_LE(angle, 4.0 + 1e-9);  // within the disc's diameter of each other
        EXPECT_LT(s.y, 0);             // south
    }
    int full = 0, none = 0, partial = 0;
    double worst = 0;
    for (double x = 25; x <= 45; x += 0.25) {
        const double beta = std::atan(20 / x) * 180 / M_PI;
        const double dd = (beta - 30) / 2;
        const double got = sunHoursFraction(*caster, {0, x, 0}, {0, 0, 1}, dirs);
        if (dd <= -1.02) {
            EXPECT_EQ(got, 1.0) << "x " << x;
            ++full;
        } else if (dd >= 1.02) {
            EXPECT_EQ(got, 0.0) << "x " << x;
            ++none;
        } else {
            const double e = std::clamp(dd, -1.0, 1.0);
            const double expected = (std::acos(e) - e * std::sqrt(1 - e * e)) / M_PI;
            EXPECT_NEAR(got, expected, 0.02) << "x " << x;
            worst = std::max(worst, std::abs(got - expected));
            ++partial;
        }
    }
    std::printf("  %d lit, %d shadowed, %d penumbra points (off the segment by <= %.4f)\n", full, none, partial, worst);
    EXPECT_GT(full, 5);
    EXPECT_GT(none, 5);
    EXPECT_GT(partial, 10);
}

}  // namespace
}  // namespace cityatlas::atlas

#include <GeographicLib/TransverseMercator.hpp>
#include <GeographicLib/UTMUPS.hpp>

#include "ingest/georef.h"

namespace cityatlas::atlas {
namespace {

// The sun's ENU directions in a scene's local frame. A grid frame's north is
// grid north: in UTM, true north lies at grid bearing -gamma, gamma the
// meridian convergence (GeographicLib's, the bearing of grid north from true
// north), as the oracle; its latitude and longitude are GeographicLib's UTM
// inverse. An ENU frame is its own: the identity. No georeference, no sun.
TEST(SunHours, SunDirectionsTurnIntoTheScenesGridNorth) {
    struct Case {
        const char* srs;
        int zone;
        Vec3d origin;
    };
    for (const Case& c : {Case{"EPSG:25833", 33, {391779.259, 5820072.159, 34}}, Case{"EPSG:32633", 33, {200000, 5817000, 0}},
                          Case{"EPSG:32632", 32, {640000, 1000, 5}}}) {
        SourceCrs crs;
        ASSERT_TRUE(parseSrsName(c.srs, &crs).ok());
        std::unique_ptr<LocalFrame> frame;
        ASSERT_TRUE(LocalFrame::create(crs, c.origin, &frame).ok());
        std::unique_ptr<LocalToEcef> map;
        ASSERT_TRUE(LocalToEcef::create(*frame, &map).ok());
        Georeference g;
        g.local_to_ecef = localToEcefMatrix(*map);
        g.enu_to_ecef = map->earth().enu_to_ecef;
        const auto f = sunFrame(g);
        ASSERT_TRUE(f.has_value());
        double lat, lon, x, y, gamma_deg, k;
        GeographicLib::UTMUPS::Reverse(c.zone, true, c.origin.x, c.origin.y, lat, lon);
        GeographicLib::TransverseMercator::UTM().Forward(6.0 * c.zone - 183, lat, lon, x, y, gamma_deg, k);
        EXPECT_NEAR(f->latitude_deg, lat, 1e-6) << c.srs;
        EXPECT_NEAR(f->longitude_deg, lon, 1e-6) << c.srs;
        const Vec3d north = f->toLocal({0, 1, 0});
        std::printf("  %s: true north at grid bearing %.6f deg, convergence %.6f deg\n", c.srs,
                    std::atan2(north.x, north.y) * 180 / M_PI, gamma_deg);
        EXPECT_NEAR(std::atan2(north.x, north.y) * 180 / M_PI, -gamma_deg, 1e-6) << c.srs;
        EXPECT_NEAR(f->toLocal({0, 0, 1}).z, 1, 1e-9) << "up stays up";
    }
    // An ENU frame: the same matrix twice is the identity.
    Georeference enu;
    enu.local_to_ecef = enu.enu_to_ecef = std::array<double, 16>{0.6, 0.8, 0, 0, -0.8, 0.6, 0, 0, 0, 0, 1, 0, 1e6, 2e6, 3e6, 1};
    const Vec3d d = sunFrame(enu)->toLocal({0.6, 0, 0.8});
    EXPECT_NEAR(d.x, 0.6, 1e-12);
    EXPECT_NEAR(d.z, 0.8, 1e-12);
    EXPECT_FALSE(sunFrame(Georeference{}).has_value());
}

}  // namespace
}  // namespace cityatlas::atlas
