#pragma once

#include <vector>

#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/geometry/xray_camera.h"
#include "fluoro_tracker/imaging/edge_map.h"
#include "fluoro_tracker/imaging/silhouette.h"

namespace fluoro_tracker {
namespace registration {

// How far inside each projected contour sample (pixels, + inward) the edge map finds the edge
// of the bone's own radiograph, rendered from its model at this pose: the general form of
// cornerRounding. The bone's metal path length is rendered over the contour's bounds
// (imaging::Renderer), shown as a dark implant on a bright field whose grey saturates at
// `saturation_mm` of path, and the same edge map (`edges`) is run on it; each sample gets that
// map's signed distance at its pixel (0 where no rendered edge lies within 2 px). Besides
// corners this sees thin rims, a stem's tip and a plate's ends seen edge-on.
//
// An option (RegistrationSettings::rendered_edges), off by default: it costs about 1 ms per
// bone and outer iteration, and how fast a real frame's display saturates is not known
// (README "Registration", "Edges predicted from a rendered radiograph").
// `camera`: the edge map's camera (contour pixels are in its coordinates).
std::vector<double> renderedEdgeRounding(const imaging::SilhouetteModel& model,
                                         const geometry::XrayCamera& camera,
                                         const geometry::Pose& camera_from_mesh,
                                         const std::vector<imaging::ContourPoint>& contour,
                                         const imaging::EdgeMapSettings& edges,
                                         double saturation_mm);

}  // namespace registration
}  // namespace fluoro_tracker
