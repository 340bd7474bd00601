#pragma once

#include <algorithm>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "fluoro_tracker/constraints/articular_contact.h"
#include "fluoro_tracker/constraints/glenohumeral_springs.h"
#include "fluoro_tracker/constraints/ligament_envelope.h"
#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/geometry/xray_camera.h"
#include "fluoro_tracker/imaging/edge_map.h"
#include "fluoro_tracker/imaging/silhouette.h"
#include "fluoro_tracker/kinematics/joint_types.h"
#include "fluoro_tracker/kinematics/knee_coordinates.h"
#include "fluoro_tracker/registration/frame_quality.h"

namespace fluoro_tracker {
namespace registration {

// One stage of a staged schedule (dissertation ch. 4, Dataset B: first image and ligament
// bounds without contact, then everything): which terms take part, how long it runs, and
// per-bone image weights (e.g. femur 2, tibia 1 when the femur's image is the more reliable).
struct RegistrationStage {
  int outer_iterations = 4;
  int solver_iterations = 8;
  bool contact = true;
  bool ligaments = true;
  int contact_from_outer_iteration = 0;         // within this stage
  std::map<std::string, double> image_weights;  // bone name -> factor; absent bones: 1

  double imageWeight(const std::string& bone) const {
    const auto it = image_weights.find(bone);
    return it == image_weights.end() ? 1.0 : it->second;
  }
};

// Single-view registrations of a joint also try the child bone's mirror poses (see
// mirror_ambiguity.h): from the solution with the child mirrored through the plane across the
// beam, and (turn_reflection) with its turn about its long axis reversed, the frame is solved
// again on the finest scale's edge maps; a candidate is kept when it fits about as well (final
// cost within cost_tolerance of the first solution's) and leaves the joint nearest neutral
// (neutralDeviation, in units of the joint's ligament bounds, which are the knee's defaults
// when the joint has no springs). The assumption: of poses the image cannot tell apart, the
// knee's varus-valgus and axial rotation are the smallest. Measured (benchmark, contact +
// ligaments): success 92 -> 95 % under the standard protocol, 78 -> 86 % from crude starts,
// 70 -> 81 % on poor images; the median time per frame rises from 27 to 48 ms (two solves).
struct MirrorCheckSettings {
  bool enabled = true;
  double cost_tolerance = 0.1;
  double min_difference_deg = 1.0;    // mirrors nearer the solution than this are not tried
  double max_difference_deg = 180.0;  // ... nor those farther than this
  // The mirror replaces the solution only when its joint is nearer neutral by more than this
  // (neutralDeviation, in units of the ligament bounds). The knee's coordinates from one view
  // scatter by about 0.3 deg in adduction (0.1 of its 3 deg bound) and 0.7 deg in internal
  // rotation, so a smaller gain is noise: a tray turned 6 deg one way about its stem and its
  // turn reflection 6 deg the other way are equally neutral, and the check used to swap such
  // pairs at random. Measured (`benchmark --conditions contact`): see README.
  double min_neutral_gain = 0.1;
  // Neutral internal rotation per degree of flexion (degrees; neutral adduction stays 0). The
  // tibia turns internally as the knee flexes: about 20 deg over 120 deg in natural knees, 3-8
  // deg on average in total knees (fluoroscopic deep-knee-bend studies). With neutral at 0 deg at
  // every flexion, trays truly turned 6-8 deg in deep flexion lost to their turn reflections at
  // -4 to +1 deg, nearer 0: contact + ligaments from the standard protocol's starts scored 80 and
  // 91 % on benchmark seeds 3 and 5 (held out from the check's design), below image terms alone.
  // The prior cuts both ways. Measured on simulated knees that turn 8 deg by their deepest
  // flexion and on knees that do not turn (README "Neutral turns with flexion"; 400 frames each):
  // 0.03 won 22 frames on the first and lost 11 on the second, 0.05 won 24 and lost 21. The
  // automatic search (PoseSearch) chooses between mirror hypotheses by the same neutral.
  double neutral_internal_rotation_per_flexion = 0.03;
  int outer_iterations = 2;  // of the mirror's solve (finest scale, each stage)
  // Levenberg-Marquardt iterations per outer iteration of the mirror's solve (at most the
  // registration's own). Fewer save time but lose accuracy on poor images: 4 instead of 8
  // measured the same success on the standard and crude protocols (42 instead of 47 ms per
  // frame) but 74 instead of 81 % from crude starts on poor images (6: 77 %).
  int solver_iterations = 8;
  // Also try the child turned about its long axis to the mirror of its turn relative to the
  // beam (turnReflectedAcrossBeam), a second solve.
  bool turn_reflection = true;
  // The child mirrored through the plane along the beam (mirroredAcrossBeam: its tilt and turn
  // relative to the beam both reversed) is tried; off, only the turn reflection is.
  bool mirror_reflection = true;
  // Also try the child with only its tilt reversed (tiltReflectedAcrossBeam), a third solve when
  // it differs from the other candidates by more than min_difference_deg (a tray turned about
  // its stem relative to the beam). Measured (`benchmark`, contact + ligaments): standard
  // protocol 95 -> 98 % (seed 7) and 96.5 -> 97.5 % (seed 11, 8 trials); crude starts 91 -> 92
  // % (good images) and 81 -> 84 % (poor); about 12 ms more per frame. Tried instead of the
  // full mirror rather than besides it: poor images from crude starts then lost 7 of 71 frames
  // with contact alone.
  bool tilt_reflection = true;
  // Frames the tracker continues from an earlier result (registration::Tracker) try only the
  // turn reflection (and the tilt reflection, below), and only when it lies within this of the
  // solution (0: never). The tracker
  // follows the tray through the view where its turn about the stem has no sign; there the two
  // branches meet, and the check keeps it on the one nearer neutral; away from that view the
  // previous frame decides. Measured with track_bag on three heavy-scatter trials
  // (config/robustness/heavy_scatter.yaml, seeds 0, 3 and 5): 49, 57 and 57 of 60 frames within
  // the criteria without the check, 60, 60 and 60 with it at 3, 6, 10 or 20 deg; the tilt mirror
  // alone fixed none. On the node benchmark's 200-frame trial, whose tray stays near that view
  // for a long stretch, track_bag ran at 54 frames/s without it, 54 at 3 deg and 42 at 6 deg
  // (the live node then dropped 23 of 200 frames at 30 Hz).
  double tracking_turn_max_difference_deg = 3.0;
  // ... and the tilt reflection too, within the same distance: a tray's plateau passing
  // edge-on, where its varus-valgus tilt has no sign, left the tracker on the mirror branch
  // (benchmark trials tracked 2-4 deg off in tilt for up to 22 frames, status ok; over 40
  // varied trials 2265 -> 2341 of 2360 frames within the criteria; README "The tilt
  // reflection while tracking").
  bool tracking_tilt_reflection = true;
  // A candidate's solve stops after an outer iteration (not its last) that leaves its cost above
  // abandon_cost_ratio x the solution's, or its joint farther from neutral than the deviation
  // it must beat by more than abandon_deviation_excess (units of the ligament bounds): such a
  // candidate is not kept. Logged on every candidate of four benchmark runs (contact +
  // ligaments: standard protocol seeds 7 and 11, crude starts on good and poor images; 1,345
  // candidates), the 153 that ended within the cost tolerance and nearer neutral than required
  // had at most 1.6 x the cost and 0.8 units of excess after their first outer iteration, while
  // 36 % of all candidates were beyond 2 x or 1 unit; the benchmarks' results were unchanged.
  double abandon_cost_ratio = 2.0;
  double abandon_deviation_excess = 1.0;
  // A candidate whose start (the child reflected, nothing solved yet) is farther from neutral than
  // the deviation it must beat by more than this (units of the ligament bounds) is not solved at
  // all: its solve moves the joint too little to get there. Logged on every candidate of the same
  // four benchmark runs (1,345 candidates), the 153 that ended within the cost tolerance and
  // nearer neutral than required had started at most 1.05 units beyond; 28-42 % of all
  // candidates started beyond 1.5, most of which the gate above stopped after one outer
  // iteration. The benchmarks' results are unchanged; about 5 fewer cost evaluations per frame.
  double start_deviation_excess = 1.5;
  // Outer iterations more for a candidate still in the running after its outer_iterations and
  // not yet converged: its joint nearer neutral than it must be, its cost within
  // abandon_cost_ratio x the solution's (0: none). Two outer iterations leave a reflected tray
  // short of its minimum on poor images: logged on crude starts (poor images, seed 3), candidates
  // near the true turn ended at 1.07-1.19 x the first solution's cost and were not kept, while
  // solving the frame from its true pose ended below that cost.
  int continued_outer_iterations = 2;
};

// Tracking (EdgeOffsetFilter): each bone's edge offset carried from frame to frame as a prior.
// Single-plane registration from a crude guess can settle with both bones several millimetres to
// centimetres along the beam, where rotations make up for the wrong size of their projections.
// When the result's quality status is not ok for some bone, the registrar solves again from the
// result moved along the first view's beam by each of `shifts_mm` (every bone by the same
// distance, along its own ray from the source) and keeps the best: fewest bones not ok, then
// the highest contour inlier fraction. Frames the tracker continues from an earlier result do
// not retry (a lost one is searched instead), nor do the pose search's refinements.
// An option, off by default: a result whose bones are all ok but one of them has fewer contour
// inliers than `light_below_inlier_fraction` (0: never) is solved again from the same shifts on
// the finest scale's edge maps only, with a mirror candidate's outer and solver iterations and no
// mirror check, the shifts side by side on two threads; the better ranked replaces it. Measured
// at 0.95 (README "Registration"): crude starts on poor images 83 / 84 / 93 / 90.5 -> 85 / 86 /
// 95 / 91 % (seeds 3 / 5 / 7 / 11), the other protocols unchanged, but their noise leaves nearly
// every poor frame below 0.95, and the median time per frame rose about 4 ms, past 30 ms.
// Two or more views: every view but the first sees a bone's place along the first beam in its
// own image plane, so before the shifts a bone in doubt is first moved by its own contour's shift
// to the views' edges (posesShiftedToEdges, one bone at a time, within
// `other_views_shift_mm`; 0: not tried), and the frame solved again from there. Bi-plane crude
// starts (each bone up to 20 or 50 mm off along the first beam) otherwise left a bone tens of
// millimetres off where the fixed shifts do not reach (README "Registration").
struct DepthRetrySettings {
  bool enabled = true;
  std::vector<double> shifts_mm = {-15.0, 15.0};
  double light_below_inlier_fraction = 0.0;
  double other_views_shift_mm = 60.0;
};

// Single view: a bone whose contour lies poorly on the image's edges after the solve (inlier
// fraction below `below_inlier_fraction`) may sit in the false minimum its own reflection across
// the beam leads into (see mirror_ambiguity.h: a start a few degrees to the wrong side of the view
// where its tilt or turn has no sign converges there, and on real frames the trap also slides it
// along the beam). The registrar then solves the frame again from each of the bone's reflections
// (full mirror, turn reflection, tilt reflection) with the other bones at their results. A
// candidate qualifies if its bone's inliers gain at least `min_inlier_gain`, the frame's final
// cost is lower and no bone's status is worse; of those, the one whose bone ends nearest its
// start replaces the result. Unlike the mirror check this asks the image, not the joint: it
// serves image-only registration too, and a better fit may replace a solution nearer neutral.
// Measured (see README, "Registration"): the real Kneel frames' perturbed starts image only
// 57 -> 60 of 60 (the tray's tilt reflection; 12-14 mm along the beam and 4-5 deg off before);
// crude starts on poor images 91 -> 93 % (seed 7), 83 -> 85 % (seed 11). Gating on the cost as
// well as the inliers matters on poor images, where a noisy femur's reflection can gain inliers
// on clutter: with the inliers alone seed 11 fell to 81.5 %. Frames the tracker continues and
// the pose search's refinements do not retry.
// `before_mirror_check`: a bone the mirror check does not reflect (not a knee's child) is also
// retried when the first solution, before the check replaced it, left it below the gate: the
// check moves only the child, and a wrong femoral component can make a wrong turn of the tray
// fit, which lifts the femur's inliers without freeing it. The retry then starts from that first
// solution; a candidate qualifies against the first solution's inliers and the kept solution's
// cost. Measured (README, "Registration"): `video_512` frame 0 from its true pose, the tray 6.6
// deg off about its stem before; crude starts with every term seeds 3 / 5 / 7 / 11, good images
// 91 / 88 / 95 / 98 -> 93 / 88 / 95 / 98 %, poor images 82 / 85 / 93 / 90 -> 84 / 85 / 93 / 90 %.
struct ReflectionRetrySettings {
  bool enabled = true;
  double below_inlier_fraction = 0.85;
  double min_inlier_gain = 0.05;
  bool before_mirror_check = true;
};

// A bone whose contour lies on its edges with a wide spread (BoneQuality::contour_spread_px
// above `above_contour_spread_px`) may sit in a false minimum a few degrees from the truth: on
// one simulated trial every frame started with the tray tilted 3 deg one way about its own
// medial-lateral axis ended 2.7-3.9 deg off and up to 11 mm along the beam, at 1.4-4 x the cost
// the same frame reaches from its truth, its contour still 0.78-0.99 on edges (README,
// "Registration"). The registrar then solves the frame again from the result with that bone
// turned by `step_deg` either way about each of its three axes and keeps the solve with the
// lowest cost, if lower than the result's and no bone's status is worse. Registrations from
// the user's poses; the search's refinements do not retry. A frame the tracker continues
// retries a bone only where its spread also rose above `tracking_spread_rise` times the median
// of its recent frames (0: never), and keeps a retry only if it undoes at least half that rise:
// a tray sliding frame by frame into such a minimum (its tilt 3 deg off by the end of a
// simulated trial, every status ok) is freed, while a bone whose spread is wide in every frame
// (bright titanium, poor images) is not solved seven times a frame, and a noisy frame's retry
// that only lands elsewhere at a lower cost is not taken.
struct RotationRetrySettings {
  bool enabled = true;
  double above_contour_spread_px = 0.45;
  double step_deg = 3.0;
  double tracking_spread_rise = 1.25;
};

struct EdgeOffsetTrackingSettings {
  bool enabled = true;
  // Standard deviation of one frame's estimate (benchmark: 0.04-0.24 px within a trial).
  double frame_sd_px = 0.15;
  // How much the true offset may change from one frame to the next.
  double drift_px = 0.005;
};

// Compare the contour where the edge map finds the edges of each bone's own radiograph,
// rendered at its pose (registration::renderedEdgeRounding), instead of corner rounding, at the
// same outer iterations. An option for offline analysis, off by default. Measured (benchmark,
// standard protocol, every term, README "Registration"): along the beam 1.50 -> 1.32 mm (seed
// 7), 1.25 -> 1.08 mm (seed 11), 2.35 -> 1.59 mm on the Kneel study's implant models, their
// rotations about X and Y 0.28 -> 0.20 deg; but image-only success on those models 98 -> 93 %
// and the median time per frame 24 -> 32 ms (seed 7).
struct RenderedEdgeSettings {
  bool enabled = false;
  // Metal path (mm) at which the rendered grey saturates: about where a real frame's display
  // stops darkening (3 mm moved depth the wrong way on the benchmark, 8 mm far more).
  double saturation_mm = 1.0;
};

struct RegistrationSettings {
  // Coarse-to-fine image scales. Half resolution first keeps a bone from sliding along the
  // beam before its edge offset is free: on the real Kneel frames full resolution alone left the
  // tibial tray 10-30 mm off in 9 of 60 perturbed starts (image only), {0.5, 1} in 3.
  // Add 0.25 for cruder starts.
  std::vector<double> scales = {0.5, 1.0};
  int outer_iterations = 4;  // silhouettes re-extracted at the new poses each time
  // Outer iterations at each scale coarser than the finest; <= 0: outer_iterations. Two
  // instead of four measured nearly the same from +-2 mm / 3 deg starts (benchmark 89/96/96 %
  // against 90/96/96 %, 2-3 ms faster) but lost 4 points from crude starts.
  int coarse_outer_iterations = 0;
  // Scales for frames the tracker starts from the previous frame's registration. Those start
  // with each bone's edge offset carried from earlier frames, so the slide above does not
  // happen; full resolution alone tracked the same frames (robustness trials) and keeps the
  // live node at 30 Hz (with the half-resolution pass: median 34 ms, 3 of 200 frames dropped).
  std::vector<double> tracking_scales = {1.0};
  // A tracked frame (registered at tracking_scales, without the depth retry and with only the
  // tracking mirror check) that leaves its bones in more doubt (statusTrouble) than the frame
  // before is registered again with the full
  // schedule above (scales, depth retry, mirror check), from the tracker's prediction and from
  // the last good poses, and the best result (resultRank) is kept. The prediction misses when
  // the motion changes between frames (real sequences tracked at a fraction of their frame
  // rate); from a few millimetres off, full resolution alone lets a bone settle along the beam.
  // Measured: the real Kneel frames tracked as a sequence (ten video frames apart), 2/3 -> 3/3
  // within 1 mm and 2 deg of the lab's reference; the simulated robustness trials unchanged.
  bool tracking_retry = true;
  // A tracked frame whose doubt did not rise is also registered again (the same full schedule and
  // starts) when a bone's contour inlier fraction lies more than tracking_retry_inlier_drop below
  // the median of its recent frames (InlierHistory, from the second frame on, where the status
  // waits for relative_inlier_min_frames of them; 0 turns this off; single view only, as a
  // second view sees the depth). Here a retry
  // replaces the continued result only if no bone's status is worse, the frame's final cost is
  // lower and those bones' fractions gain at least tracking_retry_min_inlier_gain together: the
  // continued result is not in doubt, so the retry must fit clearly better. Why: the continued
  // registration starts each frame from the last one's result and carried edge offset
  // (EdgeOffsetTrackingSettings), and a bone's offset and its depth change its outline almost
  // alike, so the two can slide together a little in every frame. On a simulated trial of bright
  // titanium at half the dose in an oblique view, with beads and a platform, the knee went 34 mm
  // along the beam over ten frames (the femoral component's offset 0.76 -> -0.94 px, the tray
  // tilted 7 deg, inliers 0.93 -> 0.75), every status ok: the inlier history's trend line
  // follows so slow a decline. The full schedule from the same starts fits 0.95-0.99 of both
  // outlines there. Measured on 92 tracked simulated trials (the 23 robustness variants at their
  // own seeds and seeds 1-3; README "Registration"): 5334 -> 5349 of 5400 frames within the
  // criteria, along the beam 1.60 -> 1.49 mm (mean of the trials' RMS); the retry runs in 0-12
  // frames of 60 (none on most trials).
  double tracking_retry_inlier_drop = 0.08;
  double tracking_retry_min_inlier_gain = 0.05;
  // A retry of a frame in more doubt than the one before clears the doubt only by fitting about
  // as much of each bone's outline: it replaces the continued result only if no bone's contour
  // inlier fraction falls more than tracking_retry_max_inlier_loss below the continued one's
  // (bones lost there aside; 1 turns this off). Why: a status can rise on a knife edge (the tray's
  // contour RMS 1.005 px against the 1.0 px threshold) while the pose is right, and the full
  // schedule from the same starts may then land on the tray's tilt reflection, status ok at a lower
  // RMS but fitting less of the outline (0.67 against 0.75 of its samples). On a titanium tray
  // (Kneel models, seed 4) tracked from no guess, that retry put the tray 2-3.5 deg off about its
  // anterior axis for 10 frames, every status ok. Measured on 148 tracked trials from frame 0's
  // pose and 79 from no guess (README "Registration"): no frame lost, 15 won.
  double tracking_retry_max_inlier_loss = 0.05;
  // A tracked frame that leaves a bone suspect or lost (after the retries above; also the first
  // frame, from poses the user gave) is registered once more, with the full schedule, from the
  // tracker's start moved across the views by where the bones' contours best meet the frame's
  // edges, up to this far (mm, at the bones' depth; 0: off; see posesShiftedToEdges), and the
  // better result (resultRank) is kept. Why: a knee that
  // travels through a fixed fluoroscope (a step-up, stair descent) moves 10-20 mm between frames
  // at 30 Hz, beyond what a registration from the last frame's poses captures, and on a trial's
  // second frame, or after a lost frame, there is no velocity to predict it from. Simulated
  // (motion: joint_travel_mm 300 mm across the view in 20 frames, 16 mm per frame): 1/20 frames
  // within the criteria without it (the knee lost from frame 1 on), see README "Registration".
  double tracking_shift_search_mm = 60.0;
  // A tracked frame that leaves a bone suspect or lost, and any frame about to be searched, is
  // first tested for showing anything at all (imaging::featurelessFrame): a frame of one grey
  // level, or whose neighbouring pixels differ as much as any two (this ratio or more; 0: off),
  // is given up at once with every bone lost at its last good pose and the tracker's state as it
  // was, so that the next frame is tracked on as if it had not come. Why: the beam off or a
  // read-out fault left the tracker searching for 1-30 s (a noise frame's every speck is a
  // candidate region) while a live node dropped the frames that arrived, and the next frame was
  // searched as well. Radiographs measure 0.007-0.011, pixel noise 1.0 (README "Tracking
  // quality").
  double featureless_noise_ratio = 0.5;
  // A tracker recovering from a lost bone first registers the frame from the last good poses,
  // with the full schedule and mirror check as from poses the user gave, and takes that only if
  // every bone is ok (its recent inlier history included); otherwise it searches the frame. Why:
  // the frame after one the tracker lost (flipped, half black, a bone hidden for a moment) mostly
  // shows the knee where it was, and the search cost 2-5 s there, while a live node dropped the
  // frames that arrived meanwhile (README "Tracking quality").
  bool tracking_recovery_registration = true;
  // A tracked frame after the first frame in doubt (a bone suspect and none lost, after a frame
  // with every bone ok) is registered a second time, from the poses predicted on from the poses
  // before that frame and that frame's own prediction, and that result is kept unless the one
  // from the doubtful poses leaves fewer bones in doubt or fits clearly better (a lower cost and
  // tracking_retry_min_inlier_gain more inlier fraction). Why: near extension a tray fits a
  // mirrored frame turned 10 deg at status ok beside a suspect femur, and the next frames,
  // registered on from that turn, carried the wrong side of the view's ambiguity at status ok for
  // up to 5 frames (README "Tracking quality").
  bool tracking_restart_after_suspect = true;
  // inner_edge_margin_px for a tracked frame registered from the previous frame's result (the
  // frames above) and for its retries. Such a frame starts within a pixel or two of its outlines,
  // where a bone's own inner edges only mislead it (a titanium tray's rim and pocket). From a
  // crude start they are evidence: a tray's far rim, a few pixels inside its outline when the
  // plateau is near edge-on, tells its turn and tilt, and leaving it out lost frames (crude
  // starts on poor images, seed 3: 83 -> 76 %), so inner_edge_margin_px stays 0 (first frames,
  // searches, single-frame registration). The retries start near too. Measured with 2 here
  // (README "Tracking quality"): kneel_titanium_tray 11 -> 60 of 60 frames, and the 92 tracked
  // robustness trials 5349 -> 5353 of 5400.
  double tracking_inner_edge_margin_px = 2.0;
  // How the tracker predicts a frame's start from the last two good frames (predictPoses):
  // each bone at constant velocity, or each joint's child from its parent by the joint's
  // coordinates, flexion and translations at constant velocity and adduction and internal
  // rotation held. Those two are the angles a single view sees least: extrapolated, one frame's
  // error in them becomes the next frame's start and grows (a tibial tray turning 3-7 deg about
  // its stem over a run of frames, status ok). Measured on 23 tracked robustness trials (heavy
  // scatter, titanium at a quarter of the dose, a quarter of the dose, the metal rod, fast
  // motion; five seeds, where it was chosen): 1175 -> 1216 of 1230 frames within the criteria.
  // On 40 held-out trials: 36 -> 25 frames outside, and 18 -> 0 bone poses more than 5 deg off
  // (README "Measured figures").
  enum class TrackingPrediction { kConstantVelocity, kJointCoordinates };
  TrackingPrediction tracking_prediction = TrackingPrediction::kJointCoordinates;
  int solver_iterations = 8;        // Levenberg-Marquardt iterations per outer iteration
  double contour_spacing_px = 1.0;  // contour sample spacing at each scale
  double robust_scale_px = 4.0;     // Cauchy scale, full-resolution pixels
  // The Cauchy scale from the finest scale's second outer iteration on (when the edge offset is
  // freed, see edge_offset_hold), full-resolution pixels; <= 0 (the default): robust_scale_px
  // throughout. A Cauchy loss pulls hardest on residuals at its scale: 4 px lets a start a few
  // pixels off find its edges, but once the contour lies on them it gives most weight to
  // samples that have no edge of their own within a pixel, e.g. a stretch of contour running
  // inside a metal rod, whose borders lie 4-6 px away. Trading the bone's edge offset against
  // its depth (nearly alike for a round outline), such samples carried the femoral component
  // of the simulated occluding-rod trial 8 mm along the beam from its true pose, its offset at
  // -2 px (6.9 mm and -1.4 px with 2 px here). Measured with 2 px (README "Registration"):
  // that trial tracked 56 -> 60 of 60 frames, 22 -> 2 flagged, 3.77 -> 2.19 mm along the beam;
  // crude starts on poor images 86.5 -> 90.0 % (seed 11); the standard protocol and the real
  // Kneel frames' perturbed starts unchanged within a frame. Why it is off: tracking the real
  // Kneel frames shown inverted (bright implants), whose third frame moves 3 mm and 3 deg, the
  // tray then slid out of reach and was lost (3/3 -> 2/3 frames; 2.5 and 3 px the same).
  double robust_scale_final_px = 0.0;
  double roi_margin_px = 60.0;
  // The reverse term (image edges near the projection -> contour): its weight relative to the
  // forward term (0 turns it off) and how far from the projected contour edges are paired.
  double reverse_term_weight = 1.0;
  double reverse_band_px = 8.0;  // edge maps cover the projected bones plus this margin
  // > 0: from the finest scale's second outer iteration on (when the edge offset is freed, see
  // edge_offset_hold), each bone's image terms leave out the edges more than this many
  // full-resolution pixels inside its own projected silhouette (EdgeMap::withoutEdgesIn). A part
  // that attenuates weakly (a titanium tray) shows its inner structure, e.g. the plate's rim and
  // pocket, as edges a few pixels inside its outline, where its true edge against the insert
  // hardly shows; its contour is drawn to them (README "Tracking quality", kneel_titanium_tray).
  // 0 (the default): off; frames the tracker continues from its last result have their own
  // (tracking_inner_edge_margin_px).
  double inner_edge_margin_px = 0.0;
  // A displayed implant edge lies a fraction of a pixel off the geometric silhouette: detector
  // blur acts on intensity before a logarithmic display, and metal thins to nothing at a
  // slanted rim. On a thin part seen edge-on (a tibial tray) half a pixel is millimetres along
  // the beam. kUniform estimates one offset per bone and view (pixels, + inward) along the
  // contour normals, with a zero-mean prior of edge_offset_prior_px; kNone compares the
  // geometric silhouette as it is. Measured (benchmark, 100 frames): out-of-plane RMS 4.8 mm
  // with kNone, 2.0 mm with kUniform.
  // A joint's child moves by its own increment (kAbsolute) or by its increment relative to its
  // parent, so that a step of the parent carries it along (kParentRelative; the dissertation's
  // Dataset B; registration::ParentRelativeCost). One level: a child whose parent is itself a
  // relative child stays absolute.
  enum class Parameterisation { kAbsolute, kParentRelative };
  Parameterisation parameterisation = Parameterisation::kAbsolute;
  enum class EdgeOffsetModel { kNone, kUniform };
  EdgeOffsetModel edge_offset_model = EdgeOffsetModel::kUniform;
  double edge_offset_prior_px = 0.5;  // full-resolution pixels
  // The lowest offset a solve may end on (full-resolution pixels; -inf, the default: no floor),
  // held by a stiff one-sided residual from one outer iteration after the offset is freed, at the
  // finest scale (a solve that converged earlier with an offset below it runs that iteration).
  // Why one would: an offset and a step along the beam change the outline almost alike, so a
  // bone can slide along the beam with its offset, and a tibial tray's thin plate seen edge-on
  // slides farthest (simulated trials with the Kneel study's real implant models, image only: the
  // tray 7.6 mm RMS along the beam, up to 22 mm, with offsets down to -1.2 px), while at the true
  // poses the offsets average 0.15-0.40 px (poses held, offsets solved; lowest -0.2 px). Why it
  // is off: on the real Kneel frames the femoral component's offset is -0.48 px in every start
  // (edges outside its model's outline), which a floor at 0 cannot hold (-0.35 px) and which,
  // with a floor at 0 or -0.5 px, costs the tracked Kneel sequence shown inverted its third frame
  // and the search its bright femoral component in deep flexion (images_to_bag_test,
  // pose_search_test). Measured with a floor of 0 (benchmark, README "Registration"): along the
  // beam, image only, 5.47 -> 3.29 mm on the Kneel implant models, 1.61 -> 1.42 mm on 8
  // generated trials, success unchanged within a frame or two; crude starts on poor images
  // 6.19 -> 4.01 mm but success 86.5 -> 86.0 % (seed 11) and 86 -> 83 % (seed 7); the tracked
  // occluding-rod trial 22 -> 2 frames flagged, 3.78 -> 2.20 mm. The floor joins late because from
  // the outer iteration that frees the offset it cost crude starts 3-5 points. The automatic
  // search's refinements leave it unbounded.
  double edge_offset_min_px = -std::numeric_limits<double>::infinity();
  // Hold the offset at zero until the finest scale's second outer iteration: while the contour
  // is still pixels away, a free offset fits it to whatever edges lie nearby and the pose
  // follows. Measured (benchmark, contact + ligaments): crude starts 78 -> 86 % success, poor
  // images 78 -> 81 %; standard starts unchanged at 95 %, image only 82 -> 87 %. The automatic
  // search's one-bone refinement turns it off (40 frames: 75 % without, 70 % with).
  bool edge_offset_hold = true;
  // Compare the contour near sharp turns where the edge map's smoothing puts the edges
  // (registration::cornerRounding, sigma = edges.blur_sigma_px), at the finest scale once the
  // offset is freed. Measured (benchmark, seeds 3 / 5 / 7 / 11, README "Registration"): along
  // the beam 1.77 -> 1.50 mm RMS and a mean bias 1.15 -> 0.68 mm (seed 7, every term), image
  // only 87 -> 90 % on seed 7; success over all 2,000 frames of the four protocols 1,862 ->
  // 1,859.
  bool corner_rounding = true;
  // Threads a registration may use. With 2 or more, the finer scales' edge maps are built on a
  // second thread while the first scale is solved (registration::EdgeMapPrefetch), and the
  // automatic search (registration::PoseSearch) matches silhouettes and refines its starts on
  // that many; the results are the same as with 1, which a caller running several
  // registrations side by side may prefer.
  int threads = 2;
  RenderedEdgeSettings rendered_edges;
  EdgeOffsetTrackingSettings edge_offset_tracking;
  // Contact penalties join at this outer iteration of the finest scale (0: from the start).
  int contact_from_outer_iteration = 1;
  // Staged schedule. Empty: one stage of outer_iterations x solver_iterations with every term
  // (contact from contact_from_outer_iteration). Otherwise the stages run in order at the
  // finest scale; coarser scales run the first stage.
  std::vector<RegistrationStage> stages;

