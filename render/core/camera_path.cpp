// SPDX-License-Identifier: GPL-3.0-or-later
#include "render/core/camera_path.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "render/core/view.h"

namespace cityatlas::render {
namespace {
using nlohmann::json;

bool vec3(const json& j, Vec3d* out) {
    if (!j.is_array() || j.size() != 3) return false;
    for (const json& v : j)
        if (!v.is_number() || !std::isfinite(v.get<double>())) return false;
    *out = {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
    return true;
}

Vec3d lerp(const Vec3d& a, const Vec3d& b, double s) { return a + s * (b - a); }

Vec3d catmullRom(const Vec3d& p0, const Vec3d& p1, const Vec3d& p2, const Vec3d& p3, double s) {
    const double s2 = s * s, s3 = s2 * s;
    return 0.5 * ((2.0 * p1) + s * (p2 - p0) + s2 * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) +
                  s3 * (3.0 * p1 - p0 - 3.0 * p2 + p3));
}

}  // namespace

size_t CameraPath::frameCount() const {
    if (keys.empty()) return 0;
    const double frames = std::floor(duration() * frame_rate + 1e-9);
    // A span of 1e300 s saturates instead of overflowing the cast (undefined behaviour).
    if (!(frames < 1e18)) return static_cast<size_t>(1e18);
    return static_cast<size_t>(frames) + 1;
}

namespace {

// The path's "lens" object (schemas/camera_path.schema.json); errors name the member.
Status parseLens(const json& j, const std::string& where, LensParams* out) {
    if (!j.is_object()) return Status::Invalid(where + ": not an object");
    LensParams l;
    auto number = [&](const char* key, double lo, double hi, double* v) -> Status {
        const auto it = j.find(key);
        if (it == j.end()) return Status::Ok();
        if (!it->is_number() || !(it->get<double>() >= lo && it->get<double>() <= hi))
            return Status::Invalid(fmt::format("{}: {} must be a number in [{}, {}]", where, key, lo, hi));
        *v = it->get<double>();
        return Status::Ok();
    };
    auto vec3 = [&](const char* key, Vec3d* v) -> Status {
        const auto it = j.find(key);
        if (it == j.end()) return Status::Ok();
        if (!it->is_array() || it->size() != 3 || !std::all_of(it->begin(), it->end(), [](const json& x) { return x.is_number(); }))
            return Status::Invalid(fmt::format("{}: {} must be [x, y, z]", where, key));
        *v = {(*it)[0].get<double>(), (*it)[1].get<double>(), (*it)[2].get<double>()};
        return Status::Ok();
    };
    if (const auto it = j.find("occlusion"); it != j.end()) {
        if (*it == "none") l.occlusion = LensParams::Occlusion::None;
        else if (*it == "discard") l.occlusion = LensParams::Occlusion::Discard;
        else if (*it == "xray") l.occlusion = LensParams::Occlusion::XRay;
        else if (*it == "flatten") l.occlusion = LensParams::Occlusion::Flatten;
        else return Status::Invalid(where + ": occlusion must be \"none\", \"discard\", \"xray\" or \"flatten\"");
    }
    if (const auto it = j.find("building"); it != j.end()) {
        if (!it->is_number_integer() || it->get<int64_t>() < 0) return Status::Invalid(where + ": building must be a feature id");
        l.poi = it->get<int64_t>();
    }
    if (const auto it = j.find("solo"); it != j.end()) {
        if (!it->is_boolean()) return Status::Invalid(where + ": solo must be true or false");
        l.solo = it->get<bool>();
    }
    if (const auto it = j.find("highlight"); it != j.end()) {
        if (!it->is_array() || !std::all_of(it->begin(), it->end(), [](const json& x) { return x.is_number_unsigned(); }))
            return Status::Invalid(where + ": highlight must be an array of feature ids");
        for (const json& x : *it) l.highlight.push_back(x.get<uint32_t>());
    }
    if (const auto it = j.find("colour_by"); it != j.end()) {
        if (*it != "height" && *it != "none") return Status::Invalid(where + ": colour_by must be \"height\" or \"none\"");
        if (*it == "height") l.colour_by = "height";
    }
    if (const auto it = j.find("near_test"); it != j.end()) {
        if (*it == "sphere") l.near_test = NearTest::Sphere;
        else if (*it == "cylinder") l.near_test = NearTest::Cylinder;
        else if (*it == "viewer_height") l.near_test = NearTest::ViewerHeight;
        else return Status::Invalid(where + ": near_test must be \"sphere\", \"cylinder\" or \"viewer_height\"");
    }
    if (const auto it = j.find("shape"); it != j.end()) {
        if (*it == "sphere") l.shape = 1;
        else if (*it == "cylinder") l.shape = 2;
        else if (*it != "none") return Status::Invalid(where + ": shape must be \"sphere\", \"cylinder\" or \"none\"");
    }
    double xray = l.xray_falloff, flatten = l.flatten;
    for (Status s : {number("sphere_radius_m", 0, 1e7, &l.sphere_radius_m), number("radius_m", 0, 1e7, &l.radius_m),
                     number("xray_falloff", 0, 1, &xray), number("flatten", 0, 1, &flatten), vec3("centre", &l.centre)})
        if (!s.ok()) return s;
    l.xray_falloff = static_cast<float>(xray);
    l.flatten = static_cast<float>(flatten);
    if ((l.occlusion != LensParams::Occlusion::None || l.solo) && l.poi < 0)
        return Status::Invalid(where + ": occlusion and solo need a \"building\"");
    if (l.shape != 0 && !(l.radius_m > 0)) return Status::Invalid(where + ": a sphere or cylinder needs radius_m > 0");
    *out = l;
    return Status::Ok();
}

}  // namespace

Status parseCameraPath(const std::string& text, const std::string& where, CameraPath* out) {
    *out = CameraPath{};
    json doc;
    try {
        doc = json::parse(text);
    } catch (const json::parse_error& e) {
        return Status::Invalid(fmt::format("{}: not JSON (byte {})", where, e.byte));
    } catch (const json::exception& e) {  // out_of_range: a number beyond double (1e999)
        return Status::Invalid(fmt::format("{}: not JSON: {}", where, e.what()));
    }
    if (!doc.is_object()) return Status::Invalid(where + ": not a JSON object");
    CameraPath p;
    if (const auto it = doc.find("interpolation"); it != doc.end()) {
        if (*it == "linear") p.interpolation = Interpolation::Linear;
        else if (*it == "catmull-rom") p.interpolation = Interpolation::CatmullRom;
        else return Status::Invalid(where + ": interpolation must be \"linear\" or \"catmull-rom\"");
    }
    if (const auto it = doc.find("frame_rate"); it != doc.end()) {
        if (!it->is_number() || !(it->get<double>() > 0 && it->get<double>() <= 1000))
            return Status::Invalid(where + ": frame_rate must be a number in (0, 1000]");
        p.frame_rate = it->get<double>();
    }
    if (const auto it = doc.find("lens"); it != doc.end())
        if (Status s = parseLens(*it, where + ": lens", &p.lens); !s.ok()) return s;
    const auto keys = doc.find("keyframes");
    if (keys == doc.end() || !keys->is_array() || keys->empty())
        return Status::Invalid(where + ": \"keyframes\" must be a non-empty array");
    for (size_t i = 0; i < keys->size(); ++i) {
        const json& k = (*keys)[i];
        const std::string kw = fmt::format("{}: keyframes[{}]", where, i);
        if (!k.is_object()) return Status::Invalid(kw + ": not an object");
        CameraKey key;
        const auto t = k.find("time_s");
        if (t == k.end() || !t->is_number() || !std::isfinite(t->get<double>()))
            return Status::Invalid(kw + ": \"time_s\" must be a number");
        key.time_s = t->get<double>();
        if (!p.keys.empty() && key.time_s <= p.keys.back().time_s)
            return Status::Invalid(fmt::format("{}: time_s {} is not after the previous keyframe's {}", kw, key.time_s,
                                            p.keys.back().time_s));
        const auto pos = k.find("position");
        if (pos == k.end() || !vec3(*pos, &key.position)) return Status::Invalid(kw + ": \"position\" must be [x, y, z]");
        const auto dir = k.find("direction");
        const auto at = k.find("look_at");
        if ((dir != k.end()) == (at != k.end())) return Status::Invalid(kw + ": give exactly one of \"direction\" and \"look_at\"");
        Vec3d d;
        if (dir != k.end()) {
            if (!vec3(*dir, &d)) return Status::Invalid(kw + ": \"direction\" must be [x, y, z]");
        } else {
            Vec3d target;
            if (!vec3(*at, &target)) return Status::Invalid(kw + ": \"look_at\" must be [x, y, z]");
            d = target - key.position;
        }
        if (length(d) < 1e-12) return Status::Invalid(kw + ": the view direction has zero length");
        // Scaled first: a long direction ([1e308, 1e308, 0]) would normalize to 0 (its length overflows).
        const double m = std::max({std::abs(d.x), std::abs(d.y), std::abs(d.z)});
        if (!std::isfinite(m)) return Status::Invalid(kw + ": the view direction is not finite (look_at too far away)");
        key.direction = normalized((1.0 / m) * d);
        if (const auto f = k.find("fov_deg"); f != k.end()) {
            if (!f->is_number() || !(f->get<double>() > 1 && f->get<double>() < 170))
                return Status::Invalid(kw + ": \"fov_deg\" must be in (1, 170)");
            key.fov_deg = f->get<double>();
        }
        if (const auto c = k.find("cut"); c != k.end()) {
            if (!c->is_boolean()) return Status::Invalid(kw + ": \"cut\" must be true or false");
            key.cut = c->get<bool>();
        }
        if (const auto l = k.find("label"); l != k.end()) {
            if (!l->is_string()) return Status::Invalid(kw + ": \"label\" must be a string");
            key.label = l->get<std::string>();
        }
        p.keys.push_back(key);
    }
    *out = std::move(p);
    return Status::Ok();
}

std::string cameraPathToJson(const CameraPath& path) {
    json keys = json::array();
    for (const CameraKey& k : path.keys) {
        json j = {{"time_s", k.time_s},
                  {"position", {k.position.x, k.position.y, k.position.z}},
                  {"direction", {k.direction.x, k.direction.y, k.direction.z}},
                  {"fov_deg", k.fov_deg}};
        if (k.cut) j["cut"] = true;
        if (!k.label.empty()) j["label"] = k.label;
        keys.push_back(j);
    }
    return json{{"interpolation", path.interpolation == Interpolation::Linear ? "linear" : "catmull-rom"},
                {"frame_rate", path.frame_rate},
                {"keyframes", keys}}
        .dump(2);
}

CameraSample sampleAt(const CameraPath& path, double time_s) {
    CameraSample s;
    s.time_s = time_s;
    if (path.keys.empty()) return s;
    const std::vector<CameraKey>& k = path.keys;
    auto pose = [&](const CameraKey& key) {
        s.position = key.position;
        s.direction = key.direction;
        s.fov_deg = key.fov_deg;
        s.label = key.label;
        return s;
    };
    if (time_s <= k.front().time_s) return pose(k.front());
    if (time_s >= k.back().time_s) return pose(k.back());
    // The segment [i, i+1] holding the time.
    size_t i = 0;
    while (i + 1 < k.size() && k[i + 1].time_s <= time_s) ++i;
    const CameraKey& a = k[i];
    const CameraKey& b = k[i + 1];
    if (b.cut) return pose(a);  // hold, then jump at b's time
    const double u = (time_s - a.time_s) / (b.time_s - a.time_s);
    // Neighbours for the spline; a cut ends the curve like the path's ends do.
    const CameraKey& before = (i > 0 && !a.cut) ? k[i - 1] : a;
    const CameraKey& after = (i + 2 < k.size() && !k[i + 2].cut) ? k[i + 2] : b;
    s.position = path.interpolation == Interpolation::Linear
                     ? lerp(a.position, b.position, u)
                     : catmullRom(before.position, a.position, b.position, after.position, u);
    Vec3d d = lerp(a.direction, b.direction, u);
    s.direction = length(d) > 1e-9 ? normalized(d) : a.direction;
    s.fov_deg = a.fov_deg + u * (b.fov_deg - a.fov_deg);
    s.label = a.label;
    return s;
}

CameraSample sampleFrame(const CameraPath& path, size_t frame) {
    const double t0 = path.keys.empty() ? 0 : path.keys.front().time_s;
    return sampleAt(path, t0 + static_cast<double>(frame) / path.frame_rate);
}

CameraPath defaultPath(const Box3d& b, double frame_rate) {
    const Vec3d c = 0.5 * (b.min + b.max);
    const double rx = 0.5 * (b.max.x - b.min.x), ry = 0.5 * (b.max.y - b.min.y);
    const double r = std::max({rx, ry, 10.0});
    const double top = b.max.z, eye = b.min.z + 1.7;
    const double fly = std::max(top + 25.0, b.min.z + 40.0);
    CameraPath p;
    p.frame_rate = frame_rate;
    p.interpolation = Interpolation::CatmullRom;
    const Vec3d centre_ground{c.x, c.y, b.min.z};
    auto key = [&](double t, const Vec3d& pos, const Vec3d& look_at, const char* label) {
        CameraKey k;
        k.time_s = t;
        k.position = pos;
        k.direction = normalized(look_at - pos);
        k.label = label;
        p.keys.push_back(k);
    };
    // Overview: south of the town, high enough to see all of it at 60 degrees.
    key(0, {c.x, c.y - 1.6 * r, top + 1.4 * r}, centre_ground, "overview");
    key(3, {c.x - 0.4 * rx, c.y - 1.1 * r, top + 0.7 * r}, centre_ground, "overview");
    // Oblique flight, descending diagonally across the town and looking ahead.
    key(6, {b.min.x + 0.2 * rx, b.min.y + 0.3 * ry, fly + 0.3 * r}, {c.x, c.y, b.min.z}, "oblique");
    key(10, {c.x, c.y, fly}, {b.max.x, b.max.y, b.min.z}, "oblique");
    key(13, {b.max.x - 0.3 * rx, b.max.y - 0.3 * ry, fly}, {b.max.x + rx, b.max.y + ry, b.min.z}, "oblique");
    // Street level: at eye height along the southern edge, looking into the town.
    CameraKey street;
    street.time_s = 14;
    street.position = {b.min.x + 0.2 * rx, b.min.y - 3.0, eye};
    street.direction = normalized(Vec3d{0.3, 1, 0});
    street.cut = true;
    street.label = "street";
    p.keys.push_back(street);
    key(20, {b.min.x + 1.2 * rx, b.min.y - 3.0, eye}, {b.min.x + 1.6 * rx, c.y, eye}, "street");
    return p;
}

}  // namespace cityatlas::render
