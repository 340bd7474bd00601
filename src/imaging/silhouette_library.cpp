#include "fluoro_tracker/imaging/silhouette_library.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/parallel_for.h"

namespace fluoro_tracker {
namespace imaging {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kGridPerUnit = 10.0;       // normalised pixels per sqrt(area)
constexpr int kTemplatePixels = 96;         // template masks are rendered this wide
constexpr std::size_t kOutlinePoints = 48;  // boundary points kept per template

// The orthographic silhouette of `mesh` at orientation `rotation`: its mask, pixel size (m)
// and the metric position of pixel (0, 0).
ShapeTemplate renderTemplate(const geometry::Mesh& mesh, const Eigen::Matrix3d& rotation) {
  std::vector<Eigen::Vector2d> xy;
  xy.reserve(mesh.vertexCount());
  Eigen::AlignedBox2d box;
  for (const auto& v : mesh.vertices()) {
    xy.push_back((rotation * v).head<2>());
    box.extend(xy.back());
  }
  const double pixel = box.sizes().maxCoeff() / (kTemplatePixels - 8);
  const Eigen::Vector2d origin = box.min() - Eigen::Vector2d::Constant(4.0 * pixel);
  cv::Mat mask(kTemplatePixels, kTemplatePixels, CV_8U, cv::Scalar(0));
  constexpr int kShift = 4;
  const double sub = 1 << kShift;
  for (const auto& t : mesh.triangles()) {
    cv::Point corners[3];
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector2d p = (xy[t[k]] - origin) / pixel;
      corners[k] = cv::Point(static_cast<int>(std::lround(p.x() * sub)),
                             static_cast<int>(std::lround(p.y() * sub)));
    }
    cv::fillConvexPoly(mask, corners, 3, cv::Scalar(255), cv::LINE_8, kShift);
  }
  const cv::Moments m = cv::moments(mask, true);
  ShapeTemplate shape;
  shape.camera_from_mesh = rotation;
  if (m.m00 <= 0.0) return shape;
  const Eigen::Vector2d centroid(m.m10 / m.m00, m.m01 / m.m00);
  shape.area_m2 = m.m00 * pixel * pixel;
  shape.centroid_m = origin + centroid * pixel;
  shape.shape = SilhouetteLibrary::normalizedShape(mask, centroid, m.m00, 0.0);
  // Boundary points (outer and holes), thinned to about kOutlinePoints.
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask, contours, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
  std::size_t total = 0;
  for (const auto& c : contours) total += c.size();
  const std::size_t stride = std::max<std::size_t>(1, total / kOutlinePoints);
  std::size_t k = 0;
  for (const auto& c : contours) {
    for (const cv::Point& p : c) {
      if (k++ % stride != 0) continue;
      shape.outline_m.push_back(origin + Eigen::Vector2d(p.x, p.y) * pixel);
    }
  }
  return shape;
}

double dissimilarity(const cv::Mat& a, const cv::Mat& b) {
  double difference = 0.0;
  double sum = 0.0;
  for (int v = 0; v < a.rows; ++v) {
    const float* pa = a.ptr<float>(v);
    const float* pb = b.ptr<float>(v);
    for (int u = 0; u < a.cols; ++u) {
      difference += std::abs(pa[u] - pb[u]);
      sum += pa[u] + pb[u];
    }
  }
  return sum > 0.0 ? difference / sum : 1.0;
}

Eigen::Matrix3d rollAboutBeam(double roll) {
  return Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

}  // namespace

SilhouetteLibrary::SilhouetteLibrary(const geometry::Mesh& mesh, double direction_step_deg) {
  if (mesh.empty()) throw InputError("silhouette library: empty mesh");
  if (!(direction_step_deg > 1.0 && direction_step_deg < 90.0)) {
    throw InputError("silhouette library: direction step must be in (1, 90) degrees");
  }
  const double step = geometry::degToRad(direction_step_deg);
  const int directions = std::max(2, static_cast<int>(std::lround(4.0 * kPi / (step * step))));
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < directions; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / directions;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const Eigen::Vector3d view(r * std::cos(golden * i), r * std::sin(golden * i), z);
    // The mesh turned so that `view` (a direction in the mesh frame) points along the beam.
    const Eigen::Matrix3d rotation =
        Eigen::Quaterniond::FromTwoVectors(view, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    ShapeTemplate t = renderTemplate(mesh, rotation);
    if (t.area_m2 > 0.0) templates_.push_back(std::move(t));
  }
}

cv::Mat SilhouetteLibrary::normalizedShape(const cv::Mat& mask, const Eigen::Vector2d& centroid,
                                           double area_px, double roll_rad) {
  cv::Mat source;
  mask.convertTo(source, CV_32F, 1.0 / 255.0);
  const double unit = std::sqrt(area_px);  // mask pixels per normalised unit
  // Average away detail finer than a normalised pixel before sampling.
  const double sigma = 0.5 * unit / kGridPerUnit;
  if (sigma > 0.5) cv::GaussianBlur(source, source, cv::Size(0, 0), sigma);
  const double c = std::cos(roll_rad) * unit / kGridPerUnit;
  const double s = std::sin(roll_rad) * unit / kGridPerUnit;
  const double half = 0.5 * (kShapeSize - 1);
  // Destination (x, y) samples source centroid + R(roll) * ((x, y) - half) * unit / grid.
  cv::Matx23d inverse(c, -s, centroid.x() - c * half + s * half, s, c,
                      centroid.y() - s * half - c * half);
  cv::Mat shape;
  cv::warpAffine(source, shape, inverse, cv::Size(kShapeSize, kShapeSize),
                 cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_CONSTANT, cv::Scalar(0));
  return shape;
}

std::vector<ShapeMatch> SilhouetteLibrary::match(const ImplantBlob& blob, int count,
                                                 double roll_step_deg, double min_separation_deg,
                                                 int threads) const {
  const cv::Moments m = cv::moments(blob.mask, true);
  if (m.m00 <= 0.0 || templates_.empty()) return {};
  const Eigen::Vector2d centroid(m.m10 / m.m00, m.m01 / m.m00);
  const int rolls = std::max(1, static_cast<int>(std::lround(360.0 / roll_step_deg)));
  // Roll-major, as the tie order of the sort below depends on it.
  std::vector<ShapeMatch> all(static_cast<std::size_t>(rolls) * templates_.size());
  parallelFor(static_cast<std::size_t>(rolls), threads, [&](std::size_t r) {
    const double roll = 2.0 * kPi * static_cast<double>(r) / rolls;
    const cv::Mat shape = normalizedShape(blob.mask, centroid, m.m00, roll);
    for (std::size_t t = 0; t < templates_.size(); ++t) {
      all[r * templates_.size() + t] = {static_cast<int>(t), roll,
                                        dissimilarity(shape, templates_[t].shape)};
    }
  });
  std::sort(all.begin(), all.end(), [](const ShapeMatch& a, const ShapeMatch& b) {
    return a.dissimilarity < b.dissimilarity;
  });
  std::vector<ShapeMatch> best;
  std::vector<Eigen::Matrix3d> orientations;
  const double min_separation = geometry::degToRad(min_separation_deg);
  for (const ShapeMatch& candidate : all) {
    if (static_cast<int>(best.size()) >= count) break;
    const Eigen::Matrix3d orientation =
        rollAboutBeam(candidate.roll_rad) * templates_[candidate.template_index].camera_from_mesh;
    const bool distinct =
        std::all_of(orientations.begin(), orientations.end(), [&](const Eigen::Matrix3d& other) {
          return geometry::rotationAngleBetween(orientation, other) >= min_separation;
        });
    if (!distinct) continue;
    best.push_back(candidate);
    orientations.push_back(orientation);
  }
  return best;
}

std::vector<EdgeMatch> SilhouetteLibrary::matchEdges(
    const cv::Mat& edge_distance, const cv::Rect& search, const std::vector<double>& px_per_m,
    int count, double roll_step_deg, double position_step_px, double truncation_px,
    double min_separation_deg, double min_separation_px, int threads) const {
  if (edge_distance.empty() || edge_distance.type() != CV_32F || count < 1) return {};
  // Truncated distances, so that a lookup is one read; padded with the truncation distance as
  // far as any outline reaches, so that a point beyond the frame reads what it costs.
  cv::Mat truncated;
  cv::min(cv::abs(edge_distance), truncation_px, truncated);
  const cv::Rect area = search & cv::Rect(0, 0, truncated.cols, truncated.rows);
  if (area.empty()) return {};
  const int step = std::max(1, static_cast<int>(std::lround(position_step_px)));
  const int rolls = std::max(1, static_cast<int>(std::lround(360.0 / roll_step_deg)));
  double reach_m = 0.0;
  for (const auto& t : templates_) {
    for (const Eigen::Vector2d& q : t.outline_m) reach_m = std::max(reach_m, q.norm());
  }
  double max_scale = 0.0;
  for (const double scale : px_per_m) max_scale = std::max(max_scale, std::abs(scale));
  const int pad = static_cast<int>(std::ceil(reach_m * max_scale)) + 2;
  cv::Mat padded;
  cv::copyMakeBorder(truncated, padded, pad, pad, pad, pad, cv::BORDER_CONSTANT,
                     cv::Scalar(truncation_px));
  // Placements on a grid every `step` pixels; each one's score summed point by point in the
  // outline's order, a row of placements at a time (contiguous reads instead of one gather per
  // point and placement).
  const int columns = (area.width + step - 1) / step;
  const int rows = (area.height + step - 1) / step;
  // Templates are scored apart (threads may share them out) and their best placements gathered
  // in template order, as the tie order of the sort below depends on it.
  std::vector<std::vector<EdgeMatch>> best_per_template(templates_.size());
  parallelFor(templates_.size(), threads, [&](std::size_t t) {
    const auto& outline = templates_[t].outline_m;
    if (outline.empty()) return;
    std::vector<double> sums(static_cast<std::size_t>(columns) * static_cast<std::size_t>(rows));
    std::vector<cv::Point> offsets;
    for (int r = 0; r < rolls; ++r) {
      const double roll = 2.0 * kPi * r / rolls;
      const Eigen::Matrix2d rotation = rollAboutBeam(roll).topLeftCorner<2, 2>();
      for (const double scale : px_per_m) {
        offsets.clear();
        for (const Eigen::Vector2d& q : outline) {
          const Eigen::Vector2d o = scale * (rotation * q);
          offsets.emplace_back(static_cast<int>(std::lround(o.x())),
                               static_cast<int>(std::lround(o.y())));
        }
        std::fill(sums.begin(), sums.end(), 0.0);
        for (const cv::Point& o : offsets) {
          for (int j = 0; j < rows; ++j) {
            const float* row =
                padded.ptr<float>(area.y + j * step + o.y + pad) + area.x + o.x + pad;
            double* sum = sums.data() + static_cast<std::size_t>(j) * columns;
            for (int i = 0; i < columns; ++i) sum[i] += row[i * step];
          }
        }
        EdgeMatch best{static_cast<int>(t), roll, Eigen::Vector2d::Zero(), scale,
                       std::numeric_limits<double>::infinity()};
        for (int j = 0; j < rows; ++j) {
          for (int i = 0; i < columns; ++i) {
            const double sum = sums[static_cast<std::size_t>(j) * columns + i];
            if (sum < best.mean_distance_px) {
              best.mean_distance_px = sum;
              best.origin_px = Eigen::Vector2d(area.x + i * step, area.y + j * step);
            }
          }
        }
        best.mean_distance_px /= static_cast<double>(offsets.size());
        best_per_template[t].push_back(best);
      }
    }
  });
  std::vector<EdgeMatch> best_per_orientation;
  for (const auto& matches : best_per_template) {
    best_per_orientation.insert(best_per_orientation.end(), matches.begin(), matches.end());
  }
  std::sort(best_per_orientation.begin(), best_per_orientation.end(),
            [](const EdgeMatch& a, const EdgeMatch& b) {
              return a.mean_distance_px < b.mean_distance_px;
            });
  std::vector<EdgeMatch> kept;
  const double min_separation = geometry::degToRad(min_separation_deg);
  for (const EdgeMatch& candidate : best_per_orientation) {
    if (static_cast<int>(kept.size()) >= count) break;
    const Eigen::Matrix3d orientation =
        rollAboutBeam(candidate.roll_rad) * templates_[candidate.template_index].camera_from_mesh;
    const bool distinct = std::all_of(kept.begin(), kept.end(), [&](const EdgeMatch& other) {
      const Eigen::Matrix3d other_orientation =
          rollAboutBeam(other.roll_rad) * templates_[other.template_index].camera_from_mesh;
      return geometry::rotationAngleBetween(orientation, other_orientation) >= min_separation ||
             (candidate.origin_px - other.origin_px).norm() >= min_separation_px;
    });
    if (distinct) kept.push_back(candidate);
  }
  return kept;
}

geometry::Pose SilhouetteLibrary::cameraFromMesh(const EdgeMatch& match,
                                                 const geometry::XrayCamera& camera) const {
  const ShapeTemplate& t = templates_.at(static_cast<std::size_t>(match.template_index));
  const double focal = std::sqrt(camera.fx() * camera.fy());
  const double depth = focal / match.px_per_m;
  const Eigen::Vector3d ray = camera.pixelRay(match.origin_px);
  const Eigen::Matrix3d toward_ray =
      Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), ray).toRotationMatrix();
  geometry::Pose pose = geometry::Pose::Identity();
  pose.linear() = toward_ray * rollAboutBeam(match.roll_rad) * t.camera_from_mesh;
  pose.translation() = depth * ray;  // ray.z() == 1
  return pose;
}

geometry::Pose SilhouetteLibrary::cameraFromMesh(const ShapeMatch& match, const ImplantBlob& blob,
                                                 const geometry::XrayCamera& camera) const {
  const ShapeTemplate& t = templates_.at(static_cast<std::size_t>(match.template_index));
  const double focal = std::sqrt(camera.fx() * camera.fy());
  const double depth = focal * std::sqrt(t.area_m2 / blob.area_px);
  const Eigen::Matrix2d roll = rollAboutBeam(match.roll_rad).topLeftCorner<2, 2>();
  const Eigen::Vector2d origin_px = blob.centroid - (focal / depth) * (roll * t.centroid_m);
  const Eigen::Vector3d ray = camera.pixelRay(origin_px);
  // Seen off-axis, the bone is viewed along its ray rather than along the optical axis.
  const Eigen::Matrix3d toward_ray =
      Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), ray).toRotationMatrix();
  geometry::Pose pose = geometry::Pose::Identity();
  pose.linear() = toward_ray * rollAboutBeam(match.roll_rad) * t.camera_from_mesh;
  pose.translation() = depth * ray;
  return pose;
}

}  // namespace imaging
}  // namespace fluoro_tracker