  // The stages that run: `stages`, or the single default stage.
  std::vector<RegistrationStage> schedule() const;
  // A bone that would end farther than this from its starting pose has diverged (the solver
  // ran down a weakly constrained direction): it is kept at its last plausible pose.
  double max_translation_from_start_m = 0.03;
  double max_rotation_from_start_rad = 0.5;
  // Stop when no bone moves more than this between outer iterations.
  double converged_translation_m = 2e-5;
  double converged_rotation_rad = 2e-4;
  // Estimate each bone's pose covariance at the solution (Ceres' covariance of the last solve,
  // scaled by the residual variance). Costs a few milliseconds per outer iteration.
  bool compute_covariance = false;
  // The covariance's allowance for an edge offset that is not uniform along the outline
  // (full-resolution pixels; 0 leaves it out): the solve fits one offset per bone and view, whose
  // trade-off with the depth its covariance already carries, but a rim's displayed edge lies
  // farther inside where the metal thins or the tissue beside it is darker, so the offset also
  // varies across the outline, and a gradient across it reads as a tilt of the bone. The
  // covariance adds what an unknown gradient of this standard deviation along each of the
  // outline's two principal axes (the offset's change from the outline's centre to its far end)
  // would move the pose by (a "consider" covariance: the gradient is not estimated).
  double covariance_offset_gradient_sd_px = 0.2;
  MirrorCheckSettings mirror_check;
  ReflectionRetrySettings reflection_retry;
  RotationRetrySettings rotation_retry;
  DepthRetrySettings depth_retry;
  imaging::EdgeMapSettings edges;
  QualitySettings quality;

