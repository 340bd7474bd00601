#include "fluoro_tracker/imaging/edge_map.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "fluoro_tracker/imaging/border_components.h"
#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace imaging {
namespace {

// Counts a row's values into `histogram`, bin_of(value) of them, in four interleaved copies
// (size 4 x levels; sumBins adds them up): runs of equal neighbouring values, as in a
// radiograph's background, would otherwise make each increment wait for the one before on the
// same counter.
template <typename T, typename BinOf>
void countBins(const T* row, int cols, int levels, BinOf bin_of, std::uint32_t* h) {
  int u = 0;
  for (; u + 4 <= cols; u += 4) {
    ++h[bin_of(row[u])];
    ++h[levels + bin_of(row[u + 1])];
    ++h[2 * levels + bin_of(row[u + 2])];
    ++h[3 * levels + bin_of(row[u + 3])];
  }
  for (; u < cols; ++u) ++h[bin_of(row[u])];
}

// The histogram: the four copies countBins filled (4 x levels), added up into `histogram`.
template <typename Count>
void sumBins(const std::uint32_t* counts, int levels, Count* histogram) {
  for (int g = 0; g < levels; ++g) {
    histogram[g] = static_cast<Count>(counts[g]) + static_cast<Count>(counts[levels + g]) +
                   static_cast<Count>(counts[2 * levels + g]) +
                   static_cast<Count>(counts[3 * levels + g]);
  }
}

// Grey levels below which `low` and `high` fractions of an 8- or 16-bit region lie, from its
// histogram (linear time, no copy).
std::pair<double, double> percentiles(const cv::Mat& region, double low, double high) {
  const int levels = region.depth() == CV_8U ? 256 : 65536;
  std::vector<std::uint32_t> counts(static_cast<std::size_t>(4 * levels), 0);
  const auto identity = [](auto x) { return static_cast<int>(x); };
  for (int v = 0; v < region.rows; ++v) {
    if (region.depth() == CV_8U) {
      countBins(region.ptr<std::uint8_t>(v), region.cols, levels, identity, counts.data());
    } else {
      countBins(region.ptr<std::uint16_t>(v), region.cols, levels, identity, counts.data());
    }
  }
  std::vector<std::size_t> histogram(static_cast<std::size_t>(levels));
  sumBins(counts.data(), levels, histogram.data());
  const double total = static_cast<double>(region.total());
  double lo = 0.0;
  double hi = levels - 1.0;
  std::size_t count = 0;
  bool lo_found = false;
  for (int g = 0; g < levels; ++g) {
    count += histogram[g];
    if (!lo_found && count > low * total) {
      lo = g;
      lo_found = true;
    }
    if (count >= high * total) {
      hi = g;
      break;
    }
  }
  return {lo, hi};
}

// Bilinear sample of a CV_32F image, clamped to its border (an image one pixel wide or high is
// interpolated along its other axis).
double bilinear(const cv::Mat& image, double u, double v) {
  u = std::clamp(u, 0.0, image.cols - 1.0);
  v = std::clamp(v, 0.0, image.rows - 1.0);
  const int u0 = static_cast<int>(u);
  const int v0 = static_cast<int>(v);
  const int u1 = std::min(u0 + 1, image.cols - 1);
  const int v1 = std::min(v0 + 1, image.rows - 1);
  const double a = u - u0;
  const double b = v - v0;
  return (1 - b) * ((1 - a) * image.at<float>(v0, u0) + a * image.at<float>(v0, u1)) +
         b * ((1 - a) * image.at<float>(v1, u0) + a * image.at<float>(v1, u1));
}

// Value below which `fraction` of the (non-negative) values of a continuous CV_32F image lie:
// the exact order statistic, found by a histogram pass and a selection within the one bin that
// holds it, since sorting or selecting over every pixel of each map costs more than the map's
// Canny pass.
float percentile(const cv::Mat& values, double fraction) {
  const std::size_t count = values.total();
  if (count == 0) return 0.0f;
  const std::size_t k = std::min(count - 1, static_cast<std::size_t>(fraction * (count - 1)));
  double max_value = 0.0;
  cv::minMaxLoc(values, nullptr, &max_value);
  if (!(max_value > 0.0)) return 0.0f;
  constexpr int kBins = 4096;
  const float to_bin = static_cast<float>((kBins - 1) / max_value);
  const auto bin_of = [&](float x) {
    return std::clamp(static_cast<int>(x * to_bin), 0, kBins - 1);
  };
  std::vector<std::uint32_t> counts(4 * kBins, 0);
  for (int v = 0; v < values.rows; ++v) {
    countBins(values.ptr<float>(v), values.cols, kBins, bin_of, counts.data());
  }
  std::vector<std::size_t> histogram(kBins);
  sumBins(counts.data(), kBins, histogram.data());
  int bin = 0;
  std::size_t below = 0;
  while (below + histogram[bin] <= k) below += histogram[bin++];
  // The bin's values: those whose scaled value lies in [bin, bin + 1) (the last bin: above its
  // start), which is bin_of's test for non-negative values without its conversion to int.
  const float bin_low =
      bin == 0 ? -std::numeric_limits<float>::infinity() : static_cast<float>(bin);
  const float bin_high =
      bin == kBins - 1 ? std::numeric_limits<float>::infinity() : static_cast<float>(bin + 1);
  std::vector<float> in_bin;
  in_bin.reserve(histogram[bin]);
  for (int v = 0; v < values.rows; ++v) {
    const float* row = values.ptr<float>(v);
    for (int u = 0; u < values.cols; ++u) {
      const float scaled = row[u] * to_bin;
      if (scaled >= bin_low && scaled < bin_high) in_bin.push_back(row[u]);
    }
  }
  const auto kth = in_bin.begin() + static_cast<std::ptrdiff_t>(k - below);
  std::nth_element(in_bin.begin(), kth, in_bin.end());
  return *kth;
}

// Pixels of a windowed 8-bit region on or near a large saturated area that reaches the region's
// border: a collimated area (black, or white in an inverted display) or open air. Their border
// is a full-range step, and in a tightly collimated field it runs through the region around the
// implants; left in, it sets the automatic Canny thresholds (at stop 37, collimated to half the
// image: 52 of 60 tracked frames; the tray's faint outline in flexion dropped out). An implant
// is saturated too where it is thick, but it lies inside the region, which the bones'
// projections and a margin define. Saturated: within 8 grey levels of the window's ends; large:
// 0.5 % of the region; near: within 8 pixels (beyond the smoothing's and Sobel's reach).
cv::Mat saturatedAreaBorders(const cv::Mat& grey) {
  // Found on a quarter-resolution copy (block means; a tenth of the full-resolution search's
  // time), where saturated blocks lie wholly inside the area, and grown by two blocks.
  constexpr int kBlock = 4;
  if (grey.cols < 4 * kBlock || grey.rows < 4 * kBlock) return cv::Mat();
  cv::Mat blocks;
  cv::resize(grey, blocks, cv::Size(grey.cols / kBlock, grey.rows / kBlock), 0.0, 0.0,
             cv::INTER_AREA);
  cv::Mat band = cv::Mat::zeros(blocks.size(), CV_8U);
  for (int extreme : {0, 1}) {
    band |= componentsReachingBorder(extreme == 0 ? (blocks <= 8) : (blocks >= 247), 0.005);
  }
  if (cv::countNonZero(band) == 0) return cv::Mat();  // none: every pixel counts
  cv::dilate(band, band, cv::Mat::ones(5, 5, CV_8U));
  cv::Mat full;
  cv::resize(band, full, grey.size(), 0.0, 0.0, cv::INTER_NEAREST);
  return full;
}

// The values of `values` where `excluded` is zero (all of them when it is empty), as one row.
cv::Mat keptValues(const cv::Mat& values, const cv::Mat& excluded) {
  if (excluded.empty()) return values;
  // Written straight into the row it returns (a vector grown value by value and then copied
  // into a Mat was a fifth of the thresholds' time).
  cv::Mat kept(1, static_cast<int>(values.total()), CV_32F);
  float* out = kept.ptr<float>(0);
  int count = 0;
  for (int v = 0; v < values.rows; ++v) {
    const float* x = values.ptr<float>(v);
    const std::uint8_t* e = excluded.ptr<std::uint8_t>(v);
    for (int u = 0; u < values.cols; ++u) {
      out[count] = x[u];
      count += e[u] == 0;
    }
  }
  if (count == 0) return values;
  return kept.colRange(0, count);
}

// The standard deviation of one gradient component under the local noise, per kTilePx tile:
// the tile's 30th percentile of the gradient magnitude (for Gaussian noise the magnitude is
// Rayleigh, whose 30th percentile is 0.845 sigma; an edge crossing a tile covers far less than
// 30 % of it).
class LocalGradientNoise {
 public:
  static constexpr int kTilePx = 16;
  // The percentile is read from a histogram per tile (a selection per tile was most of this
  // filter's time): bins an eighth of an octave wide (the float's exponent and its top three
  // mantissa bits), from 2^-4 to 2^12 grey levels per pixel; smaller values share the first bin.
  static constexpr int kMantissaBits = 3;
  static constexpr int kLowestExponent = -4;
  static constexpr int kBins = 16 << kMantissaBits;

