// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/computed_spec.h"

#include <libnova/julian_day.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <map>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace cityatlas::atlas {
namespace {

using nlohmann::json;

bool parseNumber(const std::string& s, double* out) {
    if (s == "inf" || s == "none") {
        *out = std::numeric_limits<double>::infinity();
        return true;
    }
    try {
        size_t used = 0;
        *out = std::stod(s, &used);
        return used == s.size() && std::isfinite(*out);
    } catch (const std::exception&) {
        return false;
    }
}

// Horizon as text: a number of metres, or "inf".
json horizonJson(double h) { return std::isfinite(h) ? json(h) : json("inf"); }

Status check(const ComputedSpec& s, const std::string& where) {
    auto bad = [&](const std::string& what) { return Status::Usage(fmt::format("--computed {}: {}", where, what)); };
    if (s.scale != 1 && s.scale != 2 && s.scale != 4) return bad("scale must be 1, 2 or 4");
    if (!(s.horizon_m > 0)) return bad("horizon must be a positive number of metres or inf");
    switch (s.model) {
        case ComputedModel::SkyView:
            if (s.directions < 1 || s.directions > 65536) return bad("directions must be in 1..65536");
            break;
        case ComputedModel::SunHours:
            if (s.days < 1 || s.days > 366) return bad("days must be in 1..366");
            if (!(s.step_minutes >= 1 && s.step_minutes <= 720)) return bad("step must be 1..720 minutes");
            if (s.year < 1800 || s.year > 2200) return bad("year must be in 1800..2200");
            break;
        case ComputedModel::Visibility:
            if (s.building.empty()) return bad("visibility needs a building: visibility:GML_ID");
            if (s.grid < 1 || s.grid > 256) return bad("grid must be in 1..256");
            break;
        case ComputedModel::Shadow:
            if (s.time_utc.empty() && !(s.disc.elevation_deg > 0 && s.disc.elevation_deg <= 90))
                return bad("shadow needs the sun above the horizon: elevation in (0, 90] degrees, or time=");
            if (!(s.disc.radius_deg >= 0 && s.disc.radius_deg <= 10)) return bad("radius must be 0..10 degrees");
            if (s.disc.samples < 1 || s.disc.samples > 65536) return bad("samples must be in 1..65536");
            if (!s.time_utc.empty() && !julianDayUtc(s.time_utc))
                return bad(fmt::format("time={}: expected YYYY-MM-DDTHH:MM (UTC)", s.time_utc));
            break;
    }
    return Status::Ok();
}

}  // namespace

std::string ComputedSpec::name() const {
    switch (model) {
        case ComputedModel::SkyView: return "sky_view";
        case ComputedModel::SunHours: return "sun_hours";
        case ComputedModel::Shadow: return "shadow";
        case ComputedModel::Visibility: return "visibility";
    }
    return "?";
}

json ComputedSpec::parameters() const {
    json p = {{"scale", scale}, {"horizon", horizonJson(horizon_m)}};
    switch (model) {
        case ComputedModel::SkyView: p["directions"] = directions; break;
        case ComputedModel::SunHours:
            p["year"] = year, p["days"] = days, p["step"] = step_minutes;
            break;
        case ComputedModel::Shadow:
            if (time_utc.empty())
                p["azimuth"] = disc.azimuth_deg, p["elevation"] = disc.elevation_deg;
            else
                p["time"] = time_utc;
            p["radius"] = disc.radius_deg, p["samples"] = disc.samples;
            break;
        case ComputedModel::Visibility:
            p["building"] = building, p["grid"] = grid;
            break;
    }
    return p;
}

std::optional<double> julianDayUtc(const std::string& iso) {
    int y = 0, mo = 0, d = 0, h = 0, mi = 0;
    char tail = 0;
    if (std::sscanf(iso.c_str(), "%4d-%2d-%2dT%2d:%2d%c", &y, &mo, &d, &h, &mi, &tail) != 5) return std::nullopt;
    if (mo < 1 || mo > 12 || d < 1 || d > 31 || h < 0 || h > 23 || mi < 0 || mi > 59) return std::nullopt;
    ln_date date{y, mo, d, h, mi, 0.0};
    return ln_get_julian_day(&date);
}

