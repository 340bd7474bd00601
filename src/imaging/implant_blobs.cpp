#include "fluoro_tracker/imaging/implant_blobs.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace imaging {
namespace {

// Value below which `fraction` of a CV_32F image's pixels lie.
float quantile(const cv::Mat& image, double fraction) {
  std::vector<float> v(image.begin<float>(), image.end<float>());
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(fraction * (v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

bool isDuplicate(const ImplantBlob& blob, const std::vector<ImplantBlob>& kept) {
  for (const auto& other : kept) {
    const double area_ratio = blob.area_px / other.area_px;
    if (other.dark == blob.dark && (blob.centroid - other.centroid).norm() < 3.0 / blob.scale &&
        area_ratio > 0.9 && area_ratio < 1.1) {
      return true;
    }
  }
  return false;
}

}  // namespace

std::vector<ImplantBlob> findImplantBlobs(const cv::Mat& image,
                                          const ImplantBlobSettings& settings) {
  if (image.empty()) throw InputError("implant blobs: empty image");
  if (image.channels() != 1 || (image.depth() != CV_8U && image.depth() != CV_16U)) {
    throw InputError("implant blobs: expected an 8- or 16-bit grey image");
  }
  const double scale = std::min(
      1.0, settings.working_size_px / static_cast<double>(std::max(image.cols, image.rows)));
  cv::Mat grey;
  image.convertTo(grey, CV_32F);
  if (scale < 1.0) cv::resize(grey, grey, cv::Size(), scale, scale, cv::INTER_AREA);
  cv::GaussianBlur(grey, grey, cv::Size(0, 0), 1.0);
  const float low = quantile(grey, settings.window_low_percentile / 100.0);
  const float high = quantile(grey, settings.window_high_percentile / 100.0);
  if (!(high > low)) return {};
  const double total = static_cast<double>(grey.total());
  const cv::Mat opening = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(3, 3));
  std::vector<ImplantBlob> blobs;
  for (bool dark : {true, false}) {
    for (double fraction : settings.threshold_fractions) {
      const double level = dark ? low + fraction * (high - low) : high - fraction * (high - low);
      cv::Mat mask = dark ? (grey <= level) : (grey >= level);
      cv::morphologyEx(mask, mask, cv::MORPH_OPEN, opening);
      cv::Mat labels;
      cv::Mat stats;
      cv::Mat centroids;
      const int count = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
      for (int label = 1; label < count; ++label) {
        const cv::Rect box(
            stats.at<int>(label, cv::CC_STAT_LEFT), stats.at<int>(label, cv::CC_STAT_TOP),
            stats.at<int>(label, cv::CC_STAT_WIDTH), stats.at<int>(label, cv::CC_STAT_HEIGHT));
        const double area = stats.at<int>(label, cv::CC_STAT_AREA);
        const bool touches_border =
            box.x == 0 || box.y == 0 || box.br().x == grey.cols || box.br().y == grey.rows;
        if (touches_border || area < settings.min_area_fraction * total ||
            area > settings.max_area_fraction * total) {
          continue;
        }
        ImplantBlob blob;
        blob.mask = (labels(box) == label);
        blob.box = box;
        blob.scale = scale;
        // Pixel centres: mask pixel (x, y) covers frame pixels around ((x + 0.5) / s - 0.5).
        blob.centroid = Eigen::Vector2d((centroids.at<double>(label, 0) + 0.5) / scale - 0.5,
                                        (centroids.at<double>(label, 1) + 0.5) / scale - 0.5);
        blob.area_px = area / (scale * scale);
        blob.dark = dark;
        if (!isDuplicate(blob, blobs)) blobs.push_back(std::move(blob));
      }
    }
  }
  return blobs;
}

}  // namespace imaging
}  // namespace fluoro_tracker
