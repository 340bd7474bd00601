#pragma once

#include <string>

#include <opencv2/core.hpp>

namespace fluoro_tracker {
namespace imaging {

// Whether a frame shows anything at all. With the beam off, a failed exposure or a detector
// read-out fault a frame carries one grey level or pixel noise only. Registering it, and above all
// searching it for the bones (every thresholded noise speck is a candidate region: 20-30 s per
// frame), only costs time, and a live node drops the frames that arrive meanwhile.
//
// The measure: the frame reduced to `working_size_px` on its longer side by area averaging (as
// the search finds its regions), the variance of the differences between neighbouring pixels
// over twice the variance of the pixels. Noise independent from pixel to pixel gives 1. A
// radiograph's anatomy and implants vary over many pixels, so its neighbours differ far less
// than its grey levels spread: 0.007-0.011 over the simulator's robustness variants and the real
// Kneel frames (README "Tracking quality"). NaN for a frame of one grey level. Throws
// InputError for an empty image or one that is not single-channel.
double neighbourDifferenceRatio(const cv::Mat& image, int working_size_px = 256);

// What a frame that shows nothing shows ("one grey level", "pixel noise only (...)") when its
// neighbourDifferenceRatio is NaN or at least `max_ratio`; empty when it shows structure, or when
// max_ratio is 0 (the test off).
std::string featurelessFrame(const cv::Mat& image, double max_ratio, int working_size_px = 256);

}  // namespace imaging
}  // namespace fluoro_tracker
