#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/imaging/implant_blobs.h"
#include "fluoro_tracker/imaging/silhouette_library.h"
#include "fluoro_tracker/registration/registrar.h"

namespace fluoro_tracker {
namespace registration {

// The `registration: search:` section of the trial YAML.
struct PoseSearchSettings {
  double direction_step_deg = 15.0;  // silhouette library: spacing of viewing directions
  double roll_step_deg = 10.0;       // rolls about the beam tried per region
  int matches_per_bone = 4;          // best shape matches per bone (over all regions)
  // Joints are also matched as a whole: silhouettes of both bones together across the
  // flexion range (every flexion_step), over viewing directions every direction_step.
  bool joint_silhouettes = true;
  double joint_flexion_step_deg = 15.0;
  double joint_direction_step_deg = 20.0;
  int joint_matches = 4;  // best joint matches whose bones' poses are tried
  // Chamfer matching of each bone's library on the coarse edge map (SilhouetteLibrary::
  // matchEdges) around the candidate regions, at the distances the region matches suggest:
  // finds a bone whose region merged with its neighbour's (the knee in flexion).
  bool edge_matching = true;
  // ... at these fractions of the median hinted distance (a thresholded region is a little
  // smaller than the silhouette, so 7 % nearer as well) ...
  std::vector<double> edge_match_depth_factors = {1.0, 0.93};
  // ... and at these for a bone that no hypothesis fits at QualitySettings::
  // suspect_inlier_fraction after them. A region may be only the darkest (or brightest) core of
  // an implant, so that every hint lies too far from the source: on frames whose regions are
  // only a component's thick parts, or the overlap of metal and bone in a bright display, the
  // whole knee was hinted 15-30 % too far (both bones 110-340 mm along the beam) and nothing
  // nearer was tried. Run for every bone, the nearer distances cost 0.6 s per search (+28 %)
  // and found no more frames over thirteen benchmark seeds than run only for such a bone.
  // Measured with `benchmark --protocol search --trials 4 --frames 10 --conditions
  // contact+ligaments`: see the README ("Automatic initialisation").
  std::vector<double> edge_match_nearer_depth_factors = {0.86, 0.8};
  int edge_matches_per_bone = 6;  // per region
  int edge_match_regions = 2;     // the largest candidate regions are searched
  // A bone that no hypothesis fits at the suspect inlier fraction after the chamfer matching at
  // its regions' distances is matched again at the distance of its joint partner's best-fitting
  // hypothesis (one that fits at least that well) when its regions' distance differs from the
  // partner's by more than this fraction (0: never), around the largest regions and the
  // edge_match_shape_regions regions its silhouettes match best. A joint's bones lie at nearly
  // the same distance from the source; a wire joined to a tray's region misjudged its distance
  // by half (a real Kneel frame with a wire drawn across the tray: 1.5 m against 1.03 m), and
  // there the largest regions were the platform's bands.
  double edge_match_partner_depth_gap = 0.1;
  int edge_match_shape_regions = 2;
  double edge_roll_step_deg = 15.0;
  double edge_position_step_px = 3.0;  // screening-scale pixels
  // Every start (matches, their mirrors, envelope samples) is screened by how much of its
  // contour lies on the edges of the frame at this scale; the best few are refined.
  double screening_scale = 0.25;
  int refined_per_bone = 4;
  // ... and the best few by a wider tolerance (screening-scale pixels) as well: a start 5-15 deg
  // and 5-15 mm off (from the joint's envelope, in deep flexion) has little of its contour
  // within one coarse pixel of an edge, and starts that lie on other edges outscore it.
  // Measured with `benchmark --protocol search` (40 frames, contact + ligaments): no guess
  // succeeded in 77.5 -> 85 % (seed 7) and 85 -> 90 % (seed 11) at about 0.4 s more per frame;
  // three such starts (82.5 %) or a single tolerance of 2 for all (72.5 %) did worse.
  double wide_screening_px = 2.0;
  int wide_refined_per_bone = 2;
  // ... and this many more of a bone's starts from its neighbour through the joint's envelope
  // when none of its hypotheses so far reaches QualitySettings::suspect_inlier_fraction: the
  // femoral component merged with the tray in flexion has no hypothesis of its own, and envelope
  // starts at a wrong flexion (its round condyles stay on their edges as it turns about them)
  // outscored the one 5 mm and 5 deg off (22nd of 721). Those refined for it are kept only
  // where they fit (suspect_inlier_fraction): kept all, their wrong poses crowded the right
  // combination out of the finalists. Measured with `benchmark --protocol search --trials 4
  // --frames 10 --conditions contact+ligaments`, seeds 3 / 5 / 7 / 11 and held-out 13 / 17:
  // 0 148 of 160 and 77 of 80, 10 151 and 78, 20 151 and 78; held-out 19 / 23, 66 and 65 of 80
  // with 0 and 10 (a turn reflection flipped).
  int envelope_extra_refined = 10;
  // A bone that still has no hypothesis fitting suspect_inlier_fraction after those starts,
  // beside a neighbour with one that fits at least `fine_envelope_neighbour_inliers`, is searched
  // again from the neighbour's well-fitting hypotheses, and from their tilt, turn and full
  // reflections across the beam (which fit as well when the neighbour is seen nearly edge-on),
  // through a finer envelope: flexion every `fine_envelope_flexion_step_deg` and anterior
  // translation every `fine_envelope_anterior_step_mm` (10 deg and 10 mm above), with
  // envelope_extra_refined more of those starts refined. The envelope's other coordinates sit at
  // their middles, so its starts are a few degrees off the bone's true turn and tilt anyway; the
  // finer steps bring one within the refinement's reach (a bright femoral component against its
  // bone, beside a tray found at 0.998, whose nearest start was 2-5 mm and 7-13 deg off: the
  // benchmark's no-guess trials, seed 17, trial 3, frame 6; and beside a tray found only at its
  // tilt reflection: seed 13, trial 2, frame 8). It runs only where the search would otherwise
  // end with that bone unfound. Measured with `benchmark --protocol search`: see the README
  // ("Automatic initialisation").
  bool fine_envelope = true;
  double fine_envelope_flexion_step_deg = 5.0;
  double fine_envelope_anterior_step_mm = 5.0;
  double fine_envelope_neighbour_inliers = 0.9;
  // Distances from the source at which a bone may be: a region whose size would put the bone
  // outside them is not that bone (it is a marker, a fragment, or another object).
  double min_depth_m = 0.2;
  double max_depth_m = 2.0;
  // Each match is also tried mirrored through the plane across the beam: a nearly symmetric
  // implant seen nearly edge-on has two poses with almost the same silhouette.
  bool mirror_hypotheses = true;
  // Refinement of each hypothesis, one bone at a time: coarse to fine, so that a start a few
  // degrees and millimetres off converges.
  std::vector<double> refine_scales = {0.25, 0.5, 1.0};
  double refine_robust_scale_px = 16.0;  // Cauchy scale of the refinement, full-resolution px
  // Canny's automatic high threshold for the search's edge maps (screening and refinement), as
  // a fraction of the region's 99.5th-percentile gradient (imaging::EdgeMapSettings::
  // auto_high_fraction, whose default it shares). The search works on the grey-level
  // window without local equalisation, where an implant's strong rim against soft tissue sets
  // the threshold and its weaker rims against bone can drop out: a bright femoral component's
  // box in deep flexion, whose coarse refinement then slides tens of millimetres along the
  // beam. Lower it for such images, not for cluttered ones. Measured with `benchmark --protocol
  // search --conditions contact+ligaments` (100 frames per seed, seeds 7 / 11): 0.3 89 / 93 %,
  // 0.15 95 / 94 %; but with 0.15 `scripts/robustness_benchmark.sh --no-guess lab_clutter`
  // (marker beads) lost its first 8 frames (52/60 against 60/60), so the default stays 0.3.
  double edge_high_fraction = 0.3;
  // A second pass when the first leaves any bone not ok (classifyBones) or finds no pose for
  // one: the whole search again with Canny's high threshold at this fraction, keeping the pass
  // whose result has the better statuses, then the better score. A frame the default
  // threshold serves (clutter) is searched once and keeps its result; a bright implant whose
  // faint rims the default loses gets the lower threshold. 0: no second pass.
  double retry_edge_high_fraction = 0.15;
  // When the result still leaves a bone suspect or lost, the final joint registration is solved
  // again from it with every bone moved along its line of sight to each of these fractions of
  // its distance from the source (its projected place kept, its size changed by 1 / factor),
  // and the one with the fewest bones in doubt, then the best score, replaces the result if
  // fewer of its bones are in doubt. The registrar's own depth retry moves one registration's
  // start by 15 mm; a search's result can settle 30-90 mm along the beam with both bones (a
  // region's size misjudged), in a false minimum that a start a few per cent nearer or farther
  // leaves. Empty: none. Measured with
  // `benchmark --protocol search --trials 4 --frames 10 --conditions contact+ligaments`: see
  // the README ("Automatic initialisation").
  std::vector<double> rescue_depth_factors = {0.91, 0.94, 0.97, 1.03, 1.06, 1.09};
  // Choosing among the refined hypotheses: each bone's contour inlier fraction, minus these
  // per unit of a joint's ligament envelope violation (deg or mm) and penetration (mm).
  double envelope_penalty_per_unit = 0.02;
  double penetration_penalty_per_mm = 0.05;
  // ... and, among the jointly registered finalists, per unit of neutralDeviation.
  double neutral_penalty_per_unit = 0.05;
  int finalists = 3;  // best combinations registered jointly before the final choice
  imaging::ImplantBlobSettings blobs;

