// render_benchmark: times the synthetic radiograph pipeline on a 1024x1024 view of two
// ~10,000-triangle meshes (path lengths, then detector model), and one mesh's silhouette mask
// (what each contour extraction of a registration fills, from the contour generators, and the
// renderer's rasterised coverage for comparison), and prints the figures.
#include <algorithm>
#include <chrono>
#include <iostream>
#include <numeric>
#include <random>
#include <vector>

#include "fluoro_tracker/geometry/xray_camera.h"
#include "fluoro_tracker/imaging/detector_model.h"
#include "fluoro_tracker/imaging/renderer.h"
#include "fluoro_tracker/imaging/silhouette.h"
#include "fluoro_tracker/sim/mesh_builder.h"

using namespace fluoro_tracker;

namespace {

double percentile(std::vector<double> values, double p) {
  std::sort(values.begin(), values.end());
  const std::size_t index = static_cast<std::size_t>(p * (values.size() - 1) + 0.5);
  return values[index];
}

}  // namespace

int main(int argc, char** argv) {
  const int repeats = argc > 1 ? std::max(1, std::atoi(argv[1])) : 50;
  const geometry::XrayCamera camera(1024, 1024, 3158.0, 3158.0, 511.5, 511.5);
  // Two spheres of ~10k triangles each (50 x 100 UV grid), 30 mm radius, side by side at 1 m:
  // each covers ~190 px across, about the size of a knee component in a lateral view.
  const geometry::Mesh sphere = sim::uvSphere(0.03, 50, 100);
  const geometry::Pose left = geometry::makePose(Eigen::Matrix3d::Identity(), {-0.025, 0.0, 1.0});
  const geometry::Pose right = geometry::makePose(Eigen::Matrix3d::Identity(), {0.025, 0.01, 1.0});
  const std::vector<imaging::RenderObject> objects = {{&sphere, left, 1.0}, {&sphere, right, 0.2}};
  imaging::DetectorSettings detector;
  std::mt19937_64 rng(1);

  std::vector<double> integral_ms;
  std::vector<double> total_ms;
  for (int i = 0; i < repeats; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const cv::Mat line_integral = imaging::Renderer::lineIntegral(camera, objects);
    const auto t1 = std::chrono::steady_clock::now();
    const cv::Mat frame = imaging::formRadiograph(line_integral, detector, &rng);
    const auto t2 = std::chrono::steady_clock::now();
    integral_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    total_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t0).count());
  }
  // The silhouette mask in a crop around the mesh, as SilhouetteModel::contour fills it, and as
  // the renderer rasterises it; a 200 x 200 grid (79,600 triangles, most of them a pixel or
  // less, so that per-triangle work dominates the rasteriser as it does for a femoral
  // component's 12,292).
  const geometry::Mesh fine = sim::uvSphere(0.03, 200, 200);
  const imaging::SilhouetteModel silhouette(fine);
  const geometry::XrayCamera crop = camera.cropped(300, 300, 424, 424);
  std::vector<double> mask_ms;
  std::vector<double> coverage_ms;
  std::size_t covered = 0;
  std::size_t differ = 0;
  for (int i = 0; i < repeats; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const cv::Mat mask = silhouette.mask(crop, left);
    const auto t1 = std::chrono::steady_clock::now();
    const cv::Mat coverage = imaging::Renderer::coverage(crop, fine, left);
    const auto t2 = std::chrono::steady_clock::now();
    mask_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    coverage_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
    covered = static_cast<std::size_t>(cv::countNonZero(mask));
    differ = static_cast<std::size_t>(cv::countNonZero(mask != coverage));
  }
  std::cout << "render_benchmark: 1024x1024, 2 meshes x " << sphere.triangleCount()
            << " triangles, " << repeats << " repeats\n"
            << "  path-length line integral: median " << percentile(integral_ms, 0.5) << " ms, p95 "
            << percentile(integral_ms, 0.95) << " ms\n"
            << "  full frame (+ blur, noise, display): median " << percentile(total_ms, 0.5)
            << " ms, p95 " << percentile(total_ms, 0.95) << " ms\n"
            << "  silhouette mask (" << fine.triangleCount() << " triangles, " << covered
            << " pixels covered) from the contour generators: median " << percentile(mask_ms, 0.5)
            << " ms, p95 " << percentile(mask_ms, 0.95) << " ms; rasterised front faces: median "
            << percentile(coverage_ms, 0.5) << " ms, p95 " << percentile(coverage_ms, 0.95)
            << " ms; " << differ << " pixels differ\n";
  return 0;
}
