// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// What `build --computed NAME[:params]` asks for (issue 19): one computed
/// texture's model and parameters, parsed from the option, written into the
/// plan and tileset.json, and read back.
///
///   sky_view[:directions=64,scale=4,horizon=1000]
///   sun_hours[:year=2025,days=12,step=60,scale=4,horizon=1000]
///   shadow:azimuth=DEG,elevation=DEG[,radius=0.2665,samples=64,scale=4,horizon=1000]
///   shadow:time=YYYY-MM-DDTHH:MM[...]    (UTC; the sun's position at the scene's origin)
///   visibility:BUILDING[,grid=16,scale=4,horizon=1000]  (BUILDING: a gml:id; visibility.h)
///
/// - scale: the computed image has 1/scale of the photo atlas's texels per
///   axis (1, 2 or 4).
/// - horizon: metres; only triangles within it of a ray's origin block the
///   ray ("inf" for no limit). It makes a texel's value depend on its
///   surroundings alone, so a shard needs only the triangles within the
///   horizon of its own (cli/shards.h) and any sharding gives the same values.
///   A building of height h beyond the horizon H would have taken at most
///   sin^2(atan(h / H)) of a roof's sky view: 1 % for 100 m at 1 km.

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "atlas/sun_hours.h"
#include "core/status.h"

namespace cityatlas::atlas {

enum class ComputedModel : uint8_t { SkyView, SunHours, Shadow, Visibility };

struct ComputedSpec {
    ComputedModel model = ComputedModel::SkyView;
    int scale = 4;
    double horizon_m = 1000;     ///< +inf: no limit
    int directions = 64;         ///< sky_view: cosine-weighted hemisphere directions
    // sun_hours
    int year = 2025, days = 12;
    double step_minutes = 60;
    // shadow: the sun as a disc, placed by azimuth and elevation or by a time (UTC)
    SunDisc disc{180, 45, 0.2665, 64};
    std::string time_utc;        ///< "YYYY-MM-DDTHH:MM"; empty: disc.azimuth/elevation as given
    // visibility
    std::string building;        ///< the target's gml:id (its parts included)
    int grid = 16;               ///< rays per side of the thesis' image
    /// The target's features (the building and its parts), found in the
    /// input by the build; not a parameter (the plan holds their triangles).
    std::vector<uint32_t> target_features;

    std::string name() const;    ///< "sky_view", "sun_hours", "shadow", "visibility"
    /// The parameters as written into the plan and tileset.json (every one, defaults included).
    nlohmann::json parameters() const;
};

/// Parses one --computed value; the message names the value and what is wrong.
Status parseComputedSpec(const std::string& text, ComputedSpec* out);

/// {"model": name, "parameters": {...}} and back (the plan's, tileset.json's).
nlohmann::json computedSpecJson(const ComputedSpec& spec);
Status computedSpecFromJson(const nlohmann::json& j, ComputedSpec* out);

/// The Julian day (UT) of "YYYY-MM-DDTHH:MM" (UTC); nullopt when malformed.
std::optional<double> julianDayUtc(const std::string& iso);

}  // namespace cityatlas::atlas
