#include "fluoro_tracker/sim/trial_simulator.h"

#include <cmath>
#include <filesystem>

#include "fluoro_tracker/imaging/material.h"
#include "fluoro_tracker/imaging/renderer.h"
#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/sim/mesh_builder.h"

namespace fluoro_tracker {
namespace sim {
namespace {

using geometry::Mesh;
using geometry::Pose;

// Point of the tibia frame (m) placed on the first beam's axis at source_to_joint: between the
// tray and the femoral flexion axis.
const Eigen::Vector3d kJointCentreInTibia(0.0, 0.02, 0.0);

Mesh ellipticCylinderM(double ap_mm, double ml_mm, double y0_mm, double y1_mm) {
  return cylinderY(ap_mm, ml_mm, y0_mm, y1_mm, 64).scaled(1e-3);
}

// Mirrors through the ISB sagittal plane (mesh Z, medial-lateral).
constexpr int kMedialLateralAxis = 2;

KneeImplantSet implantsForSide(const KneeImplantSet& right, kinematics::Side side) {
  if (side == kinematics::Side::kRight) return right;
  KneeImplantSet left = right;
  left.femoral_component = right.femoral_component.mirrored(kMedialLateralAxis);
  left.tibial_tray = right.tibial_tray.mirrored(kMedialLateralAxis);
  left.tibial_insert = right.tibial_insert.mirrored(kMedialLateralAxis);
  return left;
}

// The left knee's pose of a bone whose right-knee pose is `right` (both in the first view's
// optical frame): the bone mirrored through its sagittal plane and the scene through the
// plane of the beam and the image's vertical axis (x = 0), so that the joint stays on the
// beam and is seen from the other side. Two reflections make a rotation.
Pose leftFromRight(const Pose& right) {
  const Eigen::Matrix3d across_image = Eigen::Vector3d(-1.0, 1.0, 1.0).asDiagonal();
  const Eigen::Matrix3d sagittal = Eigen::Vector3d(1.0, 1.0, -1.0).asDiagonal();
  return geometry::makePose(across_image * right.linear() * sagittal,
                            across_image * right.translation());
}

kinematics::Side otherSide(kinematics::Side side) {
  return side == kinematics::Side::kRight ? kinematics::Side::kLeft : kinematics::Side::kRight;
}

}  // namespace

void ContralateralKnee::validate() const {
  if (!offset_mm.allFinite() || !travel_mm.allFinite() || !std::isfinite(phase)) {
    throw InputError(
        "simulator: contralateral_knee: offset_mm, travel_mm and phase must be finite");
  }
}

ContralateralKnee::Kind contralateralKindFromName(const std::string& name) {
  if (name == "none") return ContralateralKnee::Kind::kNone;
  if (name == "natural") return ContralateralKnee::Kind::kNatural;
  if (name == "implanted") return ContralateralKnee::Kind::kImplanted;
  throw InputError("contralateral_knee kind '" + name + "' is not one of none, natural, implanted");
}

TrialSimulatorSettings::TrialSimulatorSettings() {
  // Image-intensifier look: a round field whose corners are collimated off.
  detector.collimator_radius_fraction = 1.08;
}

void varyBenchmarkTrial(int trial, std::mt19937_64* rng, TrialSimulatorSettings* settings) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  settings->motion.max_flexion_deg = 60.0 + 60.0 * unit(*rng);
  settings->view_yaw_deg = -8.0 + 16.0 * unit(*rng);
  settings->view_roll_deg = -5.0 + 10.0 * unit(*rng);
  settings->detector.implants_bright = trial % 2 == 1;
}

void TrialSimulatorSettings::validate() const {
  if (image_width < 16 || image_height < 16)
    throw InputError("simulator: image size must be >= 16");
  if (!(principal_distance_mm > 0.0) || !(pixel_spacing_mm > 0.0)) {
    throw InputError("simulator: principal_distance_mm and pixel_spacing_mm must be > 0");
  }
  if (!(source_to_joint_mm > 100.0) || source_to_joint_mm >= principal_distance_mm) {
    throw InputError("simulator: source_to_joint_mm must be > 100 and < principal_distance_mm");
  }
  if (views != 1 && views != 2) throw InputError("simulator: views must be 1 or 2");
  if (!principal_point_offset_px.allFinite() ||
      std::abs(principal_point_offset_px.x()) >= 0.5 * image_width ||
      std::abs(principal_point_offset_px.y()) >= 0.5 * image_height) {
    throw InputError("simulator: principal_point_offset_px must be finite and within the image");
  }
  for (const auto& m : {femoral_material, tray_material, insert_material, occluder_material,
                        marker_material, platform_material}) {
    imaging::materialByName(m);
  }
  if (!(occluder_rod_radius_mm >= 0.0)) {
    throw InputError("simulator: occluder_rod_radius_mm must be >= 0");
  }
  if (!(marker_grid_spacing_mm >= 0.0) || !(marker_radius_mm > 0.0) ||
      (marker_grid_spacing_mm > 0.0 && marker_grid_spacing_mm <= 2.0 * marker_radius_mm)) {
    throw InputError(
        "simulator: marker_grid_spacing_mm must be >= 0 (0: none) and more than the beads' "
        "diameter, marker_radius_mm > 0");
  }
  // Only a grid that is drawn needs a plane: a shorter source-detector distance alone must not
  // trip over the unused default.
  if (marker_grid_spacing_mm > 0.0 && (!(marker_plane_from_source_mm > 0.0) ||
                                       !(marker_plane_from_source_mm < principal_distance_mm))) {
    throw InputError(
        "simulator: marker_plane_from_source_mm must lie between the source and the detector");
  }
  if (!(platform_width_mm >= 0.0) || !std::isfinite(platform_top_below_joint_mm)) {
    throw InputError(
        "simulator: platform_width_mm must be >= 0 (0: none) and platform_top_below_joint_mm "
        "finite");
  }
  implants.validate();
  for (const ImplantMeshFile* file : {&implant_meshes.femoral_component,
                                      &implant_meshes.tibial_tray, &implant_meshes.tibial_insert}) {
    if (!geometry::isValidPose(file->component_from_mesh)) {
      throw InputError("simulator: implant_meshes: the pose of '" + file->path +
                       "' is not a finite rigid transform");
    }
  }
  lens_distortion.validate("simulator: lens_distortion");
  contralateral_knee.validate();
  motion.validate();
  detector.validate();
}

TrialSimulator::TrialSimulator(const TrialSimulatorSettings& settings)
    : settings_(settings),
      right_implants_(makeKneeImplants(settings.implants, settings.implant_meshes)),
      implants_(implantsForSide(right_implants_, settings.side)),
      contralateral_implants_(settings.contralateral_knee.kind != ContralateralKnee::Kind::kNone
                                  ? implantsForSide(right_implants_, otherSide(settings.side))
                                  : KneeImplantSet{}),
      contact_(right_implants_, settings.implants) {
  settings_.detector.pixel_spacing_mm = settings_.pixel_spacing_mm;
  settings_.validate();
  const double focal = settings_.principal_distance_mm / settings_.pixel_spacing_mm;
  const double cx = 0.5 * (settings_.image_width - 1) + settings_.principal_point_offset_px.x();
  const double cy = 0.5 * (settings_.image_height - 1) + settings_.principal_point_offset_px.y();
  const auto view_count = static_cast<std::size_t>(settings_.views);
  fixed_frame_ = io::fixedFrameId(view_count);
  if (view_count == 1) {
    const std::string name = io::fluoroViewName(0, 1);
    views_.push_back({name,
                      geometry::XrayCamera(settings_.image_width, settings_.image_height, focal,
                                           focal, cx, cy, io::opticalFrameId(name)),
                      settings_.lens_distortion});
  } else {
    // The second beam turns about the vertical (image y) axis through the joint centre.
    const Eigen::Vector3d pivot(0.0, 0.0, 1e-3 * settings_.source_to_joint_mm);
    const Pose turn = Eigen::Translation3d(pivot) *
                      Eigen::AngleAxisd(geometry::degToRad(settings_.view_separation_deg),
                                        Eigen::Vector3d::UnitY()) *
                      Eigen::Translation3d(-pivot);
    for (std::size_t v = 0; v < view_count; ++v) {
      const std::string name = io::fluoroViewName(v, view_count);
      geometry::XrayCamera camera(settings_.image_width, settings_.image_height, focal, focal, cx,
                                  cy, io::opticalFrameId(name));
      camera.setWorldFromCamera(v == 0 ? Pose::Identity() : turn);
      views_.push_back({name, camera, settings_.lens_distortion});
    }
  }

  for (const SimulatedView& view : views_) {
    distortion_maps_.push_back(view.distortion.distorts()
                                   ? std::optional<imaging::LensMaps>(
                                         imaging::distortionMaps(view.camera, view.distortion))
                                   : std::nullopt);
  }

  if (settings_.anatomy) {
    const double soft = imaging::materialByName("soft_tissue").attenuation_per_mm;
    const double cortical = imaging::materialByName("cortical_bone").attenuation_per_mm;
    const double cancellous = imaging::materialByName("cancellous_bone").attenuation_per_mm;
    // Tissue volumes are added on top of the soft-tissue background, so each uses its excess
    // attenuation over soft tissue. Shafts are tubes: cortex minus a marrow core.
    anatomy_.push_back({ellipticCylinderM(55, 60, -20, 400), true, soft});   // thigh
    anatomy_.push_back({ellipticCylinderM(48, 46, -400, 20), false, soft});  // shank
    anatomy_.push_back({ellipticCylinderM(16, 33, -14, 60), true,
                        cancellous - soft});  // distal femur, inside the box cuts
    anatomy_.push_back(
        {ellipticCylinderM(15, 15, 60, 400), true, cortical - soft});               // femoral shaft
    anatomy_.push_back({ellipticCylinderM(9, 9, 60, 400), true, soft - cortical});  // marrow
    anatomy_.push_back(
        {ellipticCylinderM(24, 36, -55, -4), false, cancellous - soft});  // tibial plateau
    anatomy_.push_back(
        {ellipticCylinderM(15, 15, -400, -55), false, cortical - soft});  // tibial shaft
    anatomy_.push_back({ellipticCylinderM(9, 9, -400, -55), false, soft - cortical});  // marrow
  }
  placeLabObjects();
}

void TrialSimulator::placeLabObjects() {
  const Pose fixed_from_camera = views_.front().camera.worldFromCamera();
  const double joint_z = 1e-3 * settings_.source_to_joint_mm;
  if (settings_.occluder_rod_radius_mm > 0.0) {
    // A 400 mm rod along Y, turned to run diagonally across the first view 15 mm below the
    // joint centre (over the tibial tray), 60 mm nearer the source than the joint.
    const double r = 1e-3 * settings_.occluder_rod_radius_mm;
    const Pose camera_from_rod = geometry::makePose(geometry::rotationZ(geometry::degToRad(55.0)),
                                                    Eigen::Vector3d(0.0, 0.015, joint_z - 0.06));
    lab_objects_.push_back(
        {cylinderY(r, r, -0.2, 0.2, 24), fixed_from_camera * camera_from_rod,
         imaging::materialByName(settings_.occluder_material).attenuation_per_mm});
  }
  if (settings_.marker_grid_spacing_mm > 0.0) {
    // The grid spans the field of view at its plane (plus one spacing), centred on the beam.
    const double z = 1e-3 * settings_.marker_plane_from_source_mm;
    const double scale = z / (1e-3 * settings_.principal_distance_mm);
    const double half_w = 0.5e-3 * settings_.image_width * settings_.pixel_spacing_mm * scale;
    const double half_h = 0.5e-3 * settings_.image_height * settings_.pixel_spacing_mm * scale;
    const double spacing = 1e-3 * settings_.marker_grid_spacing_mm;
    const Mesh bead = uvSphere(1e-3 * settings_.marker_radius_mm, 8, 16);
    Mesh grid;
    for (double x = -std::floor(half_w / spacing) * spacing; x <= half_w + 1e-9; x += spacing) {
      for (double y = -std::floor(half_h / spacing) * spacing; y <= half_h + 1e-9; y += spacing) {
        grid.append(bead.transformed(
            geometry::makePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(x, y, z))));
      }
    }
    lab_objects_.push_back({std::move(grid), fixed_from_camera,
                            imaging::materialByName(settings_.marker_material).attenuation_per_mm});
  }
  if (settings_.platform_width_mm > 0.0) {
    // Camera y points down the image: the slab hangs below its top edge, 600 mm wide across
    // the view and 300 mm deep, tilted 3 deg about the beam.
    const double depth = 0.3;
    const double top = 1e-3 * settings_.platform_top_below_joint_mm;
    const Mesh slab = box(Eigen::Vector3d(0.3, 0.5 * depth, 0.5e-3 * settings_.platform_width_mm));
    const Pose camera_from_slab =
        geometry::makePose(geometry::rotationZ(geometry::degToRad(3.0)),
                           Eigen::Vector3d(0.0, top + 0.5 * depth, joint_z));
    lab_objects_.push_back(
        {slab, fixed_from_camera * camera_from_slab,
         imaging::materialByName(settings_.platform_material).attenuation_per_mm});
  }
}