  void validate() const;
};

// YAML / command-line names: none, uniform. Throws InputError for others.
RegistrationSettings::EdgeOffsetModel edgeOffsetModelFromName(const std::string& name);
// "absolute" or "parent_relative"; throws InputError naming the known ones.
RegistrationSettings::Parameterisation parameterisationFromName(const std::string& name);
std::string parameterisationName(RegistrationSettings::Parameterisation parameterisation);
std::string edgeOffsetModelName(RegistrationSettings::EdgeOffsetModel model);
// "constant_velocity" or "joint_coordinates"; throws InputError naming the known ones.
RegistrationSettings::TrackingPrediction trackingPredictionFromName(const std::string& name);
std::string trackingPredictionName(RegistrationSettings::TrackingPrediction prediction);

// Whether a bone could have gone from `from` to `to` in `frames` frames: within the settings'
// per-frame limits (max_translation_from_start_m, max_rotation_from_start_rad) times `frames`.
bool withinMotionLimits(const geometry::Pose& from, const geometry::Pose& to,
                        const RegistrationSettings& settings, int frames = 1);

// A frame as the registrar sees it: one image per view, each with its camera (whose
// worldFromCamera() is the view's pose in the fixed frame).
struct ViewImage {
  cv::Mat image;
  geometry::XrayCamera camera;
};

struct BoneModel {
  std::string name;
  std::shared_ptr<const imaging::SilhouetteModel> silhouette;
  double image_weight = 1.0;
};

// A joint between two of the registrar's bones (indices into its bone list): its anatomical
// frames, and the constraint terms it adds to the registration.
struct JointModel {
  std::string name;
  int parent = -1;
  int child = -1;
  kinematics::Side side = kinematics::Side::kRight;
  // The reported coordinates' system (kinematics::JointType); the registration's own terms
  // (ligament bounds, the mirror check) use the knee's.
  kinematics::JointType type = kinematics::JointType::kKnee;
  // Each bone's anatomical frame in its mesh frame (identity: the mesh frame is anatomical).
  geometry::Pose parent_anatomical = geometry::Pose::Identity();
  geometry::Pose child_anatomical = geometry::Pose::Identity();
  std::shared_ptr<const constraints::ArticularContact> contact;  // none: no contact term
  // The stay-in-contact term used in frames where the joint is loaded (solve's `loaded`).
  std::shared_ptr<const constraints::ArticularContact> loaded_contact;
  constraints::LigamentSettings ligaments;  // enabled = false: no springs

