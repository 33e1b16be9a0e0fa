// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The Scene's link to the Earth: from the local frame (local_frame.h) to
/// Earth-centred, Earth-fixed coordinates (ECEF, EPSG:4978, WGS 84, metres) and
/// to the true east/north/up (ENU) tangent frame at the scene origin.
///
/// Two kinds of local frame (see scene.h, local_frame.h)
/// -----------------------------------------------------
/// * ENU frames (geographic source CRS, e.g. EPSG:4326, 6668, 6697): the local
///   frame already IS the tangent frame at the origin (GeographicLib::
///   LocalCartesian on the CRS's ellipsoid). toEcef goes local -> (lat, lon, h)
///   with GeographicLib -> PROJ (source geographic 3D -> EPSG:4978, which adds
///   the datum step when there is one). enu_to_ecef maps local points to ECEF
///   exactly; toEnu is the identity (to < 1e-6 m for datums PROJ relates to
///   WGS 84 by a null transformation: WGS 84, ETRS89, JGD2011, GDA2020...; for
///   a datum with a real shift, e.g. Tokyo, the source ellipsoid's normal differs
///   from WGS 84's by some arc seconds and toEnu says by how much).
/// * Grid frames (projected source CRS, e.g. UTM): local = grid offsets from the
///   origin. They are NOT the tangent frame: the grid has the projection's scale
///   (UTM: 0.9996 at the central meridian, 1.0007 300 km off it), is rotated by
///   the meridian convergence (0 at the central meridian; at 52 N 2.4 degrees at
///   a zone edge and 3.5 degrees 300 km off, as for a town mapped in its
///   neighbour zone, e.g. eastern Germany in zone 32) and is flat where the
///   Earth is curved (a point 10 km away sits ~7.8 m below the tangent plane).
///   toEcef is exact: local -> source CRS coordinates -> PROJ's real
///   transformation -> EPSG:4978.
///   toEnu gives the tangent-frame position a renderer using enu_to_ecef needs;
///   planarError says how far the grid is from it.
///
/// Heights
/// -------
/// * `local.z + origin.z` is taken as an ELLIPSOIDAL height in metres on the
///   source CRS's ellipsoid. No geoid model is applied by cityatlas: only the
///   grids Debian's proj-data bundles are available (e.g. egm96_15, BETA2007,
///   not GCG2016 for Germany nor GSIGEO2011 for Japan), and PROJ's network
///   (CDN) access is switched off. Files with normal/orthometric heights
///   (DHHN2016, JGD2011 height, ...) therefore sit too low/high by the geoid
///   undulation (about +40 m in Germany, +37 m in Tokyo): a near-constant
///   vertical offset over a town, not a distortion.
/// * 2D source CRSs are promoted to 3D (proj_crs_promote_to_3D), so a datum
///   shift with a 3D Helmert moves points as 3D points.
/// * A compound CRS (horizontal + vertical, e.g. "EPSG:25832+7837", EPSG:6697)
///   is handed to PROJ as it is, and PROJ does what it does: with the geoid
///   grid present (e.g. EPSG:4326+5773, EGM96 in proj-data) it converts the
///   heights to ellipsoidal ones; without it (DHHN2016, JGD2011 height) it uses a
///   "ballpark vertical transformation", i.e. passes the heights through
///   unchanged, which is the same as the ellipsoidal assumption above.
///   EarthFrame::operation names the operation PROJ used at the origin.
///   For a GEOGRAPHIC compound CRS whose geoid PROJ applies, LocalFrame's
///   tangent frame (built on the ellipsoid with the file's heights) is no
///   longer exactly the true ENU frame: it is off by the geoid's slope and by
///   N / R in scale (measured for EPSG:4326+5773 at Berlin, N = 39.5 m:
///   6 cm horizontal and 0.2 m vertical at 10 km); toEnu reports it.
/// * Heights also scale the ground: at ellipsoidal height h a grid metre is
///   (1 + h / R) / k metres in ECEF (5 ppm at h = 34 m); toEcef includes this.
///
/// Georeference::local_to_ecef (scene.h): what the integrator stores
/// -------------------------------------------------------------------
/// One 4x4 column-major matrix, metres, ECEF = M * (local, 1). Use
/// localToEcefMatrix(), which returns:
/// * ENU frames: EarthFrame::enu_to_ecef. Exact for every point (within the
///   datum and geoid notes above).
/// * Grid frames: tangentLinearLocalToEcef(), the tangent-linear (first order)
///   map at the origin: ECEF(origin) + J * local with J = d ECEF / d local by
///   central differences through PROJ. It absorbs the grid's scale and meridian
///   convergence at the origin (which enu_to_ecef would get wrong by 4 m per
///   10 km at the central meridian and by 610 m per 10 km 300 km off it at
///   52 N), so it is the best single affine map. What no affine map can
///   do is bend the flat grid around the Earth: its residual is the curvature
///   drop d^2 / (2 R), 7.8 cm at 1 km and 7.8 m at 10 km, plus second-order
///   horizontal terms (at 10 km: 4-8 mm at the central meridian, 0.4 m 300 km
///   off it, the arc-to-chord term d^2 |x| / (2 R^2)). Fine
///   to place and orient a model; NOT for tiles that must be exact: a tile
///   writer should use enu_to_ecef as the root transform and LocalToEcef::toEnu
///   for every vertex.
///
/// Errors: computeEarthFrame / LocalToEcef::create fail (Status) for a local
/// engineering CRS and when PROJ cannot transform the origin. Per-point calls
/// return false for points PROJ cannot transform (outside the CRS's domain).

