// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The cross-fade's screen door (GlRenderer::setFade) in GLSL, one source
/// for every fragment shader that fades (meshes, BlockMaps), so a node
/// fading in and the one it replaces fading out at the same progress cover
/// each pixel exactly once between them, whatever draws them. Declares the
/// uniforms `u_fade` (0 none, 1 fading in, 2 fading out) and `u_fade_t`
/// (progress in [0, 1]) and `bool screenDoorDiscards()`: a 4 x 4 ordered
/// dither keeps a fading-in fragment where the pixel's threshold is below
/// the progress, a fading-out one where it is not. A string literal, to be
/// spliced between the raw literals of a shader's source.
#define CITYATLAS_SCREEN_DOOR_GLSL                                                                              \
    "uniform int u_fade;\n"                                                                                     \
    "uniform float u_fade_t;\n"                                                                                 \
    "const float kBayer[16] = float[16](0.0, 8.0, 2.0, 10.0, 12.0, 4.0, 14.0, 6.0, 3.0, 11.0, 1.0, 9.0, 15.0, " \
    "7.0, 13.0, 5.0);\n"                                                                                        \
    "bool screenDoorDiscards() {\n"                                                                             \
    "    if (u_fade == 0) return false;\n"                                                                      \
    "    ivec2 q = ivec2(gl_FragCoord.xy) & 3;\n"                                                               \
    "    bool in_part = (kBayer[q.y * 4 + q.x] + 0.5) / 16.0 < u_fade_t;\n"                                     \
    "    return (u_fade == 1) != in_part;\n"                                                                    \
    "}\n"
