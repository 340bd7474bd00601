#include "fluoro_tracker/imaging/projection_similarity.h"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "fluoro_tracker/imaging/renderer.h"
#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace imaging {

double normalizedCrossCorrelation(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
  CV_Assert(a.size() == b.size() && a.channels() == 1 && b.channels() == 1);
  CV_Assert(mask.empty() || (mask.size() == a.size() && mask.type() == CV_8UC1));
  // Two passes over the rows (means, then centred moments), each row converted into one reused
  // buffer: image-sized double temporaries cost more in page faults than in arithmetic (a
  // 1024 x 1024 frame's score took ~0.3 s, and the freed memory slowed what ran next).
  cv::Mat row_a;
  cv::Mat row_b;
  // Calls body(a, b) for each pixel pair the mask lets through, in raster order.
  const auto for_each_pixel = [&](const auto& body) {
    for (int v = 0; v < a.rows; ++v) {
      a.row(v).convertTo(row_a, CV_64F);
      b.row(v).convertTo(row_b, CV_64F);
      const double* x = row_a.ptr<double>();
      const double* y = row_b.ptr<double>();
      const uchar* m = mask.empty() ? nullptr : mask.ptr<uchar>(v);
      for (int u = 0; u < a.cols; ++u) {
        if (m == nullptr || m[u] != 0) body(x[u], y[u]);
      }
    }
  };
  double count = 0.0;
  double sum_a = 0.0;
  double sum_b = 0.0;
  for_each_pixel([&](double x, double y) {
    count += 1.0;
    sum_a += x;
    sum_b += y;
  });
  if (count == 0.0) return 0.0;
  const double mean_a = sum_a / count;
  const double mean_b = sum_b / count;
  double saa = 0.0;
  double sbb = 0.0;
  double sab = 0.0;
  for_each_pixel([&](double x, double y) {
    const double da = x - mean_a;
    const double db = y - mean_b;
    saa += da * da;
    sbb += db * db;
    sab += da * db;
  });
  if (saa <= 0.0 || sbb <= 0.0) return 0.0;
  return sab / std::sqrt(saa * sbb);
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
