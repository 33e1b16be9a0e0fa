// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Information lenses for streamed tiles (papers/003, Trapp; the lenses that
/// fit LOD1-2 tiles, SEED-FEATURES §5.2), GL-free: what a lens asks for, the
/// per-building state it gives (LensStyle, drawn by render/gl), and the
/// object-based occluder test.
///
/// - Occlusion lens: the occluders of a building of interest (POI) are the
///   buildings whose box meets a segment from the camera to one of the POI
///   box's sample points (papers/003 eq. 3.18, the view-axis test, with a
///   3 x 3 x 3 grid of points over the POI's box instead of its centre alone,
///   so a building that hides a corner of the POI counts), or that are near
///   the viewer: box centre within `sphere_radius_m` of the camera (the
///   spherical test, eq. 3.16), of the camera's vertical line (cylindrical,
///   the centre projected on the plane through the camera normal to its up
///   vector), or spherical and the box crossing that plane (viewer height,
///   eq. 3.17: the buildings at eye level around a pedestrian). They are
///   discarded, drawn x-ray, or flattened to their base.
/// - Highlight and colour by attribute: per-building tints (height ramp).
/// - The analytic colour lens: a sphere or vertical cylinder around a point;
///   outside it the context is desaturated and darkened (render/gl's shader).
/// - Solo: every building but the POI discarded (a reference picture).
///
/// Boxes come from the feature bounds (format/feature_bounds.h), so lenses
/// work on every level of the tree, inner nodes included (merged geometry
/// keeps its feature ids).

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/geometry.h"
#include "core/status.h"
#include "format/feature_bounds.h"

namespace cityatlas::render {

/// What the renderer draws per feature (render/gl setLens). Features past the
/// arrays draw normally.
struct LensStyle {
    enum : uint8_t { kNormal = 0, kDiscard = 1, kXRay = 2, kFlatten = 3 };
    std::vector<uint8_t> style;                 ///< per feature, one of the above; empty: none
    std::vector<float> base_z;                  ///< per feature, local frame, for kFlatten
    float flatten = 0.02F;                      ///< z' = base + (z - base) * flatten
    float xray_falloff = 0.5F;                  ///< opacity 1 - |cos angle|^e (papers/003 eq. 3.19)
    std::vector<std::array<float, 4>> tint;     ///< per feature: linear rgb and its weight (0: none); empty: none
    int lens = 0;                               ///< 0 none, 1 sphere, 2 vertical cylinder
    Vec3d lens_centre;                          ///< local frame
    double lens_radius_m = 0;
    float context_saturation = 0.15F, context_brightness = 0.55F;  ///< outside the lens
    bool operator==(const LensStyle&) const = default;
};

/// Which buildings near the viewer also occlude (papers/003 eqs. 3.16-3.17).
enum class NearTest : uint8_t { Sphere, Cylinder, ViewerHeight };

struct LensParams {
    enum class Occlusion : uint8_t { None, Discard, XRay, Flatten };
    Occlusion occlusion = Occlusion::None;
    int64_t poi = -1;                ///< building of interest (feature id); -1: none
    double sphere_radius_m = 0;      ///< also occluders: box centres this close to the camera (eq. 3.16); 0: off
    NearTest near_test = NearTest::Sphere;
    bool solo = false;               ///< only the POI is drawn
    float xray_falloff = 0.5F;
    float flatten = 0.02F;
    std::vector<uint32_t> highlight; ///< tinted with highlight_colour
    std::array<float, 3> highlight_colour{1.0F, 0.55F, 0.0F};  ///< linear
    std::string colour_by;           ///< "" or "height": a ramp over the buildings' heights
    int shape = 0;                   ///< analytic lens: 0 none, 1 sphere, 2 vertical cylinder
    Vec3d centre;                    ///< local frame
    double radius_m = 0;
    bool active() const {
        return occlusion != Occlusion::None || solo || !highlight.empty() || !colour_by.empty() || shape != 0;
    }
};

/// The viewer for the occluder test: where it is and its up vector (papers/003's
/// LF and LU: the look-at up as given, z in every camera path), and the
/// near-viewer test (radius 0: off).
struct Viewer {
    Vec3d position;
    Vec3d up{0, 0, 1};
    double near_radius_m = 0;
    NearTest near_test = NearTest::Sphere;
};

/// The occluders of `poi` seen by `viewer` (see the file comment), ascending;
/// features without geometry never occlude. Empty for a POI out of range.
std::vector<uint32_t> occludersOf(const std::vector<format::FeatureBoundsRecord>& bounds, uint32_t poi,
                                  const Viewer& viewer);

/// The per-feature state for this camera (position and up vector).
LensStyle lensStyle(const LensParams& params, const std::vector<format::FeatureBoundsRecord>& bounds,
                    const Vec3d& camera, const Vec3d& up = {0, 0, 1});

}  // namespace cityatlas::render
