#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace fluoro_tracker {
namespace imaging {

// Where a display window clips a region's grey, and so hides or moves an outline's edge.
//
// A fluoroscope's display maps the logarithm of the detected intensity to grey and clips it at
// the window's ends. Metal behind a window that ends early is a flat plateau at the darkest grey
// (the brightest when shown bright). The detector's blur acts on intensity, before the
// logarithm, so where the tissue beside clipped metal lies within a few tenths of the window's
// end too, the displayed edge sits at the point where the blurred intensity crosses the clip:
// up to 1.5-2 px outward, by an amount that follows the tissue's thickness along the outline.
// Where the tissue is clipped as well there is no edge at all, only the clipped area's own
// border farther out. One edge offset per bone cannot follow either, and the rest goes into the
// depth (README "Tracking quality": the femoral component 11 mm along the beam from its true
// pose). This class tells where that happens, so that the edge map can leave those edges out
// and the registration the contour samples whose edge the image cannot show.
//
// A plateau is where a pixel and most of its 3 x 3 neighbourhood sit at an end of the region's grey
// (clipped metal, and tissue clipped but for its noise; a noisy implant's interior that only
// touches the end at scattered pixels is not one). Plateaus that reach the region's border are
// the field's (a collimator's black, open air shown white) and are left alone: an implant lies
// inside the region, which the bones' projections and a margin define. Near an end: the
// neighbourhood's mean grey is within the margin of it.
class ClippedGrey {
 public:
  ClippedGrey() = default;
  // `region`: the raw grey levels (CV_32F) at the edge map's scale. `range`: the grey levels
  // the edge map's window spans; `margin_fraction` of it is "near" an end. Empty (nothing is
  // beside clipped grey) unless an end holds at least 1 % of the region's pixels.
  ClippedGrey(const cv::Mat& region, double range, double margin_fraction);

  bool empty() const { return region_.empty(); }

  // Whether a point of an outline lies beside clipped grey: the pixel at `clipped_side` on a
  // plateau and the one at `other_side` on it or near the same end.
  bool beside(const Eigen::Vector2d& clipped_side, const Eigen::Vector2d& other_side) const;

  // Whether the grey `reach` pixels each way from `pixel`, along both axes, lies near one end
  // whose clipped plateau the region holds: in a display that clips that end, no edge there can
  // stand out of the noise, whatever lies along the beam.
  bool amidNearEnd(const Eigen::Vector2d& pixel, double reach) const;

 private:
  enum class End { kNone, kLow, kHigh };

  // The end whose plateau the pixel nearest `pixel` lies on; kNone off the region.
  End plateauAt(const Eigen::Vector2d& pixel) const;
  // Whether the pixel nearest `pixel` is on or near `end`.
  bool nearEnd(const Eigen::Vector2d& pixel, End end) const;

  cv::Mat region_;     // CV_32F
  double low_ = 0.0;   // the region's darkest grey, when it is a plateau candidate
  double high_ = 0.0;  // ... and brightest
  bool low_candidate_ = false;
  bool high_candidate_ = false;
  double margin_ = 0.0;
  // Per block of kBlockPx x kBlockPx pixels: non-zero on or beside a plateau that reaches the
  // region's border (CV_8U; one mask per end).
  cv::Mat low_field_;
  cv::Mat high_field_;
  static constexpr int kBlockPx = 4;
};

}  // namespace imaging
}  // namespace fluoro_tracker
