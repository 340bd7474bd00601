#include "fluoro_tracker/imaging/detector_model.h"

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

#include <opencv2/imgproc.hpp>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace imaging {

void DetectorSettings::validate() const {
  if (bit_depth != 8 && bit_depth != 16) {
    throw InputError("detector bit_depth must be 8 or 16, got " + std::to_string(bit_depth));
  }
  if (!(window_max_attenuation > window_min_attenuation)) {
    throw InputError("detector window_max_attenuation must exceed window_min_attenuation");
  }
  if (!(blur_sigma_px >= 0.0) || !std::isfinite(blur_sigma_px)) {
    throw InputError("detector blur_sigma_px must be finite and >= 0");
  }
  if (!std::isfinite(photons_per_pixel))
    throw InputError("detector photons_per_pixel must be finite");
}

cv::Mat formRadiograph(const cv::Mat& line_integral, const DetectorSettings& s,
                       std::mt19937_64* rng) {
  s.validate();
  CV_Assert(line_integral.type() == CV_64F);
  const int rows = line_integral.rows;
  const int cols = line_integral.cols;

  // Single precision from here on: the display has at most 16 bits.
  cv::Mat attenuation;
  line_integral.convertTo(attenuation, CV_32F);
  cv::max(attenuation, 0.0, attenuation);  // physically >= 0; drops round-off below zero
  cv::Mat open_field;                      // 255 where the collimator lets the beam through
  if (s.collimator_radius_fraction > 0.0) {
    open_field = cv::Mat::zeros(rows, cols, CV_8U);
    const double radius = s.collimator_radius_fraction * 0.5 * std::min(rows, cols);
    constexpr int kShift = 4;  // sub-pixel circle centre for even image sizes
    cv::circle(open_field,
               cv::Point(static_cast<int>(std::lround(0.5 * (cols - 1) * (1 << kShift))),
                         static_cast<int>(std::lround(0.5 * (rows - 1) * (1 << kShift)))),
               static_cast<int>(std::lround(radius * (1 << kShift))), cv::Scalar(255), cv::FILLED,
               cv::LINE_8, kShift);
    cv::add(attenuation, cv::Scalar(s.collimator_attenuation), attenuation, ~open_field);
  }

  // Primary transmission, plus scatter, blurred by the detector's point spread before quanta
  // are counted. Scatter has no fine detail: it is computed at 1/8 resolution.
  cv::Mat transmitted;
  cv::exp(-attenuation, transmitted);
  if (s.scatter_strength > 0.0) {
    constexpr double kFactor = 0.125;
    cv::Mat source = attenuation.mul(transmitted);
    cv::Mat small;
    cv::resize(source, small, cv::Size(), kFactor, kFactor, cv::INTER_AREA);
    const double sigma = s.scatter_sigma_mm / s.pixel_spacing_mm * kFactor;
    cv::GaussianBlur(small, small, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
    cv::Mat scatter;
    cv::resize(small, scatter, transmitted.size(), 0, 0, cv::INTER_LINEAR);
    if (!open_field.empty()) scatter.setTo(0.0f, ~open_field);  // the shutter blanks it too
    transmitted += s.scatter_strength * scatter;
  }
  if (s.blur_sigma_px > 0.0) {
    cv::GaussianBlur(transmitted, transmitted, cv::Size(0, 0), s.blur_sigma_px, s.blur_sigma_px,
                     cv::BORDER_REPLICATE);
  }

  const bool noisy = s.photons_per_pixel > 0.0;
  if (noisy) {
    // Poisson counts in the Gaussian approximation (the counts that carry contrast are >> 1):
    // t' = t + sqrt(t / N0) * n, n ~ N(0, 1).
    cv::Mat sigma;
    cv::sqrt(transmitted * (1.0 / s.photons_per_pixel), sigma);
    cv::Mat noise(rows, cols, CV_32F);
    cv::RNG cv_rng((*rng)());
    cv_rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.0);
    transmitted += sigma.mul(noise);
  }
  // A detector cannot tell apart less than about one quantum.
  const double floor = noisy ? 0.5 / s.photons_per_pixel : 1e-12;
  cv::max(transmitted, floor, transmitted);
  cv::Mat measured;
  cv::log(transmitted, measured);  // = -attenuation as measured

  // Window: measured attenuation window_min -> bright, window_max -> dark (or the reverse).
  const double max_level = s.bit_depth == 8 ? 255.0 : 65535.0;
  const double window = s.window_max_attenuation - s.window_min_attenuation;
  double scale = max_level / window;  // grey = max_level * (1 - (a - a_min) / window)
  double offset = max_level * (1.0 + s.window_min_attenuation / window);
  if (s.implants_bright) {
    scale = -scale;
    offset = max_level - offset;
  }
  // measured = -a, so grey = offset + scale * measured; convertTo rounds and saturates.
  cv::Mat out;
  measured.convertTo(out, s.bit_depth == 8 ? CV_8U : CV_16U, scale, offset);
  return out;
}

}  // namespace imaging
}  // namespace fluoro_tracker