  // The frames, in each bone's mesh frame, whose knee coordinates the registration's own terms
  // (ligament springs, the search's envelope) act on: the anatomical frames turned by
  // kinematics::kneeFrameTurn, so that those coordinates are the type's own but for the first
  // angle's sign (the knee's flexion, reversed for e.g. an ankle's dorsiflexion).
  // A glenohumeral joint's coordinates are an Euler sequence, of no turn of the frames: its
  // knee frames are its anatomical frames, and its springs and envelope use its own angles
  // (reportedCoordinates) instead.
  geometry::Pose parentKneeFrame() const { return parent_anatomical * kneeFrameTurn(); }
  geometry::Pose childKneeFrame() const { return child_anatomical * kneeFrameTurn(); }
  const geometry::Pose& kneeFrameTurn() const {
    static const geometry::Pose identity = geometry::Pose::Identity();
    return kinematics::hasKneeFrameCoordinates(type) ? kinematics::kneeFrameTurn(type) : identity;
  }
  // The knee coordinates (kinematics::kneeCoordinates) of the knee frames of bones at these
  // mesh-frame poses.
  kinematics::KneeCoordinates coordinates(const geometry::Pose& parent_pose,
                                          const geometry::Pose& child_pose) const {
    return kinematics::kneeCoordinates(parent_pose * parentKneeFrame(),
                                       child_pose * childKneeFrame(), side);
  }
  // The coordinates reported to users (CSV, messages), in the joint type's system.
  kinematics::KneeCoordinates reportedCoordinates(const geometry::Pose& parent_pose,
                                                  const geometry::Pose& child_pose) const {
    return kinematics::jointCoordinates(type, parent_pose * parent_anatomical,
                                        child_pose * child_anatomical, side);
  }
  // How far the joint lies outside its ligaments: the largest of its coordinates' distance
  // outside their bounds (deg or mm, envelopeViolation) and its bundles' stretch (mm).
  double envelopeViolation(const geometry::Pose& parent_pose,
                           const geometry::Pose& child_pose) const {
    const double springs =
        type == kinematics::JointType::kGlenohumeral
            ? constraints::glenohumeralEnvelopeViolation(ligaments, parent_pose * parent_anatomical,
                                                         child_pose * child_anatomical, side)
            : registration::envelopeViolation(ligaments, coordinates(parent_pose, child_pose));
    return std::max(springs, constraints::maxStretchMm(ligaments.bundles, parent_pose, child_pose));
  }
};

// A joint at the result: its coordinates and, if it has a contact term, the contact figures.
struct JointResult {
  int parent = -1;  // bone indices
  int child = -1;
  // The knee coordinates of the joint's knee frames (JointModel::coordinates); the ones users
  // see come from JointModel::reportedCoordinates.
  kinematics::KneeCoordinates coordinates;
  JointQuality quality;
  bool has_contact = false;
  constraints::ContactFigures contact;
};

// A Gaussian prior on one bone's edge offset in one view (RegistrationSettings::
// EdgeOffsetModel), in full-resolution pixels: e.g. a tracker's estimate from earlier frames.
struct EdgeOffsetPrior {
  double mean_px = 0.0;
  double sigma_px = 0.5;
};
// Per bone and view.
using EdgeOffsetPriors = std::vector<std::vector<EdgeOffsetPrior>>;

struct RegistrationResult {
  std::vector<geometry::Pose> poses;  // per bone, in the fixed frame
  double final_cost = 0.0;
  int cost_evaluations = 0;
  int solver_iterations = 0;
  int outer_iterations = 0;
  std::vector<int> contour_points;  // per bone, at the finest scale
  // Per bone and view: the estimated edge offset (full-resolution pixels, + inward).
  std::vector<std::vector<double>> edge_offsets_px;
  // Per bone: a step would have carried it out of a view's field (behind the source or wholly
  // outside the image) or beyond the plausible distance from its start; it was kept at its
  // last valid pose and not moved further.
  std::vector<bool> diverged;
  // Per joint of the registrar, at the final poses.
  std::vector<JointResult> joints;
  // With compute_covariance, per bone: the covariance of its pose in the fixed frame, ordered
  // as ROS's PoseWithCovariance (x, y, z in m; rotations about the fixed X, Y, Z in rad), from
  // the last solve: Ceres' covariance scaled by the residual variance and by the contour
  // residuals' correlation along the outline (BoneQuality::residual_correlation_samples), plus
  // the edge offset's unknown gradient (covariance_offset_gradient_sd_px); zero when it could
  // not be computed (covariance_valid false).
  std::vector<Eigen::Matrix<double, 6, 6>> covariances;
  // The second part alone, per bone (same order and units), before it is added in.
  std::vector<Eigen::Matrix<double, 6, 6>> offset_gradient_covariances;
  std::vector<bool> covariance_valid;
  // Per bone, how well the image supports its final pose (see classifyBones).
  std::vector<BoneQuality> quality;
};

// Registers all bones of one frame jointly, in any number of views, from starting poses: the
// dissertation's contour-distance metric minimised with Ceres, coarse to fine, plus each
// joint's articular contact penalty (dissertation ch. 3) and ligament-like springs (ch. 4),
// which tie the joint's two bones into one solve.
class Registrar {
 public:
  // Throws InputError for a bone without a model or a joint naming a missing bone.
  Registrar(std::vector<BoneModel> bones, RegistrationSettings settings,
            std::vector<JointModel> joints = {});

