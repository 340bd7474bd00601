#pragma once

#include <string>
#include <utility>
#include <vector>

#include "fluoro_tracker/constraints/ligament_envelope.h"
#include "fluoro_tracker/kinematics/knee_coordinates.h"

namespace fluoro_tracker {
namespace registration {

struct RegistrationResult;

// How well one bone's registration is supported by its image, at the final pose.
struct BoneQuality {
  // Projected contour samples in all views (full resolution), but for those inside another
  // bone's silhouette (covered_points), whose edges the overlap fades.
  int contour_points = 0;
  int covered_points = 0;
  // Of contour_points, the share within inlier_distance_px of an image edge.
  double contour_inlier_fraction = 0.0;
  // The same share with each sample moved by the bone's estimated edge offset in its view, as
  // the image terms move it (RegistrationResult::edge_offsets_px): where the displayed rim lies
  // a pixel or more off the silhouette (a dense part under a rod, noise or a low resolution),
  // a bone that fits has most of its outline beyond inlier_distance_px of the edge it fits,
  // and only this share says so. Equal to contour_inlier_fraction without an offset model.
  double offset_inlier_fraction = 0.0;
  // Of contour_points, those the status's inlier fraction leaves out as unseen
  // (QualitySettings::unseen_edge_distance_px): in a view with no image edge near them and
  // clipped grey around them, while the bone's other views hold it. 0 in a single view.
  int unseen_points = 0;
  double contour_rms_px = 0.0;  // RMS edge distance of the inliers (full-resolution pixels)
  // RMS of the inliers' edge distances about their mean in each view (full-resolution pixels):
  // the fit's scatter without its uniform part. A displayed rim lies a fraction of a pixel
  // inside the silhouette, by an amount that depends on the material, dose and display (the
  // edge offset the registrar estimates), so contour_rms_px measures that offset as much as
  // the fit: bright titanium that fits reads 0.9-1.1 px, cobalt-chrome 0.3-0.6 px.
  double contour_spread_px = 0.0;
  // From the solver's covariance (RegistrationResult::covariances, when computed): the
  // translation's standard deviation along the first view's beam (m), the direction
  // single-plane registration pins down worst. Negative when not computed.
  double out_of_plane_sd_m = -1.0;
  // The largest rotational standard deviation (rad, any axis): single-plane, a rotation about
  // an axis across the beam (e.g. a tibial tray's tilt seen edge-on). Negative when not computed.
  double max_rotation_sd_rad = -1.0;
  // How many contour samples one independent residual is worth: the integrated autocorrelation
  // of the inliers' signed edge distances along the contour (1 + 2 sum of the lag
  // correlations up to the first that is not positive; 1 for uncorrelated residuals). The
  // solver's covariance treats every sample as independent; the reported one is scaled by it.
  // Measured only with the covariance (RegistrationSettings::compute_covariance); 1 otherwise.
  double residual_correlation_samples = 1.0;
};

// How plausible one joint is at the final poses.
struct JointQuality {
  double penetration_m = 0.0;  // deepest penetration of the articular surfaces (0 without contact)
  // Largest distance of a joint coordinate outside its ligament bounds, in degrees or
  // millimetres (0 inside, or without ligament bounds).
  double envelope_violation = 0.0;
};

// Thresholds that turn the quality figures into a bone's status (the `registration: quality:`
// section of the trial YAML). A bone is `lost` when its registration diverged, came back
// non-finite, or fewer than lost_inlier_fraction of its contour samples lie on image edges; it
// is `suspect` when fewer than suspect_inlier_fraction do, when their edge distances' RMS
// about their mean exceeds suspect_contour_spread_px (or their RMS, suspect_contour_rms_px),
// when a joint it belongs to penetrates deeper than suspect_penetration_mm or leaves its
// ligament envelope by more than suspect_envelope_violation (deg or mm), or when its out-of-plane
// standard deviation exceeds suspect_out_of_plane_sd_mm or its largest rotational one exceeds
// suspect_rotation_sd_deg (0 turns a test off; both need compute_covariance). Frames registered in
// sequence (the Tracker, the benchmark's trials) also compare each bone with its own recent frames
// (InlierHistory).
struct QualitySettings {
  double inlier_distance_px = 1.5;
  // The inlier tests below (lost, suspect, and the InlierHistory's) count each sample at its
  // edge offset (BoneQuality::offset_inlier_fraction) instead of where the outline lies.
  // Choosing between solutions of one frame (resultRank, the retries, the search) always
  // counts them where the outline lies: the search's refinements leave the offset unbounded,
  // and a wrong hypothesis can buy inliers with it. So does the tracker's retry of a bone that
  // fits worse than its recent frames (tracking_retry_inlier_drop), which is there to catch a
  // bone sliding along the beam with its offset. Measured: README, "Tracking quality".
  bool inliers_at_edge_offset = true;
  double lost_inlier_fraction = 0.3;
  double suspect_inlier_fraction = 0.6;
  // Inliers scattered like chance over the +-inlier_distance_px band have an RMS of
  // inlier_distance_px / sqrt(3) (0.87 px); a bone that fits has 0.2-0.5 px. 0 turns a test
  // off. Measured: README, "Tracking quality".
  double suspect_contour_spread_px = 0.7;
  double suspect_contour_rms_px = 0.0;  // off: see contour_spread_px
  double suspect_penetration_mm = 2.0;
  double suspect_envelope_violation = 5.0;
  double suspect_out_of_plane_sd_mm = 0.0;
  double suspect_rotation_sd_deg = 0.0;  // likewise for max_rotation_sd_rad (0: off)
  // Suspect, too, when the inlier fraction lies more than this below the median of the bone's
  // last relative_inlier_window frames (once it has relative_inlier_min_frames of them; 0
  // turns the test off), or, where those frames scatter more, more than relative_inlier_spread
  // robust standard deviations (1.4826 x their median absolute deviation) below it. Measured:
  // see README, "Tracking quality".
  double relative_inlier_drop = 0.1;
  double relative_inlier_spread = 3.0;
  int relative_inlier_window = 20;
  int relative_inlier_min_frames = 3;
  // Where the bone has at least this many frames, the reference is not the window's median but
  // the robust (Theil-Sen) line through the fractions of its last this many frames, carried on
  // to this frame and capped at their highest: a fraction that drifts with the pose (a tray
  // fading into the soft tissue of thigh and calf in deep flexion) is followed, a sudden drop
  // is not. 0, or more than relative_inlier_window: the median alone.
  int relative_inlier_trend_frames = 8;
  // Two or more views: a view's contour samples with no image edge within this distance
  // (full-resolution pixels), amid grey near a clipped end of the display
  // (EdgeMap::amidClippedGrey: dark on dark), are left out of the status's inlier fraction, as
  // covered samples are, when the bone's other views hold it (at least
  // held_by_other_views_inlier_fraction of their samples inliers). Where a bi-plane view looks
  // along the thigh, its soft tissue shows the femoral component black on near-black, and the
  // tray's outline fades where thigh and calf overlap in flexion; the other view holds the pose,
  // and those samples say nothing about it. A bone that slid along the holding view's beam lies
  // off its edges in the other view, in plain soft tissue, and is still flagged (bi-plane crude
  // starts 17-19 mm off, without the clipped-grey test, were not). Only the status reported
  // changes: choosing between solutions and the tracker's decisions count every sample
  // (everySampleCounted), so no pose does. 0 turns it off. Measured: README, "Tracking quality".
  double unseen_edge_distance_px = 15.0;
  double held_by_other_views_inlier_fraction = 0.9;