  explicit LocalGradientNoise(const cv::Mat& magnitude)
      : cols_(magnitude.cols),
        rows_(magnitude.rows),
        sigma_(std::max(1, magnitude.rows / kTilePx), std::max(1, magnitude.cols / kTilePx),
               CV_32F) {
    const int tiles_u = sigma_.cols;
    const int tiles_v = sigma_.rows;
    constexpr double kRayleigh30 = 0.8446;
    std::array<std::uint32_t, 4 * kBins> counts{};  // countBins' four copies
    std::array<int, kBins> histogram{};
    for (int tv = 0; tv < tiles_v; ++tv) {
      const int v0 = tv * rows_ / tiles_v;
      const int v1 = (tv + 1) * rows_ / tiles_v;
      for (int tu = 0; tu < tiles_u; ++tu) {
        const int u0 = tu * cols_ / tiles_u;
        const int u1 = (tu + 1) * cols_ / tiles_u;
        counts.fill(0);
        for (int v = v0; v < v1; ++v) {
          countBins(magnitude.ptr<float>(v) + u0, u1 - u0, kBins, binOf, counts.data());
        }
        sumBins(counts.data(), kBins, histogram.data());
        // The value with 30 % of the tile below it, linear within its bin.
        const double rank = 0.3 * (u1 - u0) * (v1 - v0);
        int bin = 0;
        int below = 0;
        while (bin < kBins - 1 && below + histogram[bin] <= rank) below += histogram[bin++];
        const double within = histogram[bin] > 0 ? (rank - below) / histogram[bin] : 0.0;
        const double value = binStart(bin) + within * (binStart(bin + 1) - binStart(bin));
        sigma_.at<float>(tv, tu) = static_cast<float>(value / kRayleigh30);
      }
    }
  }

