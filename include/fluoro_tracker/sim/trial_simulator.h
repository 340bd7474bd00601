#pragma once

#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "fluoro_tracker/geometry/mesh.h"
#include "fluoro_tracker/geometry/xray_camera.h"
#include "fluoro_tracker/imaging/detector_model.h"
#include "fluoro_tracker/imaging/lens_distortion.h"
#include "fluoro_tracker/imaging/renderer.h"
#include "fluoro_tracker/io/fluoro_view.h"
#include "fluoro_tracker/io/trial_config.h"
#include "fluoro_tracker/kinematics/knee_coordinates.h"
#include "fluoro_tracker/sim/implant_models.h"
#include "fluoro_tracker/sim/knee_motion.h"

namespace fluoro_tracker {
namespace sim {

// The other knee in the field, as a lateral view of gait or a step-up shows the far leg passing
// the tracked one: the tracked knee's mirror image through the body's sagittal plane (across the
// first view's beam, so both face the same way in the image), its flexion cycle `phase` of a
// cycle ahead, its joint centre `offset_mm` from the tracked one's (first view's camera frame;
// z < 0 nearer the source, magnified more) and moving `travel_mm` relative to it over the trial
// (from minus half at the first frame to plus half at the last), on top of the tracked knee's
// own travel. Only rendered: the trial's truth, models and YAML are the tracked knee's.
struct ContralateralKnee {
  enum class Kind {
    kNone,
    kNatural,    // bone only: its condyles (the femoral component's shape in cancellous bone),
                 // plateau, shafts and soft tissue
    kImplanted,  // a bilateral total knee: the same components, mirrored
  };
  Kind kind = Kind::kNone;
  Eigen::Vector3d offset_mm = Eigen::Vector3d(0.0, 0.0, -180.0);
  Eigen::Vector3d travel_mm = Eigen::Vector3d(-250.0, 0.0, 0.0);
  double phase = 0.5;

  void validate() const;
};

// "none", "natural", "implanted"; throws InputError naming the accepted values.
ContralateralKnee::Kind contralateralKindFromName(const std::string& name);

struct TrialSimulatorSettings {
  int image_width = 1024;
  int image_height = 1024;
  double principal_distance_mm = 1200.0;  // source to detector
  double pixel_spacing_mm = 0.38;
  double source_to_joint_mm = 1000.0;
  // Where the beam's central ray meets the detector, from the image's centre (pixels, x right,
  // y down): real calibrations place it off centre. The knee stays on the central ray.
  Eigen::Vector2d principal_point_offset_px = Eigen::Vector2d::Zero();
  int views = 1;                      // 1: single plane; 2: bi-plane
  double view_separation_deg = 55.0;  // angle between the two beams (bi-plane)
  double view_yaw_deg = 4.0;          // beam off the pure lateral direction, about vertical
  double view_roll_deg = 2.0;         // and about the beam's horizontal axis
  std::string femoral_material = "cocr";
  std::string tray_material = "cocr";
  std::string insert_material = "polyethylene";
  bool anatomy = true;  // bone shafts, metaphyses and soft tissue around the implants
  // A metal rod fixed in the lab (like the antenna of the dissertation's Dataset B) crossing the
  // view diagonally in front of the tibial component; radius 0: none.
  double occluder_rod_radius_mm = 0.0;
  std::string occluder_material = "cocr";
  // Lab clutter that real frames carry. Metal marker beads on a square grid fixed in the lab
  // across the whole field (e.g. an image intensifier's distortion-correction grid, or markers
  // on a calibration frame), in a plane across the first view's beam this far from the source;
  // spacing 0: none.
  double marker_grid_spacing_mm = 0.0;
  double marker_radius_mm = 1.0;
  double marker_plane_from_source_mm = 1150.0;
  std::string marker_material = "cocr";
  // The top edge of a platform or table the subject stands on, seen edge-on: a slab whose top
  // crosses the first view (tilted 3 deg) this far below the joint centre, its width along the
  // beam, fixed in the lab; width 0: none.
  double platform_top_below_joint_mm = 70.0;
  double platform_width_mm = 0.0;
  std::string platform_material = "polyethylene";
  // The knee's side. A left knee is the right one's mirror image (components mirrored through
  // their sagittal plane, the same clinical motion), seen from the other side: with the beam
  // still along medial-lateral, anterior points to the image right instead of the left.
  kinematics::Side side = kinematics::Side::kRight;
  ContralateralKnee contralateral_knee;
  // An image intensifier's distortion left in the frames (and written to camera_info), e.g.
  // {plumb_bob, [k1, 0, 0, 0, 0]}; none by default.
  imaging::LensDistortion lens_distortion;
  KneeMotionSettings motion;
  imaging::DetectorSettings detector;
  KneeImplantDimensions implants;
  // Components read from files instead of generated (see ImplantMeshFiles).
  ImplantMeshFiles implant_meshes;
  std::uint64_t seed = 1;
  double start_stamp_s = 100.0;  // stamp of frame 0 (bags cannot hold time 0)

