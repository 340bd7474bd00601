#include "fluoro_tracker/registration/frame_quality.h"

#include <algorithm>
#include <cmath>

#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/registration/registrar.h"

namespace fluoro_tracker {
namespace registration {

namespace {

// `sequence` less the mean of its finite values (gaps stay gaps); `finite` counts those values.
std::vector<double> lessItsMean(const std::vector<double>& sequence, int* finite) {
  double sum = 0.0;
  int n = 0;
  for (double x : sequence) {
    if (std::isfinite(x)) {
      sum += x;
      ++n;
    }
  }
  *finite = n;
  if (n == 0) return sequence;
  const double mean = sum / n;
  std::vector<double> deviations;
  deviations.reserve(sequence.size());
  for (double x : sequence) deviations.push_back(x - mean);
  return deviations;
}

// Adds the squares of `values`' finite entries to `total`, one by one.
void addFiniteSquares(const std::vector<double>& values, double* total) {
  for (double x : values) {
    if (std::isfinite(x)) *total += x * x;
  }
}

}  // namespace

double integratedAutocorrelation(const std::vector<std::vector<double>>& sequences) {
  constexpr int kMaxLag = 200;
  std::vector<std::vector<double>> centred;
  double variance_sum = 0.0;
  double raw_squares = 0.0;  // for a spread threshold relative to the values' size
  int count = 0;
  for (const auto& sequence : sequences) {
    addFiniteSquares(sequence, &raw_squares);
    int n = 0;
    std::vector<double> deviations = lessItsMean(sequence, &n);
    if (n < 2) continue;
    addFiniteSquares(deviations, &variance_sum);
    count += n;
    centred.push_back(std::move(deviations));
  }
  // Rounding leaves a constant sequence a spread of ~1e-32 of its square.
  if (count < 2 || !(variance_sum > 1e-20 * raw_squares)) return 1.0;
  const double variance = variance_sum / count;
  double tau = 1.0;
  for (int lag = 1; lag <= kMaxLag; ++lag) {
    double products = 0.0;
    int pairs = 0;
    for (const auto& sequence : centred) {
      for (std::size_t i = 0; i + lag < sequence.size(); ++i) {
        const double a = sequence[i];
        const double b = sequence[i + lag];
        if (std::isfinite(a) && std::isfinite(b)) {
          products += a * b;
          ++pairs;
        }
      }
    }
    if (pairs == 0) break;
    const double rho = products / pairs / variance;
    if (!(rho > 0.0)) break;
    tau += 2.0 * rho;
  }
  return tau;
}

void QualitySettings::validate() const {
  const auto fraction = [](double value, const char* name) {
    if (!(value >= 0.0 && value <= 1.0)) {
      throw InputError(std::string("registration quality: ") + name + " must be in [0, 1]");
    }
  };
  const auto non_negative = [](double value, const char* name) {
    if (!(value >= 0.0)) {
      throw InputError(std::string("registration quality: ") + name + " must be >= 0");
    }
  };
  if (!(inlier_distance_px > 0.0)) {
    throw InputError("registration quality: inlier_distance_px must be > 0");
  }
  fraction(lost_inlier_fraction, "lost_inlier_fraction");
  fraction(suspect_inlier_fraction, "suspect_inlier_fraction");
  non_negative(suspect_contour_spread_px, "suspect_contour_spread_px");
  non_negative(suspect_contour_rms_px, "suspect_contour_rms_px");
  non_negative(suspect_penetration_mm, "suspect_penetration_mm");
  non_negative(suspect_envelope_violation, "suspect_envelope_violation");
  non_negative(suspect_out_of_plane_sd_mm, "suspect_out_of_plane_sd_mm");
  non_negative(suspect_rotation_sd_deg, "suspect_rotation_sd_deg");
  fraction(relative_inlier_drop, "relative_inlier_drop");
  non_negative(relative_inlier_spread, "relative_inlier_spread");
  if (relative_inlier_window < 1 || relative_inlier_min_frames < 1 ||
      relative_inlier_min_frames > relative_inlier_window) {
    throw InputError(
        "registration quality: relative_inlier_window must be >= 1 and "
        "relative_inlier_min_frames in [1, relative_inlier_window]");
  }
  non_negative(unseen_edge_distance_px, "unseen_edge_distance_px");
  fraction(held_by_other_views_inlier_fraction, "held_by_other_views_inlier_fraction");
  if (relative_inlier_trend_frames != 0 && relative_inlier_trend_frames < 3) {
    throw InputError("registration quality: relative_inlier_trend_frames must be 0 (off) or >= 3");
  }
}

double envelopeViolation(const constraints::LigamentSettings& ligaments,
                         const kinematics::KneeCoordinates& k) {
  const double coordinates[6] = {k.flexion_rad, k.adduction_rad, k.internal_rotation_rad,
                                 k.x_m,         k.y_m,           k.z_m};
  return constraints::largestExcess(
      ligaments, [&](const constraints::LigamentSettings& unit, double residuals[6]) {
        constraints::ligamentResiduals(unit, coordinates, residuals);
      });
}

double rmsAboutSequenceMeans(const std::vector<std::vector<double>>& sequences) {
  double squares = 0.0;
  int count = 0;
  for (const auto& sequence : sequences) {
    int n = 0;
    addFiniteSquares(lessItsMean(sequence, &n), &squares);
    count += n;
  }
  return count > 0 ? std::sqrt(squares / count) : 0.0;
}

std::string combinedStatus(const std::string& parent, const std::string& child) {
  if (parent == "lost" || child == "lost") return "lost";
  return parent == "ok" && child == "ok" ? "ok" : "suspect";
}

int statusTrouble(const std::vector<std::string>& status) {
  int trouble = 0;
  for (const std::string& s : status) trouble += s == "ok" ? 0 : s == "lost" ? 2 : 1;
  return trouble;
}

double unseenFraction(const BoneQuality& quality) {
  return quality.contour_points > 0
             ? static_cast<double>(quality.unseen_points) / quality.contour_points
             : 0.0;
}

double statusInlierFraction(const BoneQuality& quality, const QualitySettings& settings) {
  const double fraction = settings.inliers_at_edge_offset ? quality.offset_inlier_fraction
                                                          : quality.contour_inlier_fraction;
  // Unseen samples are never inliers: the share of the others is the same count over fewer.
  const int seen = quality.contour_points - quality.unseen_points;
  if (!(settings.unseen_edge_distance_px > 0.0) || quality.unseen_points <= 0 || seen <= 0) {
    return fraction;
  }
  return fraction * quality.contour_points / seen;
}

QualitySettings everySampleCounted(QualitySettings settings) {
  settings.unseen_edge_distance_px = 0.0;
  return settings;
}

std::pair<int, double> resultRank(const RegistrationResult& result,
                                  const QualitySettings& settings) {
  double inliers = 0.0;
  for (const BoneQuality& q : result.quality) inliers += q.contour_inlier_fraction;
  return {statusTrouble(classifyBones(result, everySampleCounted(settings))), -inliers};
}

std::vector<std::string> classifyBones(const RegistrationResult& result,
                                       const QualitySettings& settings) {
  // An optional test (threshold 0: off); a figure not computed (negative) is never above it.
  const auto above = [](double figure, double threshold) {
    return threshold > 0.0 && figure > threshold;
  };
  const std::size_t bones = result.poses.size();
  std::vector<std::string> status(bones, "ok");
  for (std::size_t b = 0; b < bones; ++b) {
    const bool diverged = b < result.diverged.size() && result.diverged[b];
    if (diverged || !geometry::isValidPose(result.poses[b])) {
      status[b] = "lost";
      continue;
    }
    if (b >= result.quality.size()) continue;
    const BoneQuality& q = result.quality[b];
    const double inliers = statusInlierFraction(q, settings);
    if (inliers < settings.lost_inlier_fraction) {
      status[b] = "lost";
    } else if (inliers < settings.suspect_inlier_fraction ||
               above(q.contour_spread_px, settings.suspect_contour_spread_px) ||
               above(q.contour_rms_px, settings.suspect_contour_rms_px) ||
               above(q.out_of_plane_sd_m * 1000.0, settings.suspect_out_of_plane_sd_mm) ||
               above(geometry::radToDeg(q.max_rotation_sd_rad), settings.suspect_rotation_sd_deg)) {
      status[b] = "suspect";
    }
  }
  for (const JointResult& joint : result.joints) {
    const bool implausible =
        joint.quality.penetration_m * 1000.0 > settings.suspect_penetration_mm ||
        joint.quality.envelope_violation > settings.suspect_envelope_violation;
    if (!implausible) continue;
    for (int b : {joint.parent, joint.child}) {
      if (b >= 0 && static_cast<std::size_t>(b) < bones && status[b] == "ok") status[b] = "suspect";
    }
  }
  return status;
}

}  // namespace registration
}  // namespace fluoro_tracker
