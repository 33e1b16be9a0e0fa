// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Camera paths for `cityatlas render` (schemas/camera_path.schema.json):
/// keyframes in the tileset's local frame (metres, z up) with a view direction
/// (or a point to look at), a vertical field of view and a time; sampled at a
/// frame rate with linear or Catmull-Rom interpolation of positions and
/// normalised interpolation of directions. A keyframe marked `cut` is jumped
/// to (a teleport), not flown to.

#include <string>
#include <vector>

#include "core/geometry.h"
#include "core/status.h"
#include "render/core/lenses.h"

namespace cityatlas::render {

struct CameraKey {
    double time_s = 0;
    Vec3d position;
    Vec3d direction{0, 1, 0};  ///< unit
    double fov_deg = 60;
    bool cut = false;          ///< arrive here instantly from the previous keyframe
    std::string label;         ///< optional, carried into the frame report ("overview", "street")
};

enum class Interpolation : uint8_t { Linear, CatmullRom };

struct CameraPath {
    std::vector<CameraKey> keys;  ///< time ascending
    Interpolation interpolation = Interpolation::CatmullRom;
    double frame_rate = 10;       ///< frames per second of path time
    LensParams lens;              ///< the path's information lenses ("lens"; none by default)
    double duration() const { return keys.empty() ? 0 : keys.back().time_s - keys.front().time_s; }
    size_t frameCount() const;    ///< floor(duration * frame_rate) + 1
};

struct CameraSample {
    double time_s = 0;
    Vec3d position, direction;
    double fov_deg = 60;
    std::string label;  ///< of the keyframe segment the sample lies in
};

/// Parses the JSON of schemas/camera_path.schema.json; errors name `where` and the keyframe.
Status parseCameraPath(const std::string& text, const std::string& where, CameraPath* out);
std::string cameraPathToJson(const CameraPath& path);

CameraSample sampleAt(const CameraPath& path, double time_s);
/// Frame i of the path: time = first key's time + i / frame_rate.
CameraSample sampleFrame(const CameraPath& path, size_t frame);

/// A path a new user gets without --path, from the tileset's root box:
/// overview from high up, an oblique flight descending across the town, and a
/// walk at eye height (1.7 m above the box floor) along its southern edge
/// looking into the town.
CameraPath defaultPath(const Box3d& bounds, double frame_rate = 10);

}  // namespace cityatlas::render
