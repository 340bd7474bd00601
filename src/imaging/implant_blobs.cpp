#include "fluoro_tracker/imaging/implant_blobs.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace imaging {
namespace {

// Grey levels this close, as a fraction of the window, count as one level: a band this near
// the window's end is flat at that end, and a field's end this near the frame's adds no
// thresholds of its own.
constexpr float kSameLevelFraction = 0.02f;

// Value below which `fraction` of a CV_32F image's pixels lie, of those where `mask` is set.
float quantile(const cv::Mat& image, const cv::Mat& mask, double fraction) {
  std::vector<float> v;
  v.reserve(image.total());
  for (int y = 0; y < image.rows; ++y) {
    const float* row = image.ptr<float>(y);
    const uchar* in = mask.ptr<uchar>(y);
    for (int x = 0; x < image.cols; ++x) {
      if (in[x]) v.push_back(row[x]);
    }
  }
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(fraction * (v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// The bounding box of connected component `label` from cv::connectedComponentsWithStats.
cv::Rect componentBox(const cv::Mat& stats, int label) {
  return cv::Rect(stats.at<int>(label, cv::CC_STAT_LEFT), stats.at<int>(label, cv::CC_STAT_TOP),
                  stats.at<int>(label, cv::CC_STAT_WIDTH),
                  stats.at<int>(label, cv::CC_STAT_HEIGHT));
}

bool touchesBorder(const cv::Rect& box, const cv::Size& size) {
  return box.x == 0 || box.y == 0 || box.br().x == size.width || box.br().y == size.height;
}

// The regions of `mask` (CV_8U) that touch its border, as a mask.
cv::Mat borderRegions(const cv::Mat& mask) {
  cv::Mat labels;
  cv::Mat stats;
  cv::Mat centroids;
  const int count = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  cv::Mat touching = cv::Mat::zeros(mask.size(), CV_8U);
  for (int label = 1; label < count; ++label) {
    if (touchesBorder(componentBox(stats, label), mask.size()))
      touching.setTo(255, labels == label);
  }
  return touching;
}

bool isDuplicate(const ImplantBlob& blob, const std::vector<ImplantBlob>& kept) {
  for (const auto& other : kept) {
    const double area_ratio = blob.area_px / other.area_px;
    if (other.dark == blob.dark && other.neck_part == blob.neck_part &&
        (blob.centroid - other.centroid).norm() < 3.0 / blob.scale && area_ratio > 0.9 &&
        area_ratio < 1.1) {
      return true;
    }
  }
  return false;
}

// The implants' end of a working image's grey window, `dark` or bright: a percentile of the
// exposed field, which leaves out the parts of the frame that lie flat at that end of the grey
// scale and reach its border, grown by a few pixels over their soft edge. Those are a
// collimator's or shutter's unexposed band, or a letterbox: fully attenuated, they lie at the
// same end as the metal (dark, or bright in an inverted display), while open field lies at the
// other. Their level would otherwise be the window's end, and every threshold a fixed fraction
// of the way from it rather than from the darkest (brightest) thing in the field: scatter's haze
// lifts the implants towards the tissue around them, and the thresholds, spread over a range
// the implants no longer use, then stepped over the narrow band of grey between an implant and
// the bone ends beside it (the search found neither component of a hazy small knee in extension
// at any threshold). Without such bands, or when they would leave too little of the frame, the
// percentile is the whole frame's, `whole_end`. Open field at the other end (air beside the
// leg, saturated) is left in: it is the window's far end either way.
float implantEndOfWindow(const cv::Mat& grey, const ImplantBlobSettings& settings, bool dark,
                         float whole_low, float whole_high) {
  const float whole_end = dark ? whole_low : whole_high;
  const float flat = kSameLevelFraction * (whole_high - whole_low);
  cv::Mat outside =
      borderRegions(dark ? cv::Mat(grey <= whole_low + flat) : cv::Mat(grey >= whole_high - flat));
  if (cv::countNonZero(outside) == 0) return whole_end;
  const int soft_edge = 2 * settings.field_edge_px + 1;
  cv::dilate(outside, outside,
             cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(soft_edge, soft_edge)));
  const cv::Mat field = ~outside;
  if (cv::countNonZero(field) < settings.min_field_fraction * static_cast<double>(grey.total())) {
    return whole_end;
  }
  return quantile(
      grey, field,
      (dark ? settings.window_low_percentile : settings.window_high_percentile) / 100.0);
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
  const cv::Mat whole(grey.size(), CV_8U, cv::Scalar(255));
  const float low = quantile(grey, whole, settings.window_low_percentile / 100.0);
  const float high = quantile(grey, whole, settings.window_high_percentile / 100.0);
  if (!(high > low)) return {};
  // The implants' end of a second window, from the exposed field: dark implants' thresholds
  // also run from the field's darkest level towards the frame's brightest, bright implants' from
  // the field's brightest towards the frame's darkest.
  const float dark_low = implantEndOfWindow(grey, settings, true, low, high);
  const float bright_high = implantEndOfWindow(grey, settings, false, low, high);
  const double total = static_cast<double>(grey.total());
  std::vector<ImplantBlob> blobs;
  // Adds one region unless a near-duplicate is in: `mask` covers `box` of the working image,
  // `centroid` and `area` as connectedComponentsWithStats gives them (working pixels).
  const auto add = [&](const cv::Mat& mask, const cv::Rect& box, const cv::Point2d& centroid,
                       double area, bool dark, bool neck_part) {
    ImplantBlob blob;
    blob.mask = mask;
    blob.box = box;
    blob.scale = scale;
    // Pixel centres: mask pixel (x, y) covers frame pixels around ((x + 0.5) / s - 0.5).
    blob.centroid =
        Eigen::Vector2d((centroid.x + 0.5) / scale - 0.5, (centroid.y + 0.5) / scale - 0.5);
    blob.area_px = area / (scale * scale);
    blob.dark = dark;
    blob.neck_part = neck_part;
    if (!isDuplicate(blob, blobs)) blobs.push_back(std::move(blob));
  };
  const int neck = std::max(settings.neck_split_px, 1);
  const cv::Mat neck_opening = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(neck, neck));
  // Adds the regions of `mask` that do not touch the border, are neither noise nor background
  // and do not overlap `excluded` (if not empty).
  const auto collect = [&](const cv::Mat& mask, bool dark, const cv::Mat& excluded) {
    cv::Mat labels;
    cv::Mat stats;
    cv::Mat centroids;
    const int count = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
    for (int label = 1; label < count; ++label) {
      const cv::Rect box = componentBox(stats, label);
      const double area = stats.at<int>(label, cv::CC_STAT_AREA);
      if (touchesBorder(box, grey.size()) || area < settings.min_area_fraction * total ||
          area > settings.max_area_fraction * total) {
        continue;
      }
      const cv::Mat region = labels(box) == label;
      if (!excluded.empty() && cv::countNonZero(region & excluded(box)) > 0) continue;
      add(region, box, centroids.at<cv::Point2d>(label), area, dark, false);
      if (settings.neck_split_px < 3) continue;
      // Two implants whose outlines touch (the components in extension, or joined by a rod's
      // stub) make one region through a narrow neck: its parts are candidates as well.
      cv::Mat parts;
      cv::morphologyEx(region, parts, cv::MORPH_OPEN, neck_opening);
      cv::Mat part_labels;
      cv::Mat part_stats;
      cv::Mat part_centroids;
      const int part_count = cv::connectedComponentsWithStats(parts, part_labels, part_stats,
                                                              part_centroids, 8, CV_32S);
      // Parts as small as a tray's stem count: the opening that cuts the neck also strips a
      // tray's plate seen edge-on, leaving the stem (a tenth of a region of both components).
      const double min_part_area = settings.min_area_fraction * total;
      int sizeable = 0;
      for (int p = 1; p < part_count; ++p) {
        if (part_stats.at<int>(p, cv::CC_STAT_AREA) >= min_part_area) ++sizeable;
      }
      if (sizeable < 2) continue;
      for (int p = 1; p < part_count; ++p) {
        if (part_stats.at<int>(p, cv::CC_STAT_AREA) < min_part_area) continue;
        const cv::Rect part_box = componentBox(part_stats, p);
        add(part_labels(part_box) == p, part_box + box.tl(),
            part_centroids.at<cv::Point2d>(p) + cv::Point2d(box.tl()),
            part_stats.at<int>(p, cv::CC_STAT_AREA), dark, true);
      }
    }
  };
  const cv::Mat opening = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(3, 3));
  const int thin = settings.strip_width_px + 1;
  const cv::Mat thin_opening = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(thin, thin));
  const double min_strip_length =
      settings.min_strip_length_fraction * std::max(grey.cols, grey.rows);
  // The thin parts of a region mask: what an opening narrower than an implant's body removes.
  const auto thinParts = [&](const cv::Mat& mask) {
    cv::Mat opened;
    cv::morphologyEx(mask, opened, cv::MORPH_OPEN, thin_opening);
    return cv::Mat(mask & ~opened);
  };
  // Draws onto `band` (CV_8U) the line of each strip among `thin_parts`. A rod, wire or cable as
  // dark as the metal that crosses an implant joins its region and spoils its shape, and the
  // size and place the region implies (the search's distance and position). Such a strip is
  // thinner than an implant's body and longer than any thin part of one (a tray's plate seen
  // edge-on); straight, it is followed along its line, widened by a pixel each side.
  const auto drawStripLines = [&](const cv::Mat& thin_parts, cv::Mat* band) {
    cv::Mat labels;
    cv::Mat stats;
    cv::Mat centroids;
    const int count =
        cv::connectedComponentsWithStats(thin_parts, labels, stats, centroids, 8, CV_32S);
    for (int label = 1; label < count; ++label) {
      const cv::Size extent = componentBox(stats, label).size();
      if (std::max(extent.width, extent.height) < min_strip_length) continue;
      // Straight, too: a curved thin part of an implant (a femoral component's rim seen from
      // the side) is long but not narrow along its own axis.
      std::vector<cv::Point> points;
      cv::findNonZero(labels == label, points);
      const cv::Size2f box = cv::minAreaRect(points).size;
      if (std::min(box.width, box.height) > settings.strip_width_px + 2.0) continue;
      // Its mean width: the box's is wider by the strip's ragged edges and any slight bend.
      const double width = points.size() / std::max(box.width, box.height);
      cv::Vec4f line;
      cv::fitLine(points, line, cv::DIST_L2, 0, 0.01, 0.01);
      const double reach = 2.0 * (thin_parts.cols + thin_parts.rows);
      const cv::Point2d centre(line[2], line[3]);
      const cv::Point2d direction(line[0], line[1]);
      const int thickness = static_cast<int>(std::ceil(width)) + 2;
      cv::line(*band, centre - reach * direction, centre + reach * direction, cv::Scalar(255),
               thickness);
    }
  };
  for (bool dark : {true, false}) {
    // A strip found at any threshold is cut, along its line, from the thin parts of every
    // threshold: at the wider ones a rod runs on past the implant and through the soft tissue,
    // while at a narrower one only its stubs inside the leg remain, as short as a tray's plate,
    // and where it meets an implant its stub joins the implant's own thin parts (the plate).
    // An implant's thin part under the band goes too, and a plate's end beyond the rod with it:
    // closing the cut again where the region lies on both sides of it kept the plate but also
    // joined the two components wherever the rod crosses the joint space between them (the
    // search with a rod found fewer frames: 27 -> 10 of 90), and closing only the pieces that
    // join no two sizeable regions still lost frames (21 of 90).
    std::vector<cv::Mat> masks;
    std::vector<cv::Mat> thin;
    cv::Mat band = cv::Mat::zeros(grey.size(), CV_8U);
    std::vector<double> levels;
    for (double fraction : settings.threshold_fractions) {
      levels.push_back(dark ? low + fraction * (high - low) : high - fraction * (high - low));
    }
    // The field's thresholds are added to the frame's, not put in their place. In their place
    // they found 143 of 160 default frames with no guess against the frame's 147 (`benchmark
    // --protocol search`, seeds 3 / 5 / 7 / 11; frames flipped both ways); both find 148.
    const float same_level = kSameLevelFraction * (high - low);
    const bool field_end = dark ? dark_low > low + same_level : bright_high < high - same_level;
    if (field_end) {
      for (double fraction : settings.threshold_fractions) {
        levels.push_back(dark ? dark_low + fraction * (high - dark_low)
                              : bright_high - fraction * (bright_high - low));
      }
    }
    for (double level : levels) {
      cv::Mat mask = dark ? (grey <= level) : (grey >= level);
      cv::morphologyEx(mask, mask, cv::MORPH_OPEN, opening);
      if (settings.strip_width_px > 2) {
        thin.push_back(thinParts(mask));
        drawStripLines(thin.back(), &band);
      }
      masks.push_back(mask);
    }
    cv::Mat strips = cv::Mat::zeros(grey.size(), CV_8U);
    if (cv::countNonZero(band) > 0) {
      for (const cv::Mat& parts : thin) strips |= band & parts;
      cv::dilate(strips, strips, opening);
    }
    const bool cut = cv::countNonZero(strips) > 0;
    for (cv::Mat& mask : masks) {
      if (!cut) {
        collect(mask, dark, cv::Mat());
        continue;
      }
      // The cut cleans regions, it does not make new ones: background joined to the border
      // only through a strip (the field beside a rod) stays out.
      const cv::Mat touching = borderRegions(mask);
      mask.setTo(0, strips);
      cv::morphologyEx(mask, mask, cv::MORPH_OPEN, opening);
      collect(mask, dark, touching);
    }
  }
  return blobs;
}

}  // namespace imaging
}  // namespace fluoro_tracker