  void validate() const;  // throws InputError naming the field
};

// What a search found and how sure it is.
struct PoseSearchResult {
  RegistrationResult registration;  // the final joint registration from the chosen hypotheses
  std::vector<std::string> status;  // per bone, classifyBones of that registration
  int regions = 0;                  // candidate implant regions found in the first view
  int hypotheses = 0;               // poses refined
  // The chosen combination's contour inlier fractions minus its joints' penalties (envelope,
  // penetration, neutral deviation), as the search ranks its finalists.
  double score = 0.0;
  int passes = 1;  // 2 when the retry pass ran (PoseSearchSettings::retry_edge_high_fraction)
  // The rescue's factor whose registration was kept (PoseSearchSettings::rescue_depth_factors);
  // 1 when the search's own result was.
  double rescue_depth_factor = 1.0;
  double seconds = 0.0;
};

// Automatic initialisation: finds every bone's pose in a frame with no guess (the dissertation's
// open problem). Candidate implant regions are found in the first view (imaging::
// findImplantBlobs) and matched against each bone's silhouette library (orientation and roll),
// their area and place giving distance and position; the best matches per bone, with their
// mirror hypotheses and any seed poses (e.g. the last good poses when tracking was lost), are
// refined one bone at a time; the combination of hypotheses that best explains the image while
// keeping each joint inside its ligament envelope and out of penetration is registered jointly
// with the full registrar. Libraries are built once, at construction (about a second per bone).
class PoseSearch {
 public:
  // Throws InputError for invalid settings.
  PoseSearch(std::shared_ptr<const Registrar> registrar, PoseSearchSettings settings = {});

