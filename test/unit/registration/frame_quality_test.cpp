#include "fluoro_tracker/registration/frame_quality.h"

#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/registration/registrar.h"

using namespace fluoro_tracker;
using registration::classifyBones;

namespace {

registration::RegistrationResult twoBones(double inliers0, double inliers1) {
  registration::RegistrationResult r;
  r.poses.assign(2, geometry::Pose::Identity());
  r.diverged.assign(2, false);
  r.quality.resize(2);
  r.quality[0].contour_inlier_fraction = r.quality[0].offset_inlier_fraction = inliers0;
  r.quality[1].contour_inlier_fraction = r.quality[1].offset_inlier_fraction = inliers1;
  r.quality[0].contour_rms_px = r.quality[1].contour_rms_px = 0.4;
  r.quality[0].contour_spread_px = r.quality[1].contour_spread_px = 0.3;
  return r;
}

}  // namespace

TEST(FrameQuality, StatusFollowsTheDocumentedThresholds) {
  const registration::QualitySettings s;
  EXPECT_EQ(classifyBones(twoBones(0.95, 0.9), s), (std::vector<std::string>{"ok", "ok"}));
  EXPECT_EQ(classifyBones(twoBones(0.5, 0.1), s), (std::vector<std::string>{"suspect", "lost"}));

  auto rough = twoBones(0.95, 0.95);
  rough.quality[1].contour_spread_px = s.suspect_contour_spread_px + 0.1;
  rough.quality[1].contour_rms_px = s.suspect_contour_spread_px + 0.2;
  EXPECT_EQ(classifyBones(rough, s), (std::vector<std::string>{"ok", "suspect"}));

  auto diverged = twoBones(0.95, 0.95);
  diverged.diverged[0] = true;
  EXPECT_EQ(classifyBones(diverged, s)[0], "lost");

  auto nan = twoBones(0.95, 0.95);
  nan.poses[1].translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(classifyBones(nan, s)[1], "lost");
}

// The inliers' RMS counts the rim's uniform edge offset (0.9-1.1 px on titanium that fits), so
// by default only their spread about its mean is tested; the RMS test is there when asked.
TEST(FrameQuality, ContourRmsIsTestedOnlyWhenAsked) {
  registration::QualitySettings s;
  auto offset = twoBones(0.95, 0.95);
  offset.quality[0].contour_rms_px = 1.1;
  EXPECT_EQ(classifyBones(offset, s), (std::vector<std::string>{"ok", "ok"}));
  s.suspect_contour_rms_px = 1.0;
  EXPECT_EQ(classifyBones(offset, s), (std::vector<std::string>{"suspect", "ok"}));
  s.suspect_contour_spread_px = 0.0;  // off
  offset.quality[1].contour_spread_px = 0.85;
  EXPECT_EQ(classifyBones(offset, s)[1], "ok");
}

// The inlier tests count each sample where its bone's edge offset puts it unless told to count
// it where the outline lies; choosing between solutions always counts where the outline lies.
TEST(FrameQuality, InlierTestsCountAtTheEdgeOffsetUnlessToldOtherwise) {
  registration::QualitySettings s;
  auto r = twoBones(0.95, 0.95);
  r.quality[0].contour_inlier_fraction = 0.5;  // the rim more than 1.5 px off the outline
  r.quality[1].contour_inlier_fraction = 0.2;
  EXPECT_EQ(classifyBones(r, s), (std::vector<std::string>{"ok", "ok"}));
  EXPECT_DOUBLE_EQ(registration::resultRank(r, s).second, -0.7);
  s.inliers_at_edge_offset = false;
  EXPECT_EQ(classifyBones(r, s), (std::vector<std::string>{"suspect", "lost"}));
  EXPECT_DOUBLE_EQ(registration::statusInlierFraction(r.quality[0], s), 0.5);
}

// Unseen samples (a view's outline in clipped dark grey while the other views hold the bone)
// leave the status's fraction; choosing between solutions still counts them as misses.
TEST(FrameQuality, UnseenSamplesLeaveTheStatusButNotTheChoiceBetweenSolutions) {
  registration::QualitySettings s;
  auto held = twoBones(0.55, 0.95);
  held.quality[0].contour_points = 1000;
  held.quality[0].unseen_points = 400;  // 550 of the 600 seen samples are inliers
  EXPECT_NEAR(registration::statusInlierFraction(held.quality[0], s), 550.0 / 600.0, 1e-12);
  EXPECT_EQ(classifyBones(held, s), (std::vector<std::string>{"ok", "ok"}));
  EXPECT_EQ(registration::resultRank(held, s).first, 1);  // 0.55 of every sample: suspect
  s.unseen_edge_distance_px = 0.0;                        // off
  EXPECT_EQ(classifyBones(held, s), (std::vector<std::string>{"suspect", "ok"}));
  // Every sample unseen: nothing to count them by, so the fraction stands.
  s = registration::QualitySettings();
  held.quality[0].unseen_points = 1000;
  EXPECT_EQ(registration::statusInlierFraction(held.quality[0], s), 0.55);
}