Status parseComputedSpec(const std::string& text, ComputedSpec* out) {
    ComputedSpec s;
    const size_t colon = text.find(':');
    const std::string name = text.substr(0, colon);
    if (name == "sky_view") s.model = ComputedModel::SkyView;
    else if (name == "sun_hours") s.model = ComputedModel::SunHours;
    else if (name == "shadow") s.model = ComputedModel::Shadow;
    else if (name == "visibility") s.model = ComputedModel::Visibility;
    else
        return Status::Usage(fmt::format(
            "--computed {}: unknown computed texture '{}' (expected sky_view, sun_hours, shadow or visibility:BUILDING)", text,
            name));
    std::map<std::string, std::string> given;
    if (colon != std::string::npos) {
        const std::string list = text.substr(colon + 1);
        size_t start = 0;
        while (start <= list.size()) {
            const size_t comma = list.find(',', start);
            const std::string item = list.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
            const size_t eq = item.find('=');
            // visibility:BUILDING: the first item is the target's id.
            if (s.model == ComputedModel::Visibility && start == 0 && eq == std::string::npos && !item.empty()) {
                given.emplace("building", item);
                if (comma == std::string::npos) break;
                start = comma + 1;
                continue;
            }
            if (eq == std::string::npos || eq == 0)
                return Status::Usage(fmt::format("--computed {}: '{}' is not KEY=VALUE", text, item));
            if (!given.emplace(item.substr(0, eq), item.substr(eq + 1)).second)
                return Status::Usage(fmt::format("--computed {}: {} given twice", text, item.substr(0, eq)));
            if (comma == std::string::npos) break;
            start = comma + 1;
        }
    }
    // Every key this model takes, with where its value goes.
    std::map<std::string, double*> numbers;
    double scale = s.scale, directions = s.directions, year = s.year, days = s.days, samples = s.disc.samples;
    numbers["scale"] = &scale;
    numbers["horizon"] = &s.horizon_m;
    if (s.model == ComputedModel::SkyView) numbers["directions"] = &directions;
    if (s.model == ComputedModel::SunHours) {
        numbers["year"] = &year, numbers["days"] = &days, numbers["step"] = &s.step_minutes;
    }
    double grid = s.grid;
    if (s.model == ComputedModel::Visibility) numbers["grid"] = &grid;
    bool has_sun = false;
    if (s.model == ComputedModel::Shadow) {
        numbers["azimuth"] = &s.disc.azimuth_deg, numbers["elevation"] = &s.disc.elevation_deg;
        numbers["radius"] = &s.disc.radius_deg, numbers["samples"] = &samples;
    }
    for (const auto& [key, value] : given) {
        if (s.model == ComputedModel::Shadow && key == "time") {
            s.time_utc = value;
            continue;
        }
        if (s.model == ComputedModel::Visibility && key == "building") {
            s.building = value;
            continue;
        }
        const auto it = numbers.find(key);
        if (it == numbers.end()) {
            std::vector<std::string> keys;
            for (const auto& [k, _] : numbers) keys.push_back(k);
            if (s.model == ComputedModel::Shadow) keys.push_back("time");
            if (s.model == ComputedModel::Visibility) keys.push_back("building");
            return Status::Usage(
                fmt::format("--computed {}: {} takes no '{}' (it takes {})", text, name, key, fmt::join(keys, ", ")));
        }
        if (!parseNumber(value, it->second) || (key != "horizon" && !std::isfinite(*it->second)))
            return Status::Usage(fmt::format("--computed {}: {}={} is not a number", text, key, value));
        if (key == "azimuth" || key == "elevation") has_sun = true;
    }
    for (auto [v, key] : {std::pair{scale, "scale"}, {directions, "directions"}, {year, "year"}, {days, "days"},
                          {samples, "samples"}, {grid, "grid"}})
        if (v != std::floor(v)) return Status::Usage(fmt::format("--computed {}: {} must be a whole number", text, key));
    s.scale = static_cast<int>(scale), s.directions = static_cast<int>(directions);
    s.year = static_cast<int>(year), s.days = static_cast<int>(days), s.disc.samples = static_cast<int>(samples);
    s.grid = static_cast<int>(grid);
    if (s.model == ComputedModel::Shadow) {
        if (!s.time_utc.empty() && has_sun)
            return Status::Usage(fmt::format("--computed {}: give the sun by time= or by azimuth= and elevation=, not both", text));
        if (s.time_utc.empty() && (!given.count("azimuth") || !given.count("elevation")))
            return Status::Usage(fmt::format(
                "--computed {}: shadow needs the sun's position: azimuth=DEG,elevation=DEG or time=YYYY-MM-DDTHH:MM (UTC)", text));
    }
    if (Status st = check(s, text); !st.ok()) return st;
    *out = s;
    return Status::Ok();
}

json computedSpecJson(const ComputedSpec& spec) { return {{"model", spec.name()}, {"parameters", spec.parameters()}}; }

Status computedSpecFromJson(const json& j, ComputedSpec* out) {
    try {
        std::vector<std::string> params;
        for (const auto& [k, v] : j.at("parameters").items())
            params.push_back(fmt::format("{}={}", k, v.is_string() ? v.get<std::string>() : v.dump()));
        const std::string model = j.at("model").get<std::string>();
        return parseComputedSpec(params.empty() ? model : fmt::format("{}:{}", model, fmt::join(params, ",")), out);
    } catch (const std::exception& e) {
        return Status::Invalid(fmt::format("a computed texture's entry: {}", e.what()));
    }
}

}  // namespace cityatlas::atlas