TrialSimulator::BonePoses TrialSimulator::kneeBonesAt(int index) const {
  const KneeFramePose knee = kneePoseAt(settings_.motion, index, contact_);
  // Lateral view of the tibia: anterior to the image left, superior up, the beam along the
  // medial-lateral axis; the shank inclines as the knee flexes, and the beam is a few degrees
  // off pure lateral so that the two condyles do not project exactly onto each other.
  Eigen::Matrix3d lateral;
  lateral << -1, 0, 0, 0, -1, 0, 0, 0, 1;
  const Eigen::Matrix3d rotation =
      geometry::rotationY(geometry::degToRad(settings_.view_yaw_deg)) *
      geometry::rotationX(geometry::degToRad(settings_.view_roll_deg)) * lateral *
      geometry::rotationZ(geometry::degToRad(knee.shank_inclination_deg));
  const Eigen::Vector3d joint(0.0, 0.0, 1e-3 * settings_.source_to_joint_mm);
  BonePoses bones;
  bones.flexion_deg = knee.flexion_deg;
  bones.tibia = geometry::makePose(rotation, joint - rotation * kJointCentreInTibia);
  bones.femur = bones.tibia * knee.tibia_from_femur;
  if (settings_.side == kinematics::Side::kLeft) {
    const Pose fixed_from_camera = views_.front().camera.worldFromCamera();
    const Pose camera_from_fixed = fixed_from_camera.inverse();
    bones.tibia = fixed_from_camera * leftFromRight(camera_from_fixed * bones.tibia);
    bones.femur = fixed_from_camera * leftFromRight(camera_from_fixed * bones.femur);
  }
  return bones;
}