TEST(FrameQuality, AnImplausibleJointMakesBothBonesSuspect) {
  const registration::QualitySettings s;
  auto r = twoBones(0.95, 0.95);
  registration::JointResult joint;
  joint.parent = 0;
  joint.child = 1;
  joint.quality.penetration_m = 1e-3 * (s.suspect_penetration_mm + 0.5);
  r.joints.push_back(joint);
  EXPECT_EQ(classifyBones(r, s), (std::vector<std::string>{"suspect", "suspect"}));
  r.joints[0].quality.penetration_m = 0.0;
  r.joints[0].quality.envelope_violation = s.suspect_envelope_violation + 1.0;
  EXPECT_EQ(classifyBones(r, s), (std::vector<std::string>{"suspect", "suspect"}));
  r.joints[0].quality.envelope_violation = 0.5 * s.suspect_envelope_violation;
  EXPECT_EQ(classifyBones(r, s), (std::vector<std::string>{"ok", "ok"}));
}

TEST(FrameQuality, OutOfPlaneUncertaintyIsFlaggedOnlyWhenAsked) {
  registration::QualitySettings s;
  auto r = twoBones(0.95, 0.95);
  r.quality[0].out_of_plane_sd_m = 0.004;
  EXPECT_EQ(classifyBones(r, s)[0], "ok");  // off by default
  s.suspect_out_of_plane_sd_mm = 2.0;
  EXPECT_EQ(classifyBones(r, s)[0], "suspect");
  r.quality[0].out_of_plane_sd_m = -1.0;  // not computed: no verdict from it
  EXPECT_EQ(classifyBones(r, s)[0], "ok");
}

TEST(FrameQuality, EnvelopeViolationIsTheLargestDistanceOutsideTheBounds) {
  constraints::LigamentSettings ligaments;  // knee defaults: adduction +-3 deg, z +-5 mm
  kinematics::KneeCoordinates k;
  k.flexion_rad = 0.5;
  EXPECT_DOUBLE_EQ(registration::envelopeViolation(ligaments, k), 0.0);
  k.adduction_rad = 7.0 * 3.14159265358979323846 / 180.0;  // 4 deg outside
  k.z_m = -0.0065;                                         // 1.5 mm outside
  EXPECT_NEAR(registration::envelopeViolation(ligaments, k), 4.0, 1e-9);
  EXPECT_THROW(registration::QualitySettings{-1.0}.validate(), InputError);
}

TEST(FrameQuality, TroubleCountsBonesNotOkWithALostOneTwice) {
  EXPECT_EQ(registration::statusTrouble({"ok", "ok"}), 0);
  EXPECT_EQ(registration::statusTrouble({"ok", "suspect"}), 1);
  EXPECT_EQ(registration::statusTrouble({"lost", "suspect"}), 3);
  EXPECT_EQ(registration::statusTrouble({}), 0);
}

// Independent residuals are worth one sample each; an AR(1) sequence with coefficient phi is
// worth (1 + phi) / (1 - phi) consecutive samples per independent one.
TEST(FrameQuality, ResidualCorrelationCountsTheSamplesOneIndependentResidualIsWorth) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<double> white(20000);
  for (double& x : white) x = noise(rng);
  EXPECT_NEAR(registration::integratedAutocorrelation({white}), 1.0, 0.1);

  const double phi = 0.8;
  std::vector<double> correlated(20000);
  double x = 0.0;
  for (double& y : correlated) y = x = phi * x + noise(rng);
  const double expected = (1.0 + phi) / (1.0 - phi);
  EXPECT_NEAR(registration::integratedAutocorrelation({correlated}), expected, 0.15 * expected);

  // Gaps (samples off the edges) split nothing but their own pairs; two views pool.
  std::vector<double> gapped = correlated;
  for (std::size_t i = 0; i < gapped.size(); i += 50) {
    gapped[i] = std::numeric_limits<double>::quiet_NaN();
  }
  const std::vector<double> half_a(correlated.begin(), correlated.begin() + 10000);
  const std::vector<double> half_b(correlated.begin() + 10000, correlated.end());
  EXPECT_NEAR(registration::integratedAutocorrelation({gapped}), expected, 0.15 * expected);
  EXPECT_NEAR(registration::integratedAutocorrelation({half_a, half_b}), expected, 0.15 * expected);

  // Nothing to measure: one sample, no spread.
  EXPECT_EQ(registration::integratedAutocorrelation({{1.0}}), 1.0);
  EXPECT_EQ(registration::integratedAutocorrelation({std::vector<double>(100, 0.3)}), 1.0);
  EXPECT_EQ(registration::integratedAutocorrelation({}), 1.0);
}

// Each view's edge distances about that view's own mean: an offset shared by a whole view drops
// out, one that differs between views does too, and a view of a single inlier deviates by nothing.
TEST(FrameQuality, RmsAboutSequenceMeansLeavesOutEachSequencesOwnMean) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NEAR(registration::rmsAboutSequenceMeans({{0.8, nan, 1.2}, {-0.5}}),
              std::sqrt((0.04 + 0.04) / 3.0), 1e-12);
  EXPECT_NEAR(registration::rmsAboutSequenceMeans({{1.0, 1.0}, {-2.0, -2.0}}), 0.0, 1e-12);
  EXPECT_EQ(registration::rmsAboutSequenceMeans({{nan}}), 0.0);
  EXPECT_EQ(registration::rmsAboutSequenceMeans({}), 0.0);
}
