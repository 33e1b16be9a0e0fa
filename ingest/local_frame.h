// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// From source coordinates (whatever CRS a file declares) to the Scene's local
/// metric frame (see scene.h for the frame's definition).
///
/// * Projected CRS (metres or other linear units): local = (source - origin)
///   scaled to metres, "grid east/north/up". Areas and lengths are the grid's,
///   exactly as in the file.
/// * Geographic CRS (lat/lon/h): local = east/north/up tangent frame at the
///   origin (GeographicLib::LocalCartesian on the CRS's ellipsoid).
/// * Local engineering CRS (e.g. srsName="#local-CRS-1"): coordinates are
///   taken as metres as they are; the scene is not georeferenced.
/// A file in another CRS than the frame's is first transformed into the
/// frame's CRS with PROJ (through GDAL's OGRCoordinateTransformation).
///
/// Points handed to a frame are in "x east-ish, y north-ish" order: for a
/// geographic CRS that is (lon, lat, h); readers swap files' (lat, lon) order.

#include <memory>
#include <optional>
#include <string>

#include "ingest/scene.h"
#include "core/status.h"

namespace cityatlas {

/// A CRS as a file declares it, parsed.
struct SourceCrs {
    enum class Kind { Projected, Geographic, LocalEngineering } kind = Kind::Projected;
    std::string declared;       ///< the srsName text as found
    std::string definition;     ///< what PROJ was given, e.g. "EPSG:25832+7837"; empty for local
    std::string name;           ///< PROJ's name for it
    double linear_unit_m = 1;   ///< projected: metres per unit
    double semi_major_m = 6378137, inverse_flattening = 298.257223563;  ///< geographic: the ellipsoid
    std::string vertical_ignored;  ///< a compound CRS's height part PROJ could not use (e.g. a datum code), or empty
};

/// Parses an srsName: EPSG URNs (also versioned and compound:
/// "urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783"), OGC http URIs
/// (".../def/crs/EPSG/0/6697"), plain "EPSG:25833", AdV URNs
/// ("urn:adv:crs:ETRS89_UTM32*DE_DHHN2016_NH*GCG2016") and "#id" references to
/// an in-file engineering CRS. Fails with a message naming the text.
Status parseSrsName(const std::string& srs_name, SourceCrs* crs);

/// A SourceCrs from a definition PROJ reads ("EPSG:25832", "EPSG:25832+7837"
/// or WKT; never a file name or URL): its kind, units and ellipsoid. Keeps
/// crs->declared as it is.
Status sourceCrsFromDefinition(const std::string& definition, SourceCrs* crs);

class LocalFrame {
public:
    /// The frame is defined by the first input: its CRS and an origin in it
    /// (x east-ish, y north-ish order; metres or degrees).
    static Status create(const SourceCrs& crs, const Vec3d& origin_source, std::unique_ptr<LocalFrame>* frame);
    ~LocalFrame();

    const SourceCrs& crs() const { return crs_; }
    const Vec3d& originSource() const { return origin_; }

    /// A converter for points in `source` (the frame's own CRS or another).
    class Mapper {
    public:
        ~Mapper();
        /// false when the point cannot be transformed (outside the CRS's domain).
        bool toLocal(const Vec3d& source, Vec3d* local) const;
        /// Converts a point from the source CRS into the frame's CRS (identity
        /// when they are the same).
        bool toFrameCrs(const Vec3d& source, Vec3d* frame_crs) const;

    private:
        friend class LocalFrame;
        const LocalFrame* frame_ = nullptr;
        struct Transform;
        std::unique_ptr<Transform> transform_;  // null when source == frame CRS
    };
    Status mapperFor(const SourceCrs& source, std::unique_ptr<Mapper>* mapper) const;

private:
    LocalFrame() = default;
    SourceCrs crs_;
    Vec3d origin_;
    struct Tangent;
    std::unique_ptr<Tangent> tangent_;  // geographic frames only
    Vec3d frameToLocal(const Vec3d& p) const;
};

}  // namespace cityatlas
