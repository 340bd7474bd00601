#include "fluoro_tracker/imaging/projection_similarity.h"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "fluoro_tracker/imaging/renderer.h"
#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace imaging {

double normalizedCrossCorrelation(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
  CV_Assert(a.size() == b.size() && a.channels() == 1 && b.channels() == 1);
  cv::Mat fa;
  cv::Mat fb;
  a.convertTo(fa, CV_64F);
  b.convertTo(fb, CV_64F);
  cv::Scalar mean_a;
  cv::Scalar std_a;
  cv::Scalar mean_b;
  cv::Scalar std_b;
  cv::meanStdDev(fa, mean_a, std_a, mask);
  cv::meanStdDev(fb, mean_b, std_b, mask);
  if (std_a[0] <= 0.0 || std_b[0] <= 0.0) return 0.0;
  const cv::Mat product = (fa - mean_a[0]).mul(fb - mean_b[0]);
  return cv::mean(product, mask)[0] / (std_a[0] * std_b[0]);
}

ProjectionSimilarity projectionSimilarity(const EdgeMap& frame,
                                          const std::vector<const geometry::Mesh*>& meshes,
                                          const std::vector<geometry::Pose>& poses) {
  if (meshes.size() != poses.size()) {
    throw InputError("projection similarity: " + std::to_string(poses.size()) + " pose(s) for " +
                     std::to_string(meshes.size()) + " mesh(es)");
  }
  const geometry::XrayCamera& camera = frame.camera();
  const geometry::Pose camera_from_fixed = camera.worldFromCamera().inverse();
  std::vector<RenderObject> objects;
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    objects.push_back({meshes[i], camera_from_fixed * poses[i], 1.0});
  }
  // Synthetic radiograph: attenuation through unit-density models, compressed like a display
  // (metal saturates in real frames, so long and short chords should look alike).
  cv::Mat synthetic = Renderer::lineIntegral(camera, objects);
  cv::Mat display;
  cv::exp(-0.5 * synthetic, display);
  display.convertTo(display, CV_8U, 255.0);

  ProjectionSimilarity s;
  // The frame may show implants dark or bright: the sign of the grey correlation is polarity.
  s.grey = std::abs(normalizedCrossCorrelation(frame.grey(), display));

  cv::Mat synthetic_edges;
  cv::Canny(display, synthetic_edges, 20, 50, 3, true);
  cv::Mat a;
  cv::Mat b;
  cv::GaussianBlur(frame.edges(), a, cv::Size(0, 0), 1.0);
  cv::GaussianBlur(synthetic_edges, b, cv::Size(0, 0), 1.0);
  s.edges = normalizedCrossCorrelation(a, b);
  return s;
}

}  // namespace imaging
}  // namespace fluoro_tracker
