// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The colour ramp a computed texture is shown with (`render --computed NAME
/// --computed-mode ramp`; issue 19): 256 sRGB colours, entry i for the
/// value i / 255. Deep blue through teal and green to yellow, lightness
/// rising all the way, so a grey-scale print keeps the order. Piecewise
/// linear in sRGB bytes between four stops (ours, not a published map).

#include <array>
#include <cstdint>

namespace cityatlas::render {

/// How a computed texture (issue 19; papers/000 §5.1.3) shows on textured
/// surfaces: not at all (the photo), as a colour ramp (render/core/
/// computed_ramp.h, the value v picking entry round(255 v) between texels),
/// modulating the photo (papers/000 Fig. 20: colour * min(1, b_min + v
/// (b_max - b_min)), in linear light), or emphasising where the value is
/// high (Fig. 34, for a visibility texture: "from where is the tower
/// visible?"): the photo's saturation follows v (grey at 0), its brightness
/// as in modulate, and a blend of kEmphasisYellowWeight * v toward
/// kEmphasisYellow, all in linear light. Material-coloured surfaces have no
/// computed values and keep their colour.
enum class ComputedMode : uint8_t { Photo = 0, Ramp = 1, Modulate = 2, Emphasis = 3 };
const char* computedModeName(ComputedMode mode);  ///< "photo", "ramp", "modulate", "emphasis"
/// Emphasis: the yellow (linear RGB) and its largest weight (at v = 1);
/// grey is the Rec. 709 luminance of the linear colour.
inline constexpr std::array<float, 3> kEmphasisYellow{1.0F, 0.8F, 0.1F};
inline constexpr float kEmphasisYellowWeight = 0.15F;
struct ComputedStyle {
    ComputedMode mode = ComputedMode::Photo;
    float b_min = 0.3F, b_max = 1.0F;  ///< Modulate, Emphasis: the brightness range
};

using RampColour = std::array<uint8_t, 3>;
const std::array<RampColour, 256>& computedRamp();

}  // namespace cityatlas::render