  // Bilinear between tile centres, constant beyond the outer ones.
  double at(int u, int v) const {
    return bilinear(sigma_, (u + 0.5) * sigma_.cols / cols_ - 0.5,
                    (v + 0.5) * sigma_.rows / rows_ - 0.5);
  }

 private:
  static int binOf(float value) {
    // The key of 2^kLowestExponent: its biased exponent, then zero mantissa bits.
    constexpr int first = (127 + kLowestExponent) << kMantissaBits;
    const int key = static_cast<int>(bitsOf(std::max(value, 0.0f)) >> (23 - kMantissaBits));
    return std::clamp(key - first, 0, kBins - 1);
  }

  static double binStart(int bin) {
    if (bin <= 0) return 0.0;
    const int exponent = bin >> kMantissaBits;
    const int mantissa = bin & ((1 << kMantissaBits) - 1);
    return std::ldexp(1.0 + static_cast<double>(mantissa) / (1 << kMantissaBits),
                      kLowestExponent + exponent);
  }

  static std::uint32_t bitsOf(float value) {
    std::uint32_t bits = 0;
    std::memcpy(&bits, &value, sizeof(bits));
    return bits;
  }

  int cols_;
  int rows_;
  cv::Mat sigma_;  // CV_32F, one per tile
};

// The non-zero pixels of a sparse CV_8U mask in row-major order, skipping zeros eight at a
// time (cv::findNonZero looks at every pixel, twice).
std::vector<cv::Point> nonZeroPixels(const cv::Mat& mask) {
  std::vector<cv::Point> pixels;
  for (int v = 0; v < mask.rows; ++v) {
    const std::uint8_t* row = mask.ptr<std::uint8_t>(v);
    int u = 0;
    for (; u + 8 <= mask.cols; u += 8) {
      std::uint64_t word = 0;
      std::memcpy(&word, row + u, sizeof(word));
      if (word == 0) continue;
      for (int k = 0; k < 8; ++k) {
        if (row[u + k] != 0) pixels.emplace_back(u + k, v);
      }
    }
    for (; u < mask.cols; ++u) {
      if (row[u] != 0) pixels.emplace_back(u, v);
    }
  }
  return pixels;
}

// Removes from `edges` the pixels whose gradient is below `low` local noise standard
// deviations, and the 8-connected chains left that nowhere reach `high`. `pixels`: the edge
// pixels in row-major order (nonZeroPixels); those removed are dropped from it.
void removeInsignificantEdges(const cv::Mat& magnitude, double high, double low, cv::Mat* edges,
                              std::vector<cv::Point>* pixels) {
  const LocalGradientNoise noise(magnitude);
  std::size_t kept = 0;
  for (const cv::Point& p : *pixels) {
    if (magnitude.at<float>(p) < low * noise.at(p.x, p.y)) {
      edges->at<std::uint8_t>(p) = 0;
    } else {
      (*pixels)[kept++] = p;
    }
  }
  pixels->resize(kept);
  // Each chain, flood-filled from its first pixel, is dropped unless one pixel reaches `high`.
  cv::Mat visited = cv::Mat::zeros(edges->size(), CV_8U);
  std::vector<cv::Point> chain;
  for (const cv::Point& seed : *pixels) {
    if (visited.at<std::uint8_t>(seed) != 0) continue;
    chain.assign(1, seed);
    visited.at<std::uint8_t>(seed) = 1;
    bool significant = false;
    for (std::size_t i = 0; i < chain.size(); ++i) {
      const cv::Point p = chain[i];
      if (!significant && magnitude.at<float>(p) >= high * noise.at(p.x, p.y)) significant = true;
      for (int dv = -1; dv <= 1; ++dv) {
        for (int du = -1; du <= 1; ++du) {
          const cv::Point q(p.x + du, p.y + dv);
          if (q.x < 0 || q.y < 0 || q.x >= edges->cols || q.y >= edges->rows) continue;
          if (edges->at<std::uint8_t>(q) == 0 || visited.at<std::uint8_t>(q) != 0) continue;
          visited.at<std::uint8_t>(q) = 1;
          chain.push_back(q);
        }
      }
    }
    if (!significant) {
      for (const cv::Point& p : chain) edges->at<std::uint8_t>(p) = 0;
    }
  }
  kept = 0;
  for (const cv::Point& p : *pixels) {
    if (edges->at<std::uint8_t>(p) != 0) (*pixels)[kept++] = p;
  }
  pixels->resize(kept);
}

// How far either side of an outline its two sides' greys are read (map pixels): beyond the
// detector's and the edge map's blur, within an implant's thinnest part. An edge's two sides
// are both read at the inner reach (which of them is the implant's is not known).
constexpr double kInsideReachPx = 2.0;
constexpr double kOutsideReachPx = 3.0;

// Leaves out the edges beside clipped grey (EdgeMapSettings::clipped_grey_margin).
void removeEdgesBesideClippedGrey(const ClippedGrey& clipped, const cv::Mat& gx, const cv::Mat& gy,
                                  cv::Mat* edges, std::vector<cv::Point>* pixels) {
  std::size_t kept = 0;
  for (const cv::Point& p : *pixels) {
    Eigen::Vector2d n(gx.at<float>(p), gy.at<float>(p));  // toward the brighter side
    const double norm = n.norm();
    bool beside = false;
    if (norm > 0.0) {
      n /= norm;
      const Eigen::Vector2d pixel(p.x, p.y);
      const Eigen::Vector2d darker = pixel - kInsideReachPx * n;
      const Eigen::Vector2d brighter = pixel + kInsideReachPx * n;
      beside = clipped.beside(darker, brighter) || clipped.beside(brighter, darker);
    }
    if (beside) {
      edges->at<std::uint8_t>(p) = 0;
    } else {
      (*pixels)[kept++] = p;
    }
  }
  pixels->resize(kept);
}

}  // namespace

