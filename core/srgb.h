// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The sRGB transfer functions (IEC 61966-2-1), exact formulas, in [0, 1]:
/// every stage that averages, resamples or compares colours in linear light
/// goes through these (tables built from them where speed matters).

#include <cmath>

namespace cityatlas {

inline double linearFromSrgb(double encoded) {
    return encoded <= 0.04045 ? encoded / 12.92 : std::pow((encoded + 0.055) / 1.055, 2.4);
}
inline double srgbFromLinear(double linear) {
    return linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
}

}  // namespace cityatlas