  const std::vector<BoneModel>& bones() const { return bones_; }
  const RegistrationSettings& settings() const { return settings_; }
  const std::vector<JointModel>& joints() const { return joints_; }

  // Throws InputError for a wrong number of poses, no views, non-finite poses, or bad images.
  // `loaded`: per joint, whether it is known to be loaded in this frame (its loaded_contact
  // term then joins); empty: none is. `offset_priors` (per bone and view; empty: the settings'
  // zero-mean edge_offset_prior_px) start each edge offset at its mean and hold it near it.
  // `recent_spreads_px` (a tracked frame's: per bone, the median contour spread of its recent
  // frames, NaN with too few) makes the rotation retry that of a tracked frame
  // (RotationRetrySettings::tracking_spread_rise); empty: a registration from the user's poses.
  RegistrationResult solve(const std::vector<ViewImage>& views,
                           const std::vector<geometry::Pose>& initial_poses,
                           const std::vector<bool>& loaded = {},
                           const EdgeOffsetPriors& offset_priors = {},
                           const std::vector<double>& recent_spreads_px = {}) const;

 private:
  // A registration's poses before its joint figures and image quality are worked out, with
  // what they need: per bone and view, the model points of the finest scale's last contour, and
  // the finest scale's maps.
  struct Solution {
    RegistrationResult result;
    std::vector<std::vector<std::vector<Eigen::Vector3d>>> contour_model_points;
    // Per sample of contour_model_points: which way (map pixels) the edge offset moves it.
    std::vector<std::vector<std::vector<Eigen::Vector2d>>> contour_offset_directions;
    std::vector<imaging::EdgeMap> maps;
    bool abandoned = false;  // stopped by a CandidateGate: not a solution
  };
  // Stops a mirror candidate's solve after an outer iteration that shows it will not be kept
  // (MirrorCheckSettings::abandon_cost_ratio): its cost above max_cost, or its joint's
  // deviation from neutral above max_deviation.
  // After its planned outer iterations, a candidate not yet converged whose cost is at most
  // max_cost and whose deviation is below keep_deviation gets extra_outer_iterations more.
  struct CandidateGate {
    double max_cost;
    std::function<double(const std::vector<geometry::Pose>&)> deviation;
    double max_deviation;
    double keep_deviation;
    int extra_outer_iterations;
  };