void EdgeMapSettings::validate() const {
  if (!(window_low_percentile >= 0.0 && window_high_percentile <= 100.0 &&
        window_low_percentile < window_high_percentile)) {
    throw InputError("edge map: window percentiles must satisfy 0 <= low < high <= 100");
  }
  if (!(max_distance_px > 1.0)) throw InputError("edge map: max_distance_px must be > 1");
  if (!(blur_sigma_px >= 0.0)) throw InputError("edge map: blur_sigma_px must be >= 0");
  if (!(line_distance_band_px > 0.0)) {
    throw InputError("edge map: line_distance_band_px must be > 0");
  }
  if (!(clipped_grey_margin >= 0.0 && clipped_grey_margin < 1.0)) {
    throw InputError("edge map: clipped_grey_margin must be in [0, 1)");
  }
  if (!(min_edge_significance >= 0.0) ||
      !(edge_significance_low_ratio > 0.0 && edge_significance_low_ratio <= 1.0)) {
    throw InputError(
        "edge map: min_edge_significance must be >= 0 and edge_significance_low_ratio in (0, 1]");
  }
  if (canny_low < 0.0 || canny_high < 0.0)
    throw InputError("edge map: Canny thresholds must be >= 0");
}

EdgeMap::EdgeMap(const cv::Mat& image, const geometry::XrayCamera& camera, const EdgeMapSettings& s,
                 cv::Rect roi, double scale)
    : scale_(scale), max_distance_(s.max_distance_px) {
  s.validate();
  if (image.empty())
    throw InputError("edge map: the image of view '" + camera.frameId() + "' is empty");
  if (image.cols != camera.width() || image.rows != camera.height()) {
    throw InputError("edge map: image of view '" + camera.frameId() + "' is " +
                     std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                     " but its camera_info says " + std::to_string(camera.width()) + "x" +
                     std::to_string(camera.height()));
  }
  if (image.channels() != 1 || (image.depth() != CV_8U && image.depth() != CV_16U)) {
    throw InputError("edge map: image of view '" + camera.frameId() +
                     "' must be 8- or 16-bit single-channel grey");
  }
  if (!(scale > 0.0 && scale <= 1.0)) throw InputError("edge map: scale must be in (0, 1]");
  const cv::Rect full(0, 0, image.cols, image.rows);
  roi_ = roi.area() > 0 ? (roi & full) : full;
  if (roi_.area() == 0) roi_ = full;

  cv::Mat region;
  image(roi_).convertTo(region, CV_32F);
  if (scale < 1.0) cv::resize(region, region, cv::Size(), scale, scale, cv::INTER_AREA);
  camera_ = camera.cropped(roi_.x, roi_.y, roi_.width, roi_.height);
  if (scale < 1.0) camera_ = camera_.scaled(scale);
  // Scaling may round the size; keep the camera and the image consistent.
  camera_ = geometry::XrayCamera(region.cols, region.rows, camera_.fx(), camera_.fy(), camera_.cx(),
                                 camera_.cy(), camera_.frameId());
  camera_.setWorldFromCamera(camera.worldFromCamera());

  // Window to 8 bits between robust percentiles of the region's grey levels.
  const auto [lo, hi_raw] =
      percentiles(image(roi_), s.window_low_percentile / 100.0, s.window_high_percentile / 100.0);
  const double hi = hi_raw > lo ? hi_raw : lo + 1.0;
  region.convertTo(grey_, CV_8U, 255.0 / (hi - lo), -255.0 * lo / (hi - lo));
  if (s.clahe) {
    cv::createCLAHE(s.clahe_clip_limit, cv::Size(8, 8))->apply(grey_, grey_);
  }
  cv::Mat smooth = grey_;
  if (s.blur_sigma_px > 0.0) cv::GaussianBlur(grey_, smooth, cv::Size(0, 0), s.blur_sigma_px);

  cv::Mat gx;
  cv::Mat gy;
  cv::Mat magnitude;
  cv::Sobel(smooth, gx, CV_32F, 1, 0);
  cv::Sobel(smooth, gy, CV_32F, 0, 1);
  cv::magnitude(gx, gy, magnitude);
  double low = s.canny_low;
  double high = s.canny_high;
  if (high <= 0.0) {
    // EdgeMapSettings::thresholds_skip_saturated_borders; see saturatedAreaBorders.
    const cv::Mat field_border =
        s.thresholds_skip_saturated_borders ? saturatedAreaBorders(grey_) : cv::Mat();
    high = std::max(10.0,
                    s.auto_high_fraction * percentile(keptValues(magnitude, field_border), 0.995));
    low = s.auto_low_ratio * high;
  } else if (low <= 0.0) {
    low = s.auto_low_ratio * high;
  }
  cv::Canny(smooth, edges_, low, high, 3, true);
  // The edge pixels, listed once: Canny's edges are a few percent of the region, and scanning
  // every pixel for them, as each step after it did, cost more than the steps' own work.
  std::vector<cv::Point> edge_pixels = nonZeroPixels(edges_);
  if (s.min_edge_significance > 0.0) {
    removeInsignificantEdges(magnitude, s.min_edge_significance,
                             s.edge_significance_low_ratio * s.min_edge_significance, &edges_,
                             &edge_pixels);
  }
  clipped_grey_ = ClippedGrey(region, hi - lo, s.clipped_grey_margin);
  if (!clipped_grey_.empty()) {
    removeEdgesBesideClippedGrey(clipped_grey_, gx, gy, &edges_, &edge_pixels);
  }
  findNearestEdges(gx, gy, magnitude, edge_pixels, s.line_distance_band_px);
}

