#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "fluoro_tracker/geometry/mesh.h"
#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/imaging/edge_map.h"

namespace fluoro_tracker {
namespace imaging {

// Normalised cross-correlation of two single-channel images over the pixels where `mask` is
// non-zero (all pixels when it is empty), in [-1, 1]; 0 when either is constant there.
double normalizedCrossCorrelation(const cv::Mat& a, const cv::Mat& b,
                                  const cv::Mat& mask = cv::Mat());

struct ProjectionSimilarity {
  double grey = 0.0;   // |NCC| of the frame with the synthetic projection (either polarity)
  double edges = 0.0;  // NCC of the frame's edges with the synthetic projection's edges
  double total() const { return grey + edges; }
};

// The dissertation's (JointTrack's) global image score: the bones are projected at `poses`
// (fixed frame) as a synthetic radiograph (path lengths through every mesh), and correlated
// with the frame in the edge map's region and scale, both as grey images and as edge images
// (each edge map blurred by 1 px so that near-coincident edges correlate). Higher is better;
// used to verify a registration or to compare candidate poses, not inside the solver.
ProjectionSimilarity projectionSimilarity(const EdgeMap& frame,
                                          const std::vector<const geometry::Mesh*>& meshes,
                                          const std::vector<geometry::Pose>& poses);

}  // namespace imaging
}  // namespace fluoro_tracker
