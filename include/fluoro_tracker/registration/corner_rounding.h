#pragma once

#include <vector>

#include "fluoro_tracker/imaging/silhouette.h"

namespace fluoro_tracker {
namespace registration {

// How far inside each projected contour sample (pixels, + inward) the edge map should find the
// implant's edge, where the outline turns sharply. Smoothing before edge detection rounds
// corners: at a convex corner the detected edge cuts inside the geometric outline, at a concave
// one it passes outside. Corners lie far from a bone's centre (a tray's plate ends, its stem's
// tip), so compared with the sharp outline they read as a smaller, more distant bone: on ideal
// 512 x 512 frames the tray ended 2.6 mm too far from the source (README "Registration").
//
// Near a corner the silhouette is modelled as two half-planes, the sample's own and that of the
// nearest sample within 3 sigma whose normal turns by more than 30 degrees: their intersection
// where the sample lies inside the other half-plane (convex), their union where it lies outside
// (concave). Blurred by a Gaussian of `sigma_px`, the half level of Phi(a / s) Phi(b / s)
// (or of 1 - Phi(-a / s) Phi(-b / s)) along the sample's normal is at
// a = s Phi^-1(0.5 / Phi(|b| / s)) inside (outside), b the sample's distance into the other
// half-plane; capped at sigma. Samples with no such neighbour (straight or gently curved
// outline, or parts wider than about 3 sigma) get 0. `sigma_px` <= 0: all 0.
std::vector<double> cornerRounding(const std::vector<imaging::ContourPoint>& contour,
                                   double sigma_px);

}  // namespace registration
}  // namespace fluoro_tracker