  // solve() but FCL's contact separation, which it adds to the solution it returns.
  RegistrationResult solveWithRetries(const std::vector<ViewImage>& views,
                                      const std::vector<geometry::Pose>& initial_poses,
                                      const std::vector<bool>& loaded,
                                      const EdgeOffsetPriors& offset_priors,
                                      const std::vector<double>& recent_spreads_px) const;
  // The reflection retry (ReflectionRetrySettings) of `result`, solved from these arguments;
  // `unchecked` (optional) is the first solution the mirror check replaced with `result`.
  void retryReflections(const std::vector<ViewImage>& views,
                        const std::vector<geometry::Pose>& initial_poses,
                        const std::vector<bool>& loaded, const EdgeOffsetPriors& offset_priors,
                        const RegistrationResult* unchecked, RegistrationResult* result) const;
  // solveFrom, then the mirror check (single view), whose candidates `threads` threads share
  // (1 when the caller's other threads are busy); `finest_maps_out` (optional) receives the
  // finest scale's maps, `unchecked_out` (optional) the first solution if the check replaced it.
  RegistrationResult solveChecked(const std::vector<ViewImage>& views,
                                  const std::vector<geometry::Pose>& initial_poses,
                                  const std::vector<bool>& loaded,
                                  const EdgeOffsetPriors& offset_priors, int threads,
                                  std::vector<imaging::EdgeMap>* finest_maps_out = nullptr,
                                  std::optional<RegistrationResult>* unchecked_out = nullptr) const;
  // The rotation retry (RotationRetrySettings) of `result`, solved from these arguments;
  // `recent_spreads_px` as in solve().
  void retryRotations(const std::vector<ViewImage>& views, const std::vector<bool>& loaded,
                      const EdgeOffsetPriors& offset_priors,
                      const std::vector<double>& recent_spreads_px,
                      RegistrationResult* result) const;
  // Whether the mirror check reflects bone `b` (the child of a knee joint).
  bool mirrorChecked(std::size_t b) const;
  // Two or more views: the frame solved again with each bone in doubt moved by its own contour's
  // shift to the views' edges (DepthRetrySettings::other_views_shift_mm); nothing when no bone
  // moved or the solve threw.
  std::optional<RegistrationResult> solvedFromOtherViewsShifts(
      const std::vector<ViewImage>& views, const std::vector<bool>& loaded,
      const EdgeOffsetPriors& offset_priors, const RegistrationResult& result) const;
  // The depth retry's starts: `poses` with every bone moved along its ray from the first view's
  // source by each of DepthRetrySettings::shifts_mm.
  std::vector<std::vector<geometry::Pose>> depthShifted(
      const std::vector<ViewImage>& views, const std::vector<geometry::Pose>& poses) const;
  // One registration from these starts (solve is this plus the mirror check), finished.
  // `finest_maps` (optional): when it holds maps, only the finest scale runs, on them; when
  // empty, it receives the finest scale's maps.
  RegistrationResult solveFrom(const std::vector<ViewImage>& views,
                               const std::vector<geometry::Pose>& initial_poses,
                               const std::vector<bool>& loaded,
                               const EdgeOffsetPriors& offset_priors,
                               std::vector<imaging::EdgeMap>* finest_maps = nullptr) const;
  // The solve itself; `finest_maps` as in solveFrom, but only read.
  Solution solveUnfinished(const std::vector<ViewImage>& views,
                           const std::vector<geometry::Pose>& initial_poses,
                           const std::vector<bool>& loaded, const EdgeOffsetPriors& offset_priors,
                           const std::vector<imaging::EdgeMap>* finest_maps,
                           const CandidateGate* gate = nullptr) const;
  // Adds each joint's coordinates and figures and each bone's image quality.
  void finish(const std::vector<ViewImage>& views, Solution* solution) const;
  // Per bone, the parent its increment is relative to (settings' parameterisation), else -1:
  // each joint's child whose parent is not itself relative and which carries no relative child.
  std::vector<int> relativeParents(const std::vector<bool>& diverged) const;

  std::vector<BoneModel> bones_;
  RegistrationSettings settings_;
  std::vector<JointModel> joints_;
  std::vector<Eigen::Vector3d> centroids_;  // per bone, mesh frame: the rotation centres
};

}  // namespace registration
}  // namespace fluoro_tracker