  TrialSimulatorSettings();
  void validate() const;
};

// Loads settings from a YAML file (see config/simulate_knee.yaml); keys not given keep their
// defaults. Throws InputError naming the file and key.
TrialSimulatorSettings loadSimulatorSettings(const std::string& path);

// The benchmarks' spread of trials: trial `trial`'s deepest flexion (60-120 deg), its view's yaw
// (+-8 deg) and roll (+-5 deg) drawn from `rng` in that order, and implants shown bright in odd
// trials. The rest of `settings` is left as it is.
void varyBenchmarkTrial(int trial, std::mt19937_64* rng, TrialSimulatorSettings* settings);

// "fluoro" (single plane) or "fluoro1", "fluoro2"; worldFromCamera() is the pose in the
// trial's fixed frame.
using SimulatedView = io::FluoroView;

struct SimulatedFrame {
  int index = 0;
  double stamp_s = 0.0;
  double flexion_deg = 0.0;
  geometry::Pose femur = geometry::Pose::Identity();  // in the fixed frame, metres
  geometry::Pose tibia = geometry::Pose::Identity();
  std::vector<cv::Mat> images;  // one per view (empty when only poses were asked for)
};

// Simulates a single- or bi-plane fluoroscopy trial of a total knee moving through a flexion
// cycle with the femur resting on the insert, and renders each frame.
class TrialSimulator {
 public:
  static constexpr const char* kFemur = "femur";
  static constexpr const char* kTibia = "tibia";

  explicit TrialSimulator(const TrialSimulatorSettings& settings);

  const TrialSimulatorSettings& settings() const { return settings_; }
  const KneeImplantSet& implants() const { return implants_; }
  const std::vector<SimulatedView>& views() const { return views_; }
  // "fluoro_optical" for a single view, "lab" for bi-plane (the first view's optical frame).
  const std::string& fixedFrame() const { return fixed_frame_; }
  int frameCount() const { return settings_.motion.frames; }

  // True poses of frame `index` without rendering.
  SimulatedFrame truth(int index) const;
  // True poses and the rendered images of frame `index`. Noise comes from `rng`.
  SimulatedFrame render(int index, std::mt19937_64* rng) const;
  // Line integral (attenuation) image of frame `index` in one view, before the detector.
  cv::Mat lineIntegral(int index, int view) const;

  // Writes femoral_component.stl, tibial_tray.stl and tibial_insert.stl (mm) into `directory`.
  void writeModels(const std::string& directory) const;
  // The trial YAML content for models written by writeModels() into `model_directory`, with the
  // true first-frame poses as initial poses.
  io::TrialConfig trialConfig(const std::string& model_directory) const;

 private:
  struct AnatomyPart {
    geometry::Mesh mesh;
    bool on_femur;
    double attenuation_per_mm;
  };

  struct BonePoses {
    geometry::Pose femur;
    geometry::Pose tibia;
    double flexion_deg = 0.0;
  };
  // The tracked knee's bones at frame `index` in the fixed frame, before the joint's travel.
  BonePoses kneeBonesAt(int index) const;
  // The contralateral knee's bones at frame `index` in the fixed frame (see ContralateralKnee).
  BonePoses contralateralBonesAt(int index) const;
  // A knee's render objects, posed in a view's camera frame: `implants` (or, not `implanted`, its
  // femoral component's shape in cancellous bone as natural condyles) and the anatomy.
  void appendKnee(const KneeImplantSet& implants, bool implanted,
                  const geometry::Pose& camera_from_femur, const geometry::Pose& camera_from_tibia,
                  std::vector<imaging::RenderObject>* objects) const;

  TrialSimulatorSettings settings_;
  // The motion and the contact that settles it are modelled on a right knee; a left trial
  // renders and hands out the mirror images (implants_).
  KneeImplantSet right_implants_;
  KneeImplantSet implants_;
  // The other side's components, for a contralateral knee.
  KneeImplantSet contralateral_implants_;
  KneeContactSolver contact_;
  std::vector<AnatomyPart> anatomy_;
  // Objects fixed in the lab (rod, marker grid, platform): mesh, pose in the fixed frame.
  struct LabObject {
    geometry::Mesh mesh;
    geometry::Pose pose;
    double attenuation_per_mm;
  };
  std::vector<LabObject> lab_objects_;

  void placeLabObjects();
  std::vector<SimulatedView> views_;
  // Per view, the maps that put its lens distortion into a frame (none: a pinhole view).
  std::vector<std::optional<imaging::LensMaps>> distortion_maps_;
  std::string fixed_frame_;
};

}  // namespace sim
}  // namespace fluoro_tracker