bool EdgeMap::besideClippedGrey(const Eigen::Vector2d& pixel,
                                const Eigen::Vector2d& outward) const {
  return clipped_grey_.beside(pixel - kInsideReachPx * outward, pixel + kOutsideReachPx * outward);
}

bool EdgeMap::amidClippedGrey(const Eigen::Vector2d& pixel) const {
  return clipped_grey_.amidNearEnd(pixel, kOutsideReachPx);
}

void EdgeMap::findNearestEdges(const cv::Mat& gx, const cv::Mat& gy, const cv::Mat& magnitude,
                               const std::vector<cv::Point>& edge_pixels, double band) {
  // Sub-pixel edge points and unit normals (toward the brighter side) at every edge pixel.
  edge_points_ = cv::Mat(edges_.size(), CV_32FC2, cv::Scalar(0, 0));
  distance_window_ = cv::Rect(0, 0, edges_.cols, edges_.rows);
  std::vector<Eigen::Vector2d> points;
  std::vector<Eigen::Vector2d> normals;
  points.reserve(edge_pixels.size());
  normals.reserve(edge_pixels.size());
  for (const cv::Point& pixel : edge_pixels) {
    const int u = pixel.x;
    const int v = pixel.y;
    Eigen::Vector2d n(gx.at<float>(v, u), gy.at<float>(v, u));
    const double norm = n.norm();
    n = norm > 0.0 ? Eigen::Vector2d(n / norm) : Eigen::Vector2d(1.0, 0.0);
    const double m0 = magnitude.at<float>(v, u);
    const double plus = bilinear(magnitude, u + n.x(), v + n.y());
    const double minus = bilinear(magnitude, u - n.x(), v - n.y());
    const double curvature = plus - 2.0 * m0 + minus;
    double offset = 0.0;
    if (curvature < 0.0) offset = std::clamp(0.5 * (minus - plus) / curvature, -0.5, 0.5);
    const Eigen::Vector2d point = Eigen::Vector2d(u, v) + offset * n;
    edge_points_.at<cv::Vec2f>(v, u) =
        cv::Vec2f(static_cast<float>(point.x()), static_cast<float>(point.y()));
    points.push_back(point);
    normals.push_back(n);
  }
  if (points.empty()) {
    distance_ = cv::Mat(edges_.size(), CV_32F, cv::Scalar(max_distance_));
    return;
  }
  distance_ = cv::Mat(edges_.size(), CV_32F, cv::Scalar(kNotWorkedOut));
  nearest_ = bucketEdgePoints(points, normals, band, edges_.size());
}

