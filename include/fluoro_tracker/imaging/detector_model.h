#pragma once

#include <cstdint>
#include <random>

#include <opencv2/core.hpp>

namespace fluoro_tracker {
namespace imaging {

// How an image intensifier / flat panel turns the attenuation line integral into a displayed
// frame: Beer–Lambert transmission, X-ray scatter, detector blur, quantum (Poisson) noise, log
// display with a window, polarity and bit depth, and an optional circular collimator.
//
// Scatter, single-scatter approximation: a ray with line integral A and transmission t = e^-A
// scatters in proportion to A·t (nothing in open air, nothing behind opaque metal), and the
// scatter reaches the detector spread by a wide Gaussian. In uniform tissue the
// scatter-to-primary ratio is then about scatter_strength × A (0.5 for a knee at A ~ 2.5 with
// the default). Scatter is why metal looks dark grey rather than black in real fluoroscopy, and
// it moves the displayed metal edge back toward the true silhouette.
struct DetectorSettings {
  double photons_per_pixel = 4000.0;    // unattenuated quanta per pixel; <= 0 turns noise off
  double blur_sigma_px = 0.8;           // Gaussian detector blur; 0 turns blur off
  double scatter_strength = 0.2;        // see above; 0 turns scatter off
  double scatter_sigma_mm = 25.0;       // width of the scatter kernel at the detector
  double pixel_spacing_mm = 0.38;       // detector pixel pitch (converts the scatter kernel)
  double window_max_attenuation = 4.0;  // measured line integral shown as the darkest grey
  double window_min_attenuation = 0.0;  // measured line integral shown as the brightest grey
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