TrialSimulator::BonePoses TrialSimulator::contralateralBonesAt(int index) const {
  const ContralateralKnee& other = settings_.contralateral_knee;
  const int n = frameCount();
  const long ahead = std::lround(other.phase * n);
  const int cycle_index = static_cast<int>(((index + ahead) % n + n) % n);
  const BonePoses tracked = kneeBonesAt(cycle_index);
  // Mirrored through the plane across the first beam at the joint: the far leg, facing the
  // same way. Reflecting the scene and the mesh (its sagittal plane) makes a rotation.
  const Eigen::Matrix3d across_beam = Eigen::Vector3d(1.0, 1.0, -1.0).asDiagonal();
  const Eigen::Matrix3d sagittal = Eigen::Vector3d(1.0, 1.0, -1.0).asDiagonal();
  const Eigen::Vector3d joint(0.0, 0.0, 1e-3 * settings_.source_to_joint_mm);
  const double progress = n > 1 ? static_cast<double>(index) / (n - 1) - 0.5 : 0.0;
  const Eigen::Vector3d shift = 1e-3 * (other.offset_mm + progress * other.travel_mm) +
                                jointTravelAt(settings_.motion, index);
  const Pose fixed_from_camera = views_.front().camera.worldFromCamera();
  const Pose camera_from_fixed = fixed_from_camera.inverse();
  const auto mirrored = [&](const Pose& fixed_from_bone) {
    const Pose camera_from_bone = camera_from_fixed * fixed_from_bone;
    return fixed_from_camera *
           geometry::makePose(
               across_beam * camera_from_bone.linear() * sagittal,
               across_beam * (camera_from_bone.translation() - joint) + joint + shift);
  };
  return {mirrored(tracked.femur), mirrored(tracked.tibia), tracked.flexion_deg};
}

