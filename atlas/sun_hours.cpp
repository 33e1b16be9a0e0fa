// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/sun_hours.h"

#include <libnova/julian_day.h>
#include <libnova/solar.h>
#include <libnova/transform.h>

#include <algorithm>
#include <cmath>

namespace cityatlas::atlas {
namespace {

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

Vec3d SunFrame::toLocal(const Vec3d& d) const {
    const auto& m = enu_to_local;
    const Vec3d v{m[0] * d.x + m[1] * d.y + m[2] * d.z, m[3] * d.x + m[4] * d.y + m[5] * d.z,
                  m[6] * d.x + m[7] * d.y + m[8] * d.z};
    return (1.0 / length(v)) * v;
}

std::optional<SunFrame> sunFrame(const Georeference& g) {
    if (!g.local_to_ecef || !g.enu_to_ecef) return std::nullopt;
    // 3x3 parts, row-major, of the column-major 4x4 matrices.
    auto part = [](const std::array<double, 16>& m) {
        return std::array<double, 9>{m[0], m[4], m[8], m[1], m[5], m[9], m[2], m[6], m[10]};
    };
    const std::array<double, 9> a = part(*g.local_to_ecef), e = part(*g.enu_to_ecef);
    // A^-1 by the adjugate.
    const double det = a[0] * (a[4] * a[8] - a[5] * a[7]) - a[1] * (a[3] * a[8] - a[5] * a[6]) +
                       a[2] * (a[3] * a[7] - a[4] * a[6]);
    if (!(std::abs(det) > 0) || !std::isfinite(det)) return std::nullopt;
    const std::array<double, 9> inv{(a[4] * a[8] - a[5] * a[7]) / det, (a[2] * a[7] - a[1] * a[8]) / det,
                                    (a[1] * a[5] - a[2] * a[4]) / det, (a[5] * a[6] - a[3] * a[8]) / det,
                                    (a[0] * a[8] - a[2] * a[6]) / det, (a[2] * a[3] - a[0] * a[5]) / det,
                                    (a[3] * a[7] - a[4] * a[6]) / det, (a[1] * a[6] - a[0] * a[7]) / det,
                                    (a[0] * a[4] - a[1] * a[3]) / det};
    SunFrame f;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            f.enu_to_local[3 * r + c] = inv[3 * r] * e[c] + inv[3 * r + 1] * e[3 + c] + inv[3 * r + 2] * e[6 + c];
    // E's third column, up = (cos lat cos lon, cos lat sin lon, sin lat).
    const Vec3d up{e[2], e[5], e[8]};
    f.latitude_deg = std::asin(std::clamp(up.z / length(up), -1.0, 1.0)) * 180.0 / M_PI;
    f.longitude_deg = std::atan2(up.y, up.x) * 180.0 / M_PI;
    return f;
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

double sunHoursFraction(const RayCaster& caster, const Vec3d& point, const Vec3d& normal, const std::vector<Vec3d>& sun,
                        double far_m) {
    if (sun.empty() || !(length(normal) > 0)) return 0;
    const Vec3d origin = surfaceRayOrigin(point, normal);
    size_t lit = 0;
    for (const Vec3d& s : sun)
        if (dot(s, normal) > 0 && !caster.occluded(origin, s, 0, far_m)) ++lit;
    return static_cast<double>(lit) / static_cast<double>(sun.size());
}

}  // namespace cityatlas::atlas
