// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Sun hours (issue 19's `sun_hours` computed texture; papers/000 §5.1's "the
/// annual average number of hours per day during which the sun is visible"):
/// the fraction of a year's daylight sun positions that reach a surface point.
///
/// Sun positions come from libnova (apparent solar coordinates, VSOP87, then
/// the observer's horizon; no atmospheric refraction: the sun counts from the
/// moment its centre's geometric altitude is above 0). A year is sampled as
/// `days` representative days (the 15th of each month for 12), every
/// `step_minutes` over the 24 hours of UTC, starting at 00:00 + step / 2;
/// daylight steps are those with the sun above the horizon. A point receives
/// a step's sun when the sun is in front of its surface (n . s > 0) and the
/// ray toward it leaves the scene (RayCaster::occluded).
///
/// Directions are east, north, up (ENU) at the given latitude and longitude.
/// A scene in a projected CRS has grid north, not true north: the caller
/// rotates the directions into the scene's frame (meridian convergence).

#include <array>
#include <optional>
#include <vector>

#include "atlas/raycast.h"
#include "core/geometry.h"
#include "ingest/scene.h"

namespace cityatlas::atlas {

struct SunSchedule {
    double latitude_deg = 0, longitude_deg = 0;  ///< WGS 84, east positive
    int year = 2025;
    int days = 12;             ///< 12: the 15th of each month; otherwise that many days from January 1
    double step_minutes = 15;
};

/// The unit direction toward the sun (ENU) at Julian day `jd` (UT), seen
/// from `latitude_deg`, `longitude_deg`.
Vec3d sunDirectionEnu(double latitude_deg, double longitude_deg, double jd);

/// The sun's directions (ENU) at every daylight step of the schedule.
std::vector<Vec3d> daylightSunDirections(const SunSchedule& schedule);

/// The sun as a disc (issue 19's `shadow` computed texture; papers/000
/// §5.2.3's smooth shadows, done physically): a soft shadow is the fraction
/// of the disc a point sees, sunHoursFraction over these directions.
struct SunDisc {
    double azimuth_deg = 180;   ///< clockwise from north (ENU: 90 = east)
    double elevation_deg = 45;
    double radius_deg = 0.2665; ///< the sun's own angular radius; larger softens the penumbra
    int samples = 256;
};

/// `samples` unit directions (ENU) spread evenly over the disc's area (a
/// Vogel spiral: radius sqrt((i + 1/2) / n), the golden angle between
/// successive points).
std::vector<Vec3d> sunDiscDirections(const SunDisc& disc);

/// Where the sun is seen from, and how its ENU directions turn into the
/// scene's local frame: local = A^-1 E d, with A the 3x3 part of the
/// georeference's local_to_ecef (for a grid frame the tangent-linear map at
/// the origin, which holds the grid's meridian convergence and scale) and E
/// that of enu_to_ecef; the result normalised. Latitude and longitude are
/// the origin's, from E's up axis (the ellipsoid normal).
struct SunFrame {
    double latitude_deg = 0, longitude_deg = 0;
    std::array<double, 9> enu_to_local{};  ///< row-major 3x3, before normalising
    Vec3d toLocal(const Vec3d& enu) const;
};
/// Nullopt for a scene without a georeference (a local engineering CRS):
/// it has no sun.
std::optional<SunFrame> sunFrame(const Georeference& georef);

/// The fraction of `sun` (unit directions in the caster's frame) that reach
/// `point` on a surface with outward `normal`: in front of the surface and
/// not blocked (by a triangle within `far_m`). Rays start 1 cm off the
/// surface. 0 when `sun` is empty.
double sunHoursFraction(const RayCaster& caster, const Vec3d& point, const Vec3d& normal, const std::vector<Vec3d>& sun,
                        double far_m = std::numeric_limits<double>::infinity());

}  // namespace cityatlas::atlas