SimulatedFrame TrialSimulator::truth(int index) const {
  if (index < 0 || index >= frameCount()) {
    throw InputError("simulator: frame " + std::to_string(index) + " is outside 0.." +
                     std::to_string(frameCount() - 1));
  }
  const BonePoses bones = kneeBonesAt(index);
  SimulatedFrame frame;
  frame.index = index;
  frame.stamp_s = settings_.start_stamp_s + index / settings_.motion.frame_rate_hz;
  frame.flexion_deg = bones.flexion_deg;
  frame.tibia = bones.tibia;
  frame.femur = bones.femur;
  const Eigen::Vector3d travel = jointTravelAt(settings_.motion, index);
  if (!travel.isZero()) {
    const Pose fixed_from_camera = views_.front().camera.worldFromCamera();
    const Pose moved =
        fixed_from_camera * Eigen::Translation3d(travel) * fixed_from_camera.inverse();
    frame.tibia = moved * frame.tibia;
    frame.femur = moved * frame.femur;
  }
  return frame;
}

void TrialSimulator::appendKnee(const KneeImplantSet& implants, bool implanted,
                                const Pose& camera_from_femur, const Pose& camera_from_tibia,
                                std::vector<imaging::RenderObject>* objects) const {
  if (implanted) {
    objects->push_back({&implants.femoral_component, camera_from_femur,
                        imaging::materialByName(settings_.femoral_material).attenuation_per_mm});
    objects->push_back({&implants.tibial_tray, camera_from_tibia,
                        imaging::materialByName(settings_.tray_material).attenuation_per_mm});
    objects->push_back({&implants.tibial_insert, camera_from_tibia,
                        imaging::materialByName(settings_.insert_material).attenuation_per_mm});
  } else {
    // The natural condyles: the femoral component's shape, filled with cancellous bone.
    objects->push_back({&implants.femoral_component, camera_from_femur,
                        imaging::materialByName("cancellous_bone").attenuation_per_mm});
  }
  // The anatomy's parts are symmetric about their sagittal plane: the same meshes serve either
  // side.
  for (const auto& part : anatomy_) {
    objects->push_back({&part.mesh, part.on_femur ? camera_from_femur : camera_from_tibia,
                        part.attenuation_per_mm});
  }
}

