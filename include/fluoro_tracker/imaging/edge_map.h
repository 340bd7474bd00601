#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "fluoro_tracker/geometry/xray_camera.h"
#include "fluoro_tracker/imaging/clipped_grey.h"

namespace fluoro_tracker {
namespace imaging {

struct EdgeMapSettings {
  // Grey-level window from these percentiles of the region (robust to collimator borders and
  // saturated metal); the edge detector is polarity-free, so implants may be dark or bright.
  double window_low_percentile = 1.0;
  double window_high_percentile = 99.0;
  // Contrast-limited adaptive equalisation (8 x 8 tiles over the region) before edges: brings
  // out an implant's edges where the global window leaves them faint, e.g. where the tibial
  // tray overlaps the femoral component in flexion, or under low dose, scatter or a coarse
  // detector. Measured (scripts/robustness_benchmark.sh variants, 8 simulated trials tracked
  // from frame 0): 334 -> 416 of 420 frames within the criteria at clip limit 1.3; on the real
  // Kneel frames (benchmark --kneel --kneel-starts 20) 50/60 starts against 49/60 without. A
  // higher limit (2.0) amplified the real frames' clutter: 47/60.
  bool clahe = true;
  double clahe_clip_limit = 1.3;
  double blur_sigma_px = 1.0;  // Gaussian smoothing before Canny, at the map's scale
  double canny_low = 0.0;      // Canny thresholds on the 8-bit windowed image; 0: automatic
  double canny_high = 0.0;
  // Automatic thresholds: high = this fraction of the 99.5th percentile of the gradient
  // magnitude, low = high * auto_low_ratio.
  double auto_high_fraction = 0.3;
  double auto_low_ratio = 0.4;
  // The automatic thresholds leave out large saturated areas that reach the region's border
  // (a collimator's black, or white shown inverted; open air) and their borders: a full-range
  // step that, in a tightly collimated field, runs through the region around the implants and
  // would set thresholds that drop a faint implant's outline (a field collimated to half the
  // image, scripts/robustness_benchmark.sh narrow_collimation: 52/60 tracked frames without).
  bool thresholds_skip_saturated_borders = true;
  // An edge chain is kept only if somewhere along it the gradient stands this many standard
  // deviations of the local noise above zero, and only its pixels above the low ratio of it:
  // in a low-dose frame of a weakly attenuating implant (titanium) the few quanta through the
  // metal make its interior noisy, local equalisation stretches that noise, and its Canny
  // edges crowd the outline from inside. The noise is each 16-pixel tile's 30th percentile of
  // the gradient magnitude (robust to the edges crossing it), as for Gaussian noise. 0: off.
  double min_edge_significance = 3.0;
  double edge_significance_low_ratio = 0.6;
  // Outline beside grey the display window clips (see ClippedGrey): edges with one side on a
  // plateau at an end of the region's grey and the other within this fraction of the window's
  // range of the same end are left out, and besideClippedGrey() tells the registration which
  // contour samples lie where the image cannot show their edge. 0: off. Chosen from 0.1 / 0.15
  // / 0.2 on the saturated-window and titanium robustness trials (README "Tracking quality"):
  // 0.15 gained as much on the first but left out more of bright titanium's outline.
  double clipped_grey_margin = 0.1;
  double max_distance_px = 40.0;  // distances are truncated here (and their gradient is 0)
  // Within this many pixels of an edge the distance is to the edge's sub-pixel tangent line;
  // beyond twice this, to the nearest edge pixel; blended in between.
  double line_distance_band_px = 2.0;

  void validate() const;
};

// Edge features of one view of one frame, in a region of interest and at one scale: Canny edges,
// each refined to sub-pixel position along its gradient (a parabola through the gradient
// magnitude across the edge, Devernay 1995), and a signed distance from every pixel to the
// nearest edge: near an edge, the distance to its tangent line through the sub-pixel point,
// positive on the edge's brighter side. Pixel-accurate edges and an unsigned distance would
// bias a silhouette fit by up to half a pixel, which for a thin implant seen edge-on becomes
// millimetres along the beam; a signed distance is also linear across the edge, so bilinear
// sampling keeps its zero where the edge is and the residual is smooth through it.
// Pixel coordinates are those of camera(), the view's camera cropped to the region and scaled.
//
// The signed distance of a pixel is worked out when it is first sampled, from the nearest
// sub-pixel edge point: a registration samples a band around its contours, 2-3 % of the region
// (the whole region by a labelled distance transform was 13 % of an image-only registration's
// instructions). So an EdgeMap, and its copies, which share the pixels worked out, must not be
// used by two threads at once.
class EdgeMap {
 public:
  // `image`: the full frame (8- or 16-bit grey). `roi`: region of the full frame (clipped to
  // it; empty = whole frame). `scale`: e.g. 0.5 for half resolution. Throws InputError for an
  // empty image, one whose size differs from the camera's, or an unsupported type.
  EdgeMap(const cv::Mat& image, const geometry::XrayCamera& camera, const EdgeMapSettings& settings,
          cv::Rect roi = cv::Rect(), double scale = 1.0);

  // A copy whose signed distances are its own: the pixels worked out so far come along, those
  // worked out later are not shared with this map or its other copies, so it may be used on
  // another thread (the edges and their points, never changed, are still shared).
  EdgeMap unshared() const;

  // A copy without the edges whose sub-pixel points fall on `mask` (CV_8U; non-zero: leave out),
  // whose top-left pixel is the map's pixel `origin` (the part of it outside the map is
  // ignored), e.g. the edges deep inside a bone's own projected silhouette
  // (RegistrationSettings::inner_edge_margin_px). The copy has signed distances of its own, and
  // keeps those it works out only within kMaskedWindowMarginPx of the mask: it is made to be
  // sampled near the mask, and a map-sized store, filled for each bone and outer iteration,
  // cost more than the registration's own use of it. Elsewhere its distances are right, only
  // worked out again at each sample. Throws InputError for a mask that is not CV_8U.
  EdgeMap withoutEdgesIn(const cv::Mat& mask, cv::Point origin = cv::Point()) const;