  const PoseSearchSettings& settings() const { return settings_; }

  // `seeds`: extra starting poses per bone (fixed frame), tried besides the image's hypotheses;
  // empty or one per bone. Throws InputError for unusable views or seeds.
  PoseSearchResult search(const std::vector<ViewImage>& views,
                          const std::vector<geometry::Pose>& seeds = {}) const;

 private:
  std::shared_ptr<const Registrar> registrar_;
  PoseSearchSettings settings_;
  std::vector<std::unique_ptr<imaging::SilhouetteLibrary>> libraries_;  // per bone
  // The edge settings of one pass of the search and its single-bone refiners (per bone).
  struct EdgePass {
    imaging::EdgeMapSettings edges;  // the refiners' edges, also for screening
    std::vector<std::unique_ptr<Registrar>> refiners;
  };
  std::vector<EdgePass> passes_;  // the first pass, then the retry pass if configured
  // Per joint: the child's pose in the parent's mesh frame across the envelope.
  std::vector<std::vector<geometry::Pose>> envelope_;
  // ... and at the finer steps (PoseSearchSettings::fine_envelope), built on the first frame
  // that needs them (rarely: about a second of contact queries per joint).
  mutable std::once_flag fine_envelope_built_;
  mutable std::vector<std::vector<geometry::Pose>> fine_envelope_;
  struct JointLibrary {
    std::size_t joint;
    geometry::Pose child_in_parent;
    std::unique_ptr<imaging::SilhouetteLibrary> library;
  };
  std::vector<JointLibrary> joint_libraries_;

  // `found` solved again from its poses moved along the lines of sight
  // (PoseSearchSettings::rescue_depth_factors) when a bone is not ok; the better is returned.
  PoseSearchResult rescueAlongSightLines(const std::vector<ViewImage>& views,
                                         PoseSearchResult found) const;
  // Per joint, the child's pose in the parent's mesh frame across the finer envelope.
  const std::vector<std::vector<geometry::Pose>>& fineEnvelope() const;
  // A joint's penalty in the search's scores: envelope violation and penetration.
  double jointPenalty(double envelope_violation, double penetration_m) const;
  // How a jointly registered result ranks among the finalists: its bones' contour inlier
  // fractions minus its joints' penalties and neutral deviation.
  double finalistScore(const RegistrationResult& registered) const;
  // One pass of the search with `pass`'s edges, over the first view's candidate regions.
  PoseSearchResult searchPass(const EdgePass& pass, const std::vector<ViewImage>& views,
                              const std::vector<geometry::Pose>& seeds,
                              const std::vector<imaging::ImplantBlob>& blobs) const;
};

}  // namespace registration
}  // namespace fluoro_tracker
