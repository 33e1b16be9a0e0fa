// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/sun_hours.h"

#include <libnova/julian_day.h>
#include <libnova/solar.h>
#include <libnova/transform.h>

#include <cmath>

namespace cityatlas::atlas {
namespace {

constexpr double kOffsetM = 0.01;  // as sky_view.cpp: clear of the surface at float precision

double radians(double deg) { return deg * M_PI / 180.0; }

}  // namespace

Vec3d sunDirectionEnu(double latitude_deg, double longitude_deg, double jd) {
    ln_equ_posn equ{};
    ln_get_solar_equ_coords(jd, &equ);
    ln_lnlat_posn observer{longitude_deg, latitude_deg};
    ln_hrz_posn hrz{};
    ln_get_hrz_from_equ(&equ, &observer, jd, &hrz);
    // libnova's azimuth runs from south through west: south (0, -1), west (-1, 0).
    const double az = radians(hrz.az), alt = radians(hrz.alt);
    return {-std::sin(az) * std::cos(alt), -std::cos(az) * std::cos(alt), std::sin(alt)};
}

std::vector<Vec3d> daylightSunDirections(const SunSchedule& s) {
    std::vector<Vec3d> out;
    if (!(s.step_minutes > 0) || s.days < 1) return out;
    ln_date jan1{s.year, 1, 1, 0, 0, 0.0};
    const double jd_year = ln_get_julian_day(&jan1);
    const int steps = static_cast<int>(std::floor(24.0 * 60.0 / s.step_minutes));
    for (int d = 0; d < s.days; ++d) {
        double jd_day = 0;
        if (s.days == 12) {
            ln_date mid{s.year, d + 1, 15, 0, 0, 0.0};
            jd_day = ln_get_julian_day(&mid);
        } else {
            jd_day = jd_year + d;
        }
        for (int k = 0; k < steps; ++k) {
            const double jd = jd_day + (k + 0.5) * s.step_minutes / (24.0 * 60.0);
            const Vec3d dir = sunDirectionEnu(s.latitude_deg, s.longitude_deg, jd);
            if (dir.z > 0) out.push_back(dir);
        }
    }
    return out;
}

std::vector<Vec3d> sunDiscDirections(const SunDisc& disc) {
    std::vector<Vec3d> out;
    const double az = radians(disc.azimuth_deg), el = radians(disc.elevation_deg);
    const Vec3d c{std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el)};
    const Vec3d e1{std::cos(az), -std::sin(az), 0};  // horizontal, across the sun's azimuth
    const Vec3d e2 = cross(e1, c);
    const double golden = M_PI * (3.0 - std::sqrt(5.0));
    for (int i = 0; i < disc.samples; ++i) {
        const double rho = radians(disc.radius_deg) * std::sqrt((i + 0.5) / disc.samples), phi = i * golden;
        const Vec3d d = c + std::tan(rho) * (std::cos(phi) * e1 + std::sin(phi) * e2);
        out.push_back((1.0 / length(d)) * d);
    }
    return out;
}

double sunHoursFraction(const RayCaster& caster, const Vec3d& point, const Vec3d& normal, const std::vector<Vec3d>& sun) {
    if (sun.empty() || !(length(normal) > 0)) return 0;
    const Vec3d n = (1.0 / length(normal)) * normal;
    const Vec3d origin = point + kOffsetM * n;
    size_t lit = 0;
    for (const Vec3d& s : sun)
        if (dot(s, n) > 0 && !caster.occluded(origin, s)) ++lit;
    return static_cast<double>(lit) / static_cast<double>(sun.size());
}

}  // namespace cityatlas::atlas
