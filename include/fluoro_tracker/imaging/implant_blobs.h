#pragma once

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace fluoro_tracker {
namespace imaging {

struct ImplantBlobSettings {
  int working_size_px = 256;  // the frame is reduced so that its longer side has this many pixels
  // Grey-level window from these percentiles of the frame; thresholds are fractions of it. If
  // the frame has flat bands at the implants' end of the grey scale that reach its border (a
  // collimator, shutters, a letterbox: as attenuating as metal), the same fractions are also
  // taken of a window whose implants' end comes from the exposed field without them, grown by
  // field_edge_px working pixels over their soft edge (not if that would keep less than
  // min_field_fraction of the frame).
  double window_low_percentile = 1.0;
  double window_high_percentile = 99.0;
  int field_edge_px = 3;
  double min_field_fraction = 0.1;
  // Candidate thresholds, as fractions of the window from the dark end (implants darker than
  // their surroundings) and, mirrored, from the bright end (either polarity).
  std::vector<double> threshold_fractions = {0.08, 0.16, 0.25, 0.35, 0.45};
  double min_area_fraction = 0.001;  // of the frame; smaller regions are noise or markers
  double max_area_fraction = 0.2;    // larger ones are background
  // Strips at most strip_width_px wide (working pixels; <= 2: none cut) and at least
  // min_strip_length_fraction of the frame long (a rod or wire across an implant) are cut out
  // of the thresholded regions, followed along their lines up to and across the implants.
  int strip_width_px = 8;
  double min_strip_length_fraction = 0.3;
  // A region that an opening with a disc this wide (working pixels; < 3: none) splits into two
  // or more parts of at least min_area_fraction also offers those parts (ImplantBlob::neck_part).
  int neck_split_px = 5;
};

// A connected region of extreme grey level that does not touch the frame's border (the
// collimator and everything outside the field of view do): a candidate implant silhouette.
struct ImplantBlob {
  cv::Mat mask;              // CV_8U, 255 inside; covers `box` at `scale` of the frame
  cv::Rect box;              // in the mask's pixels (frame pixels x scale)
  double scale = 1.0;        // mask pixels per frame pixel
  Eigen::Vector2d centroid;  // frame pixels
  double area_px = 0.0;      // frame pixels
  bool dark = true;          // darker than its surroundings
  bool neck_part = false;    // a part of a region split at a narrow neck (neck_split_px)
};

// Candidate implant regions of one frame (8- or 16-bit grey), from several thresholds in
// both polarities; near-duplicates (the same region at two thresholds) are kept once. Metal
// implants are the most attenuating objects in a fluoroscopic image, but their grey level
// varies with thickness, exposure and display, so no single threshold is trusted: the shape
// matching that follows decides which region is which bone, if any. Long straight strips (a rod
// or wire across an implant, see ImplantBlobSettings) are cut out of the regions first. Throws
// InputError for an empty image or an unsupported type.
std::vector<ImplantBlob> findImplantBlobs(const cv::Mat& image,
                                          const ImplantBlobSettings& settings = {});

}  // namespace imaging
}  // namespace fluoro_tracker
