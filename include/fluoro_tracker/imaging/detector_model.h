#pragma once

#include <cstdint>
#include <random>

#include <opencv2/core.hpp>

namespace fluoro_tracker {
namespace imaging {

// How an image intensifier / flat panel turns the attenuation line integral into a displayed
// frame: Beer–Lambert transmission, detector blur, quantum (Poisson) noise, log display with a
// window, polarity and bit depth, and an optional circular collimator.
struct DetectorSettings {
  double photons_per_pixel = 4000.0;    // unattenuated quanta per pixel; <= 0 turns noise off
  double blur_sigma_px = 0.8;           // Gaussian detector blur; 0 turns blur off
  double window_max_attenuation = 7.0;  // line integral shown as the darkest grey
  double window_min_attenuation = 0.0;  // line integral shown as the brightest grey
  bool implants_bright = false;         // false: attenuating objects dark (usual fluoroscopy)
  int bit_depth = 8;                    // 8 (CV_8U) or 16 (CV_16U)
  // Circular collimator radius as a fraction of half the shorter image side; outside it the
  // beam is blocked. <= 0: no collimator.
  double collimator_radius_fraction = 0.0;
  double collimator_attenuation = 12.0;  // line integral added outside the collimator

  // Throws InputError naming the field for an invalid setting.
  void validate() const;
};

// Forms a displayed frame from a line-integral image (CV_64F). The random generator drives
// the quantum noise, so a fixed seed gives the same frame.
cv::Mat formRadiograph(const cv::Mat& line_integral, const DetectorSettings& settings,
                       std::mt19937_64* rng);

}  // namespace imaging
}  // namespace fluoro_tracker
