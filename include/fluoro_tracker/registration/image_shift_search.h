#pragma once

#include <optional>
#include <vector>

#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/imaging/edge_map.h"
#include "fluoro_tracker/registration/registrar.h"

namespace fluoro_tracker {
namespace registration {

// Where a frame's bones moved across the views when the tracker's start missed them: a knee
// that travels through a fixed fluoroscope (a step-up, stair descent) moves 10-20 mm between
// frames at 30 Hz, several times what a registration from the last frame's poses captures (its
// robust scale is a few pixels), and on the trial's first frames, or after a lost frame, there is
// no velocity to predict it from. In each view the bones' projected contours at `poses` are
// moved together across a coarse edge map (EdgeMapSettings `edges`, at `scale`) by every whole
// coarse pixel up to `max_shift_m` at the bones' mean depth, each shift scored by the contour
// samples' mean chamfer distance to the edges (truncated at 3 coarse pixels). The views' best
// shifts give the knee's translation by least squares (one view: parallel to its image plane).
// Returns the poses moved by it (the same translation for every bone, so the joint is kept as
// it was), or nothing when every view's best is within a coarse pixel of no shift or no bone is
// in any view.
std::optional<std::vector<geometry::Pose>> posesShiftedToEdges(
    const std::vector<BoneModel>& bones, const std::vector<geometry::Pose>& poses,
    const std::vector<ViewImage>& views, const imaging::EdgeMapSettings& edges, double max_shift_m,
    double scale = 0.25);

}  // namespace registration
}  // namespace fluoro_tracker