  // Whether an outline at `pixel` (map pixels) whose outward normal is `outward` lies where the
  // image cannot show its edge: its inside on a plateau of clipped grey and its outside at or
  // within EdgeMapSettings::clipped_grey_margin of the same end. Always false when the setting
  // is 0 or the region has no clipped plateau.
  bool besideClippedGrey(const Eigen::Vector2d& pixel, const Eigen::Vector2d& outward) const;
  // Whether the image around `pixel` (map pixels; 3 px each way) lies within
  // EdgeMapSettings::clipped_grey_margin of an end of the region's grey that a clipped plateau
  // holds: dark on dark (or bright on bright), where an outline cannot show. Always false when
  // the setting is 0 or the region has no clipped plateau.
  bool amidClippedGrey(const Eigen::Vector2d& pixel) const;

  const geometry::XrayCamera& camera() const { return camera_; }
  const cv::Mat& edges() const { return edges_; }  // CV_8U, 255 on edges
  // |signed distance| at every pixel, truncated at `truncation_px` (chamfer matching), CV_32F.
  cv::Mat unsignedDistance(double truncation_px) const;
  const cv::Mat& grey() const { return grey_; }  // CV_8U windowed region
  double scale() const { return scale_; }
  cv::Rect roi() const { return roi_; }

  // Signed distance to the nearest edge at a sub-pixel position (positive on its brighter
  // side), and its gradient. Outside the map returns max_distance_px with zero gradient and
  // false.
  bool sample(double u, double v, double* distance, double* du, double* dv) const;

  // Sub-pixel position of the edge at edge pixel (u, v) (map pixels).
  Eigen::Vector2d edgePoint(int u, int v) const {
    const cv::Vec2f& p = edge_points_.at<cv::Vec2f>(v, u);
    return Eigen::Vector2d(p[0], p[1]);
  }

 private:
  static constexpr int kCellPx = 4;  // of the grid the edge points are bucketed in
  // How far around its mask a copy from withoutEdgesIn keeps the distances it works out.
  static constexpr int kMaskedWindowMarginPx = 16;
  // distance_'s value where not yet worked out: finite, unlike NaN, so that builds with
  // -ffinite-math-only still see it (distances lie within +-max_distance_px).
  static constexpr float kNotWorkedOut = std::numeric_limits<float>::max();

  // What the signed distance of any pixel is worked out from: the sub-pixel edge points
  // bucketed by grid cell, searched ring by ring around the pixel.
  struct NearestEdges {
    int cols = 0;                          // grid cells across
    int rows = 0;                          // ... and down
    std::vector<int> cell_begin;           // cell c's points: [cell_begin[c], cell_begin[c + 1])
    std::vector<Eigen::Vector2d> points;   // sub-pixel edge points, by cell
    std::vector<Eigen::Vector2d> normals;  // unit, toward the brighter side
    double band = 0.0;                     // line_distance_band_px

    // Index of the point nearest `pixel`; -1 when none lies within max_distance (some farther
    // ones may be returned). `left_out`: null, or a flag per point (non-zero: not a candidate).
    int find(const Eigen::Vector2d& pixel, double max_distance, const std::uint8_t* left_out) const;
  };

  // The points bucketed by grid cell for a map of `size`.
  static std::shared_ptr<const NearestEdges> bucketEdgePoints(
      const std::vector<Eigen::Vector2d>& points, const std::vector<Eigen::Vector2d>& normals,
      double band, cv::Size size);
  // `edge_pixels`: edges_'s non-zero pixels in row-major order.
  void findNearestEdges(const cv::Mat& gx, const cv::Mat& gy, const cv::Mat& magnitude,
                        const std::vector<cv::Point>& edge_pixels, double band);
  // The distance kept in distance_ at pixel (u, v) of the map; kNotWorkedOut if none.
  float keptDistance(int u, int v) const;
  // The signed distance at pixel (u, v) of the map, from distance_ when worked out there, else
  // worked out (and kept when (u, v) lies in distance_window_).
  float distanceAt(int u, int v) const;
  // Works out the signed distance at pixel (u, v); `nearest_point`: the index of its nearest
  // edge point when already found, else -1.
  float computeDistance(int u, int v, int nearest_point = -1) const;
  const std::uint8_t* leftOut() const { return left_out_ ? left_out_->data() : nullptr; }

  geometry::XrayCamera camera_;
  cv::Rect roi_;
  double scale_ = 1.0;
  double max_distance_ = 0.0;
  cv::Mat grey_;
  cv::Mat edges_;
  // CV_32F over distance_window_ (the whole map, but for a copy from withoutEdgesIn);
  // kNotWorkedOut where not yet.
  cv::Mat distance_;
  cv::Rect distance_window_;
  std::shared_ptr<const NearestEdges> nearest_;  // null: no edges (every distance is max)
  // Null, or a flag per nearest_ point: left out of this map (withoutEdgesIn). The points are
  // flagged rather than bucketed again, which cost as much as the rest of the copy.
  std::shared_ptr<const std::vector<std::uint8_t>> left_out_;
  cv::Mat edge_points_;       // CV_32FC2: sub-pixel edge position at each edge pixel
  ClippedGrey clipped_grey_;  // empty unless clipped_grey_margin > 0 and an end is a plateau
};

}  // namespace imaging
}  // namespace fluoro_tracker