cv::Mat TrialSimulator::lineIntegral(int index, int view) const {
  const SimulatedFrame frame = truth(index);
  const SimulatedView& v = views_.at(view);
  const Pose camera_from_fixed = v.camera.worldFromCamera().inverse();
  const Pose camera_from_femur = camera_from_fixed * frame.femur;
  const Pose camera_from_tibia = camera_from_fixed * frame.tibia;
  std::vector<imaging::RenderObject> objects;
  appendKnee(implants_, true, camera_from_femur, camera_from_tibia, &objects);
  const ContralateralKnee::Kind other = settings_.contralateral_knee.kind;
  if (other != ContralateralKnee::Kind::kNone) {
    const BonePoses bones = contralateralBonesAt(index);
    appendKnee(contralateral_implants_, other == ContralateralKnee::Kind::kImplanted,
               camera_from_fixed * bones.femur, camera_from_fixed * bones.tibia, &objects);
  }
  for (const LabObject& object : lab_objects_) {
    objects.push_back({&object.mesh, camera_from_fixed * object.pose, object.attenuation_per_mm});
  }
  return imaging::Renderer::lineIntegral(v.camera, objects);
}

SimulatedFrame TrialSimulator::render(int index, std::mt19937_64* rng) const {
  SimulatedFrame frame = truth(index);
  for (int v = 0; v < static_cast<int>(views_.size()); ++v) {
    cv::Mat image = imaging::formRadiograph(lineIntegral(index, v), settings_.detector, rng);
    if (distortion_maps_[v]) image = imaging::remapThroughLens(image, *distortion_maps_[v]);
    frame.images.push_back(std::move(image));
  }
  return frame;
}

void TrialSimulator::writeModels(const std::string& directory) const {
  std::filesystem::create_directories(directory);
  implants_.femoral_component.save(directory + "/femoral_component.stl");
  implants_.tibial_tray.save(directory + "/tibial_tray.stl");
  implants_.tibial_insert.save(directory + "/tibial_insert.stl");
}

io::TrialConfig TrialSimulator::trialConfig(const std::string& model_directory) const {
  const SimulatedFrame first = truth(0);
  io::TrialConfig config;
  config.fixed_frame = fixed_frame_;
  io::BoneConfig femur;
  femur.name = kFemur;
  femur.mesh = model_directory + "/femoral_component.stl";
  femur.initial_pose = first.femur;
  io::BoneConfig tibia;
  tibia.name = kTibia;
  tibia.mesh = model_directory + "/tibial_tray.stl";
  tibia.articular_mesh = model_directory + "/tibial_insert.stl";
  tibia.initial_pose = first.tibia;
  config.bones = {femur, tibia};
  io::JointConfig knee;
  knee.name = "knee";
  knee.parent = kFemur;
  knee.child = kTibia;
  knee.type = "knee";
  knee.side = settings_.side;
  config.joints = {knee};
  return config;
}

}  // namespace sim
}  // namespace fluoro_tracker