std::shared_ptr<const EdgeMap::NearestEdges> EdgeMap::bucketEdgePoints(
    const std::vector<Eigen::Vector2d>& points, const std::vector<Eigen::Vector2d>& normals,
    double band, cv::Size size) {
  // The points bucketed by grid cell (a counting sort), so that a pixel's nearest is found by
  // searching the cells around it ring by ring.
  auto nearest = std::make_shared<NearestEdges>();
  nearest->band = band;
  nearest->cols = (size.width + kCellPx - 1) / kCellPx;
  nearest->rows = (size.height + kCellPx - 1) / kCellPx;
  const auto cell_of = [&](const Eigen::Vector2d& p) {
    const int cu = std::clamp(static_cast<int>(std::floor(p.x() / kCellPx)), 0, nearest->cols - 1);
    const int cv = std::clamp(static_cast<int>(std::floor(p.y() / kCellPx)), 0, nearest->rows - 1);
    return cv * nearest->cols + cu;
  };
  nearest->cell_begin.assign(static_cast<std::size_t>(nearest->cols * nearest->rows) + 1, 0);
  for (const auto& p : points) ++nearest->cell_begin[cell_of(p) + 1];
  for (std::size_t c = 1; c < nearest->cell_begin.size(); ++c) {
    nearest->cell_begin[c] += nearest->cell_begin[c - 1];
  }
  std::vector<int> next(nearest->cell_begin.begin(), nearest->cell_begin.end() - 1);
  nearest->points.resize(points.size());
  nearest->normals.resize(points.size());
  for (std::size_t k = 0; k < points.size(); ++k) {
    const int slot = next[cell_of(points[k])]++;
    nearest->points[slot] = points[k];
    nearest->normals[slot] = normals[k];
  }
  return nearest;
}

