// SPDX-License-Identifier: GPL-3.0-or-later
//
// Procedural textures for `cityatlas synth` (synthetic test towns).
//
// Every synthetic building gets its own facade texture so that a rendered view of the
// town can be checked against the scene description: the building's NUMBER is drawn in
// large digits on a plain plate, and a later test reads it back from the render.
//
// Facade layout (row 0 = top of the image):
//   * a wall pattern chosen by the seed (brick, ashlar blocks or concrete panels),
//     a darker cornice along the top edge and a plinth along the bottom edge;
//   * a "sign band" in the upper part: the number plate, centred horizontally, its top
//     edge at height/8;
//   * below the sign band, `storeys` equal rows, each with `window_columns` evenly spaced
//     windows (frame, glazing bars, sill); the bottom row has a door instead of one window.
//
// The number plate contract (relied on by the decoding tests and by render checks):
//   * the plate is exactly (255,255,255) and the digits exactly (0,0,0); nothing else on
//     the facade uses either colour (all other colours are kept within 8..247);
//   * the plate is framed by a dark border and the digits use the 5x7 font of digitGlyph(),
//     one font cell = s x s pixels, one empty cell between digits, one cell of plate padding
//     around the text; every glyph touches all four sides of its 5x7 box;
//   * s = min(2*height/63, width/(6*digits+3)), at least 1: the digits are about 22% of
//     the image height unless the number has to shrink to fit the width;
//   * alpha (RGBA facades) is 255 everywhere except window glass, which is 0..100.
//
// Legibility: the number can be decoded exactly from the image whenever it fits at s = 1,
// i.e. width >= 6*digits+3 (a 6-digit number needs width >= 39; 16 px fits 2 digits; if it
// does not fit, the plate and digits are clipped at the image edges, never drawn outside).
// The guaranteed-legible minimum for a render (font cells of at least 2x2 px) for numbers
// of up to 6 digits is width >= 78 and height >= 63, so 128x128 is the smallest recommended
// size (cells 3 px for 6 digits, 4 px for 1..4 digits); at 512x512 cells are 13..16 px.
//
// Determinism: integer arithmetic and a splitmix64 hash only, so the same inputs give the
// same bytes with any compiler, standard library and libm.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace cityatlas::synth {

struct FacadeStyle {
    uint32_t building_number = 0;   // drawn in decimal, large
    int storeys = 1;                // rows of windows, bottom row has a door; >= 1
    int window_columns = 3;         // windows per row, >= 1
    bool transparent_glass = false; // RGBA output with translucent panes
    uint64_t seed = 0;              // varies wall/window colours and small details
    bool number_plate = true;       // false: no sign band plate (stylised-facade truth tests)
};

// Image in memory, row 0 = TOP of the image (as PNG stores it), interleaved 8-bit channels.
struct Image8 {
    int width = 0, height = 0, channels = 0;   // channels 3 (RGB) or 4 (RGBA)
    std::vector<uint8_t> pixels;               // width*height*channels bytes
};

// Draws a facade (see the layout above). width, height: 16..16384 each (not necessarily
// powers of two); channels = transparent_glass ? 4 : 3. Throws std::invalid_argument when
// a size is out of range or storeys / window_columns < 1. Storeys too small to hold a
// window (on a tiny texture) are drawn as plain wall. About 0.4 ms for 512x512 on one core.
Image8 drawFacade(const FacadeStyle& style, int width, int height);

// What each pixel of a drawn facade shows (the ground truth of stylised facades,
// ingest/stylised_facades.h): the wall pattern (blocks and joints), trim (cornice,
// plinth, string courses), a window (frame, glass, bars and sill), the door (with its
// frame) or the number plate (with its border).
enum class FacadePart : uint8_t { Wall, Trim, Window, Door, Plate };
struct FacadeTruth {
    int width = 0, height = 0;
    std::vector<FacadePart> part;  // width*height, row 0 = top
    int window_rows = 0;           // storeys drawn with openings (windows, or the door alone)
    int window_columns = 0;        // windows per row as drawn (0 when the slots are too small)
};
// drawFacade, also labelling every pixel.
Image8 drawFacade(const FacadeStyle& style, int width, int height, FacadeTruth* truth);

// Tileable paving, RGB, size x size (size 16..16384, else std::invalid_argument):
// a 4x4 grid of square slabs with mortar joints, deterministic for (size, seed).
// Joints are centred on the tile border, so column size-1 continues into column 0 and
// row size-1 into row 0 when the texture repeats.
Image8 drawPaving(int size, uint64_t seed);

// Writes `image` as PNG with OpenImageIO (zlib level 2, no timestamps or other varying
// metadata: identical images give byte-identical files). RGBA is written as straight
// (unassociated) alpha, exactly as stored. Returns false and, if error is non-null, sets
// *error to one line "<path>: <reason>" on failure (no partial file is left behind).
bool writePng(const std::string& path, const Image8& image, std::string* error);

// The 5x7 bitmap glyphs used for the number: 7 rows (top first) of 5 bits, bit 4 = leftmost
// column, for '0'..'9'; all zero for any other char.
std::array<uint8_t, 7> digitGlyph(char digit);

}  // namespace cityatlas::synth