  void validate() const;  // throws InputError naming the field
};

// Largest distance of a joint coordinate outside its ligament bounds (degrees or millimetres);
// 0 inside.
double envelopeViolation(const constraints::LigamentSettings& ligaments,
                         const kinematics::KneeCoordinates& coordinates);

// The integrated autocorrelation 1 + 2 sum_k rho_k of one or more sequences (NaN entries are
// gaps: pairs with a gap are skipped), the lag correlations pooled over the sequences, each
// about its own mean, summed up to the first lag whose correlation is not positive (Geyer's
// initial positive sequence) and at most 200 lags: how many consecutive samples one independent
// sample is worth. 1 for fewer than two finite samples or no spread.
double integratedAutocorrelation(const std::vector<std::vector<double>>& sequences);

// The RMS of one or more sequences' finite values about their own sequence's mean (NaN entries
// are gaps; a sequence of one value deviates by nothing), over all the finite values; 0 without
// any. Of each view's inliers' edge distances: BoneQuality::contour_spread_px.
double rmsAboutSequenceMeans(const std::vector<std::vector<double>>& sequences);

// The share of a bone's counted contour samples left out of the status's fraction as unseen
// (BoneQuality::unseen_points; 0 without samples).
double unseenFraction(const BoneQuality& quality);

// The inlier fraction the status tests use (QualitySettings::inliers_at_edge_offset), of the
// contour samples not unseen (BoneQuality::unseen_points).
double statusInlierFraction(const BoneQuality& quality, const QualitySettings& settings);

// A joint's status from its two bones': lost if either is, ok if both are, else suspect.
std::string combinedStatus(const std::string& parent, const std::string& child);

// How much of a result is in doubt, for choosing between results of one frame: its bones not
// ok, a lost one counting twice (0 when every bone is ok).
int statusTrouble(const std::vector<std::string>& status);

// The settings with every contour sample counted (unseen_edge_distance_px 0): for choosing
// between solutions of one frame and deciding whether to retry it, where a wrong solution whose
// outline a view shows in clipped dark grey would lose its misses there (a bi-plane knee from
// crude starts, 12-19 mm along the first beam, was called ok).
QualitySettings everySampleCounted(QualitySettings settings);

// For choosing between registrations of one frame (lower is better): statusTrouble of its
// bones' classifyBones status under everySampleCounted, then the negated sum of their contour
// inlier fractions.
std::pair<int, double> resultRank(const RegistrationResult& result,
                                  const QualitySettings& settings);

// Per bone "ok", "suspect" or "lost" from a registration's quality figures (see QualitySettings).
std::vector<std::string> classifyBones(const RegistrationResult& result,
                                       const QualitySettings& settings);

}  // namespace registration
}  // namespace fluoro_tracker