EdgeMap EdgeMap::withoutEdgesIn(const cv::Mat& mask, cv::Point origin) const {
  EdgeMap copy = *this;
  if (!mask.empty() && mask.type() != CV_8U) {
    throw InputError("edge map: a mask of edges to leave out must be CV_8U");
  }
  const cv::Rect map_rect(0, 0, edges_.cols, edges_.rows);
  const cv::Rect mask_rect = cv::Rect(origin, mask.size()) & map_rect;
  if (!nearest_ || mask_rect.empty()) return copy.unshared();
  const cv::Mat on_map = mask(mask_rect - origin);  // the mask's part on the map
  const auto masked = [&](int u, int v) {
    return mask_rect.contains(cv::Point(u, v)) &&
           on_map.at<std::uint8_t>(v - mask_rect.y, u - mask_rect.x) != 0;
  };
  const NearestEdges& nearest = *nearest_;
  auto left_out = left_out_ ? std::make_shared<std::vector<std::uint8_t>>(*left_out_)
                            : std::make_shared<std::vector<std::uint8_t>>(nearest.points.size(), 0);
  // Only the cells the mask covers, and one more each side: a point bucketed by its floor may
  // round to a pixel of the next cell.
  const int cu0 = std::max(0, mask_rect.x / kCellPx - 1);
  const int cv0 = std::max(0, mask_rect.y / kCellPx - 1);
  const int cu1 = std::min(nearest.cols - 1, (mask_rect.br().x - 1) / kCellPx + 1);
  const int cv1 = std::min(nearest.rows - 1, (mask_rect.br().y - 1) / kCellPx + 1);
  for (int cv = cv0; cv <= cv1; ++cv) {
    for (int cu = cu0; cu <= cu1; ++cu) {
      const int c = cv * nearest.cols + cu;
      for (int k = nearest.cell_begin[c]; k < nearest.cell_begin[c + 1]; ++k) {
        const Eigen::Vector2d& p = nearest.points[k];
        if (masked(static_cast<int>(std::floor(p.x() + 0.5)),
                   static_cast<int>(std::floor(p.y() + 0.5)))) {
          (*left_out)[k] = 1;
        }
      }
    }
  }
  copy.edges_ = edges_.clone();
  copy.edges_(mask_rect).setTo(0, on_map);
  copy.distance_window_ =
      cv::Rect(mask_rect.x - kMaskedWindowMarginPx, mask_rect.y - kMaskedWindowMarginPx,
               mask_rect.width + 2 * kMaskedWindowMarginPx,
               mask_rect.height + 2 * kMaskedWindowMarginPx) &
      map_rect;
  if (std::find(left_out->begin(), left_out->end(), 0) == left_out->end()) {
    copy.nearest_.reset();  // every edge left out
    copy.left_out_.reset();
    copy.distance_ = cv::Mat(copy.distance_window_.size(), CV_32F, cv::Scalar(max_distance_));
    return copy;
  }
  copy.left_out_ = std::move(left_out);
  copy.distance_ = cv::Mat(copy.distance_window_.size(), CV_32F, cv::Scalar(kNotWorkedOut));
  return copy;
}

int EdgeMap::NearestEdges::find(const Eigen::Vector2d& pixel, double max_distance,
                                const std::uint8_t* left_out) const {
  const int cu = std::clamp(static_cast<int>(pixel.x()) / kCellPx, 0, cols - 1);
  const int cv = std::clamp(static_cast<int>(pixel.y()) / kCellPx, 0, rows - 1);
  const int max_ring = std::max(std::max(cu, cols - 1 - cu), std::max(cv, rows - 1 - cv));
  double best = std::numeric_limits<double>::infinity();
  int best_index = -1;
  const auto search_cell = [&](int u, int v) {
    if (u < 0 || v < 0 || u >= cols || v >= rows) return;
    const int c = v * cols + u;
    for (int k = cell_begin[c]; k < cell_begin[c + 1]; ++k) {
      if (left_out != nullptr && left_out[k] != 0) continue;
      const double squared = (points[k] - pixel).squaredNorm();
      if (squared < best) {
        best = squared;
        best_index = k;
      }
    }
  };
  for (int ring = 0; ring <= max_ring; ++ring) {
    if (ring == 0) {
      search_cell(cu, cv);
    } else {
      for (int u = cu - ring; u <= cu + ring; ++u) {
        search_cell(u, cv - ring);
        search_cell(u, cv + ring);
      }
      for (int v = cv - ring + 1; v <= cv + ring - 1; ++v) {
        search_cell(cu - ring, v);
        search_cell(cu + ring, v);
      }
    }
    // Every point in a cell of a later ring is at least ring x kCellPx away.
    const double reach = static_cast<double>(ring) * kCellPx;
    if (best <= reach * reach || reach >= max_distance) break;
  }
  return best_index;
}

float EdgeMap::keptDistance(int u, int v) const {
  const int wu = u - distance_window_.x;
  const int wv = v - distance_window_.y;
  if (wu < 0 || wv < 0 || wu >= distance_window_.width || wv >= distance_window_.height) {
    return kNotWorkedOut;
  }
  return distance_.at<float>(wv, wu);
}

float EdgeMap::distanceAt(int u, int v) const {
  const float kept = keptDistance(u, v);
  return kept != kNotWorkedOut ? kept : computeDistance(u, v);
}

