// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Stylised facades (issue 19 item 4; papers/000 §5.2.2): a photo facade
/// reduced to its average facade colour, its average window colour and its
/// window grid, then drawn again as a clean texture of the same size. The
/// thesis did the reduction by hand and named rectangle detection as future
/// work; here it is automatic:
///
/// 1. Two per-pixel measures of how far a pixel is from the wall: its
///    colour's distance from the facade's median colour, box-blurred over
///    1/32 of the facade (the joints of a brick wall average out, while a
///    window's glass and frame, both far, stay far), and the blurred
///    colour's distance from the median blurred colour (a window of another
///    hue shows there even when its glass is no farther from the wall than
///    the joints are). SEED-FEATURES §4.2 suggests two-cluster k-means on
///    luminance; on the synthetic town that failed where glass and a red
///    brick wall share a luminance, and where the cluster split sills and
///    lit windows from the rest.
/// 2. For each measure the cut where the facade ends: the histogram's main
///    peak plus three of its half widths, or the valley before a second peak
///    where that comes first. Far pixels are windows, trim, doors and signs;
///    full-width bands are trim; blobs larger than the typical blob both ways
///    (signs, number plates) are not windows.
/// 3. The grid along u and along v from the windows' share of each column
///    (row): its runs; where they repeat, one regular grid through them
///    (the spacing of the runs, refined by the profile's autocorrelation and
///    a least-squares fit of the runs to it), each cell confirmed by a run;
///    the cells' extent then tightened on the unblurred distances.
/// 4. The facade colour: the mean in linear light of the pixels neither far
///    nor near a window, row by row, each row weighted by its facade area
///    (trim bands and window rows take their own share); the windows' colour
///    from their pixels inside the cells.
///
/// Measured against the synthetic facades' truth (tests/ingest/
/// test_stylised_facades.cpp) at 128-512 px: windows per row right on
/// all 216 facades, rows on 96.3 %, the facade colour within 2/255 on
/// 93.1 %. The grid assumes the texture shows the wall upright (rows
/// level); the build pass checks that (cli/shards.h addStylisedFacades).

#include <array>
#include <cstdint>
#include <vector>

#include "ingest/scene.h"
#include "ingest/synth/facade_texture.h"

namespace cityatlas {

/// One axis of a window grid: where each window starts and how long it is (pixels).
struct WindowAxis {
    std::vector<int> start;  ///< increasing; empty when no windows
    int length = 0;
    double period = 0;       ///< pixels; 0 when the windows were not found periodic
};

/// What a facade is reduced to.
struct FacadeSummary {
    std::array<uint8_t, 3> facade_rgb{0, 0, 0};  ///< sRGB
    std::array<uint8_t, 3> window_rgb{0, 0, 0};  ///< sRGB
    uint8_t facade_alpha = 255, window_alpha = 255;
    WindowAxis columns;  ///< along u (image x)
    WindowAxis rows;     ///< along v (image y, row 0 = top)
};

/// The summary of a facade image (1 to 4 channels, rows top-down).
FacadeSummary analyseFacade(const synth::Image8& image);

/// Whether a wall triangle's texture shows the wall upright: world up runs
/// up the image (rows stay level on the wall) within 10 degrees. Photos
/// rectified to the facade do; crops of oblique aerial images often do not,
/// and a window grid along the image's axes means nothing there.
bool uprightOnWall(const Triangle& t, const TextureInfo& texture);

/// The clean facade of a summary: facade colour, and a window at every
/// (row, column) of the grid. channels 3 or 4.
synth::Image8 drawStylisedFacade(const FacadeSummary& summary, int width, int height, int channels);

}  // namespace cityatlas