#include <array>
#include <memory>
#include <span>
#include <string>

#include "ingest/local_frame.h"
#include "ingest/scene.h"
#include "core/status.h"

namespace cityatlas {

/// The Scene's link to the Earth, computed from a LocalFrame.
struct EarthFrame {
    /// 4x4 column-major: the east/north/up tangent frame at the frame's origin
    /// (WGS 84 ellipsoid normal) -> ECEF (EPSG:4978), metres. Columns 0..2 are
    /// the unit vectors east, north, up; column 3 is origin_ecef. What a
    /// 3D Tiles root transform is.
    std::array<double, 16> enu_to_ecef{};
    /// The origin on the WGS 84 ellipsoid (PROJ to EPSG:4979).
    double origin_lat_deg = 0, origin_lon_deg = 0, origin_h_m = 0;
    Vec3d origin_ecef;  ///< EPSG:4978, metres
    bool grid = false;  ///< true when local coordinates are grid offsets of a projected CRS (not true ENU)
    /// PROJ's name for the operation it used at the origin, e.g. "Inverse of
    /// UTM zone 33N + ETRS89 to WGS 84 (1) + Conversion from WGS 84 (geog3D)
    /// to WGS 84 (geocentric)". Tells ballpark from real height conversions.
    std::string operation;
};

/// Fails (Status) for a local engineering CRS or when PROJ cannot transform
/// the origin.
Status computeEarthFrame(const LocalFrame& frame, EarthFrame* out);

/// Exact position of a local point in ECEF: grid frames go local -> source CRS
/// -> (PROJ, the real transformation) -> EPSG:4978; ENU frames go through
/// GeographicLib to (lat, lon, h), then PROJ to EPSG:4978.
///
/// Create once, call many times: the PROJ objects are kept. All const members
/// may be called from any number of threads at once: each thread borrows its
/// own PROJ context and operation from a small pool (PROJ objects must not be
/// shared between threads), creating one on first use (a few ms).
/// Independent of the LocalFrame after create() (it copies what it needs).
class LocalToEcef {
public:
    static Status create(const LocalFrame& frame, std::unique_ptr<LocalToEcef>* out);
    ~LocalToEcef();
    LocalToEcef(const LocalToEcef&) = delete;
    LocalToEcef& operator=(const LocalToEcef&) = delete;

    /// ECEF (EPSG:4978, metres) of a local point; false when PROJ cannot
    /// transform it.
    bool toEcef(const Vec3d& local, Vec3d* ecef) const;
    /// Many points at once (one pool borrow for all): ecef.size() must equal
    /// local.size(). False if any point fails (its output is then NaN; the
    /// others are still computed).
    bool toEcef(std::span<const Vec3d> local, std::span<Vec3d> ecef) const;

    /// The real position of a local point in the ENU tangent frame at the
    /// origin (what a tile renderer using enu_to_ecef should be given):
    /// enu_to_ecef^-1 * toEcef(local). For ENU frames this is the identity
    /// (see the file comment for datums with a real shift).
    bool toEnu(const Vec3d& local, Vec3d* enu) const;

    /// |toEnu(local) - local|: the error of treating grid coordinates as if they
    /// were the tangent frame ("planar error"), split into the horizontal part
    /// (hypot of east and north differences) and the vertical part (absolute
    /// up difference), metres. About 0 for ENU frames.
    bool planarError(const Vec3d& local, double* horizontal_m, double* vertical_m) const;

    const EarthFrame& earth() const;
    bool grid() const { return earth().grid; }

private:
    LocalToEcef();
    friend std::array<double, 16> tangentLinearLocalToEcef(const LocalToEcef& map);
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// Grid frames: the tangent-linear map at the origin, 4x4 column-major, metres:
/// ECEF = ECEF(origin) + J * local, J = d ECEF / d local by central differences
/// (+-10 m along each local axis, through PROJ; computed once in create()).
/// Column j (j < 3) is the image of local axis j: its length is 1/k (grid scale
/// k) for the horizontal axes and 1 for up; the angle between the east column
/// and enu_to_ecef's east is the meridian convergence. For ENU frames it equals
/// enu_to_ecef (within 1e-9). Accuracy: see the file comment.
std::array<double, 16> tangentLinearLocalToEcef(const LocalToEcef& map);

/// What Georeference::local_to_ecef should hold: enu_to_ecef for ENU frames,
/// tangentLinearLocalToEcef for grid frames (see the file comment).
std::array<double, 16> localToEcefMatrix(const LocalToEcef& map);

/// Applies a 4x4 column-major matrix to a point (w = 1).
Vec3d transformPoint(const std::array<double, 16>& m, const Vec3d& p);

/// What the ingest records about the link to the Earth: the frames, and how
/// far the single local_to_ecef matrix is from the real transformation at the
/// corners of the scene's bounding box (the "planar error").
struct GeorefSummary {
    EarthFrame earth;
    std::array<double, 16> local_to_ecef{};
    double planar_error_horizontal_m = 0, planar_error_vertical_m = 0;  ///< worst over the box corners
    double extent_m = 0;  ///< largest horizontal distance of a corner from the origin
};
Status summarizeGeoreference(const LocalFrame& frame, const Box3d& bounds_local, GeorefSummary* out);

}  // namespace cityatlas