float EdgeMap::computeDistance(int u, int v, int k) const {
  if (!nearest_) return static_cast<float>(max_distance_);
  const NearestEdges& nearest = *nearest_;
  const Eigen::Vector2d pixel(u, v);
  // Unbounded search: the sign of a pixel far inside a bright region comes from its nearest
  // edge however far, so that the truncated distance has no jump from -max to +max.
  if (k < 0) k = nearest.find(pixel, std::numeric_limits<double>::infinity(), leftOut());
  const Eigen::Vector2d offset = pixel - nearest.points[k];
  const double along_normal = nearest.normals[k].dot(offset);
  const double squared = offset.squaredNorm();
  const double band = nearest.band;
  // Tangent-line distance near the edge, point distance far from it, blended between.
  double value = max_distance_;
  if (squared <= band * band) {
    value = std::abs(along_normal);
  } else if (squared < max_distance_ * max_distance_) {
    const double to_point = std::sqrt(squared);
    const double w = std::min((to_point - band) / band, 1.0);
    value =
        w == 1.0
            ? to_point
            : std::sqrt(along_normal * along_normal + w * (squared - along_normal * along_normal));
  }
  const float out = static_cast<float>(along_normal < 0.0 ? -value : value);
  // distance_ shares its pixels with copies of this map; each is written once, always alike.
  if (distance_window_.contains(cv::Point(u, v))) {
    const_cast<cv::Mat&>(distance_).at<float>(v - distance_window_.y, u - distance_window_.x) = out;
  }
  return out;
}

EdgeMap EdgeMap::unshared() const {
  EdgeMap copy = *this;
  copy.distance_ = distance_.clone();
  return copy;
}

cv::Mat EdgeMap::unsignedDistance(double truncation_px) const {
  const double limit = std::min(truncation_px, max_distance_);  // what far pixels read
  cv::Mat result(edges_.size(), CV_32F, cv::Scalar(limit));
  if (!nearest_) return result;
  // Within twice the line band of its nearest point a pixel's distance may be less than the
  // point's (the tangent line is nearer); beyond both, it is at least `limit`.
  const double reach = std::max(limit, 2.0 * nearest_->band);
  for (int v = 0; v < result.rows; ++v) {
    float* row = result.ptr<float>(v);
    for (int u = 0; u < result.cols; ++u) {
      const float known = keptDistance(u, v);
      if (known != kNotWorkedOut) {
        row[u] = static_cast<float>(std::min<double>(std::abs(known), truncation_px));
        continue;
      }
      // A pixel that far from every edge needs no exact nearest: a bounded search.
      const Eigen::Vector2d pixel(u, v);
      const int k = nearest_->find(pixel, reach, leftOut());
      if (k < 0 || (nearest_->points[k] - pixel).squaredNorm() >= reach * reach) continue;
      row[u] =
          static_cast<float>(std::min<double>(std::abs(computeDistance(u, v, k)), truncation_px));
    }
  }
  return result;
}

bool EdgeMap::sample(double u, double v, double* distance, double* du, double* dv) const {
  if (!(u >= 0.0 && v >= 0.0 && u <= edges_.cols - 1.0 && v <= edges_.rows - 1.0)) {
    *distance = max_distance_;
    *du = 0.0;
    *dv = 0.0;
    return false;
  }
  const int u0 = std::min(static_cast<int>(u), edges_.cols - 2);
  const int v0 = std::min(static_cast<int>(v), edges_.rows - 2);
  const double a = u - u0;
  const double b = v - v0;
  double f00, f10, f01, f11;
  const int wu = u0 - distance_window_.x;
  const int wv = v0 - distance_window_.y;
  if (wu >= 0 && wv >= 0 && wu + 1 < distance_window_.width && wv + 1 < distance_window_.height) {
    const float* r0 = distance_.ptr<float>(wv) + wu;
    const float* r1 = distance_.ptr<float>(wv + 1) + wu;
    const auto at = [&](const float* row, int column, int uu, int vv) -> double {
      return row[column] == kNotWorkedOut ? computeDistance(uu, vv) : row[column];
    };
    f00 = at(r0, 0, u0, v0);
    f10 = at(r0, 1, u0 + 1, v0);
    f01 = at(r1, 0, u0, v0 + 1);
    f11 = at(r1, 1, u0 + 1, v0 + 1);
  } else {
    f00 = distanceAt(u0, v0);
    f10 = distanceAt(u0 + 1, v0);
    f01 = distanceAt(u0, v0 + 1);
    f11 = distanceAt(u0 + 1, v0 + 1);
  }
  // Bilinear interpolation and its exact derivative, so that solver Jacobians are consistent
  // with the values (a smoothed gradient underestimates the slope next to an edge, where the
  // distance has its V-shaped minimum).
  *distance = (1 - b) * ((1 - a) * f00 + a * f10) + b * ((1 - a) * f01 + a * f11);
  *du = (1 - b) * (f10 - f00) + b * (f11 - f01);
  *dv = (1 - a) * (f01 - f00) + a * (f11 - f10);
  return true;
}

}  // namespace imaging
}  // namespace fluoro_tracker
