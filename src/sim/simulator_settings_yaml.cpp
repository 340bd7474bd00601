// Fills TrialSimulatorSettings from YAML: the one place where simulator keys are named.
#include <filesystem>

#include <yaml-cpp/yaml.h>

#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/io/yaml_file.h"
#include "fluoro_tracker/sim/trial_simulator.h"

namespace fluoro_tracker {
namespace sim {

TrialSimulatorSettings loadSimulatorSettings(const std::string& path) {
  const YAML::Node root = io::loadYamlFile(path, "simulator settings");
  TrialSimulatorSettings s;
  const io::YamlSection r(root, "simulator settings '" + path + "'");
  r.allowOnly({"image_width",
               "image_height",
               "principal_distance_mm",
               "pixel_spacing_mm",
               "source_to_joint_mm",
               "principal_point_offset_px",
               "views",
               "view_separation_deg",
               "view_yaw_deg",
               "view_roll_deg",
               "femoral_material",
               "tray_material",
               "insert_material",
               "anatomy",
               "occluder_rod_radius_mm",
               "occluder_material",
               "marker_grid_spacing_mm",
               "marker_radius_mm",
               "marker_plane_from_source_mm",
               "marker_material",
               "platform_top_below_joint_mm",
               "platform_width_mm",
               "platform_material",
               "seed",
               "start_stamp_s",
               "side",
               "contralateral_knee",
               "lens_distortion",
               "motion",
               "detector",
               "implants",
               "implant_meshes"});
  r.read("image_width", &s.image_width);
  r.read("image_height", &s.image_height);
  r.read("principal_distance_mm", &s.principal_distance_mm);
  r.read("pixel_spacing_mm", &s.pixel_spacing_mm);
  r.read("source_to_joint_mm", &s.source_to_joint_mm);
  r.read("views", &s.views);
  r.read("view_separation_deg", &s.view_separation_deg);
  r.read("view_yaw_deg", &s.view_yaw_deg);
  r.read("view_roll_deg", &s.view_roll_deg);
  r.read("femoral_material", &s.femoral_material);
  r.read("tray_material", &s.tray_material);
  r.read("insert_material", &s.insert_material);
  r.read("anatomy", &s.anatomy);
  r.read("occluder_rod_radius_mm", &s.occluder_rod_radius_mm);
  r.read("occluder_material", &s.occluder_material);
  r.read("marker_grid_spacing_mm", &s.marker_grid_spacing_mm);
  r.read("marker_radius_mm", &s.marker_radius_mm);
  r.read("marker_plane_from_source_mm", &s.marker_plane_from_source_mm);
  r.read("marker_material", &s.marker_material);
  r.read("platform_top_below_joint_mm", &s.platform_top_below_joint_mm);
  r.read("platform_width_mm", &s.platform_width_mm);
  r.read("platform_material", &s.platform_material);
  r.read("seed", &s.seed);
  r.read("start_stamp_s", &s.start_stamp_s);
  std::string side = kinematics::sideName(s.side);
  r.read("side", &side);
  try {
    s.side = kinematics::sideFromName(side);
  } catch (const InputError& e) {
    throw InputError("simulator settings '" + path + "'.side: " + e.what());
  }

  // An [x, y] or [x, y, z] list into a fixed-size Eigen vector.
  const auto read_vector = [&path](const io::YamlSection& section, const std::string& key,
                                   const std::string& where, auto* value) {
    const auto size = static_cast<std::size_t>(value->size());
    std::vector<double> list(value->data(), value->data() + size);
    section.read(key, &list);
    if (list.size() != size) {
      throw InputError("simulator settings '" + path + "'." + where + key + " must be " +
                       (size == 2 ? "[x, y]" : "[x, y, z]"));
    }
    for (std::size_t i = 0; i < size; ++i) (*value)(static_cast<Eigen::Index>(i)) = list[i];
  };

  read_vector(r, "principal_point_offset_px", "", &s.principal_point_offset_px);

  const io::YamlSection other = r.child("contralateral_knee");
  other.allowOnly({"kind", "offset_mm", "travel_mm", "phase"});
  std::string kind = "none";
  other.read("kind", &kind);
  try {
    s.contralateral_knee.kind = contralateralKindFromName(kind);
  } catch (const InputError& e) {
    throw InputError("simulator settings '" + path + "'.contralateral_knee.kind: " + e.what());
  }
  read_vector(other, "offset_mm", "contralateral_knee.", &s.contralateral_knee.offset_mm);
  read_vector(other, "travel_mm", "contralateral_knee.", &s.contralateral_knee.travel_mm);
  other.read("phase", &s.contralateral_knee.phase);

  const io::YamlSection lens = r.child("lens_distortion");
  lens.allowOnly({"model", "coefficients"});
  lens.read("model", &s.lens_distortion.model);
  lens.read("coefficients", &s.lens_distortion.coefficients);

  const io::YamlSection m = r.child("motion");
  m.allowOnly({"frames", "frame_rate_hz", "start_flexion_deg", "max_flexion_deg",
               "internal_rotation_at_max_deg", "rollback_at_max_mm", "adduction_amplitude_deg",
               "shank_inclination_ratio", "joint_travel_mm"});
  m.read("frames", &s.motion.frames);
  m.read("frame_rate_hz", &s.motion.frame_rate_hz);
  m.read("start_flexion_deg", &s.motion.start_flexion_deg);
  m.read("max_flexion_deg", &s.motion.max_flexion_deg);
  m.read("internal_rotation_at_max_deg", &s.motion.internal_rotation_at_max_deg);
  m.read("rollback_at_max_mm", &s.motion.rollback_at_max_mm);
  m.read("adduction_amplitude_deg", &s.motion.adduction_amplitude_deg);
  m.read("shank_inclination_ratio", &s.motion.shank_inclination_ratio);
  read_vector(m, "joint_travel_mm", "motion.", &s.motion.joint_travel_mm);

  const io::YamlSection d = r.child("detector");
  d.allowOnly({"photons_per_pixel", "blur_sigma_px", "scatter_strength", "scatter_sigma_mm",
               "window_max_attenuation", "window_min_attenuation", "implants_bright", "bit_depth",
               "collimator_radius_fraction", "collimator_attenuation"});
  d.read("photons_per_pixel", &s.detector.photons_per_pixel);
  d.read("blur_sigma_px", &s.detector.blur_sigma_px);
  d.read("scatter_strength", &s.detector.scatter_strength);
  d.read("scatter_sigma_mm", &s.detector.scatter_sigma_mm);
  d.read("window_max_attenuation", &s.detector.window_max_attenuation);
  d.read("window_min_attenuation", &s.detector.window_min_attenuation);
  d.read("implants_bright", &s.detector.implants_bright);
  d.read("bit_depth", &s.detector.bit_depth);
  d.read("collimator_radius_fraction", &s.detector.collimator_radius_fraction);
  d.read("collimator_attenuation", &s.detector.collimator_attenuation);

  const io::YamlSection i = r.child("implants");
  i.allowOnly({"width_mm", "distal_radius_mm", "posterior_radius_mm", "lateral_condyle_offset_mm",
               "condyle_coronal_radius_mm", "condyle_track_mm", "tray_ap_mm", "tray_ml_mm",
               "insert_thickness_mm", "dish_depth_mm", "eminence_height_mm", "box_width_mm",
               "post_width_mm", "post_length_mm", "post_height_mm", "post_offset_mm"});
  i.read("width_mm", &s.implants.width_mm);
  i.read("distal_radius_mm", &s.implants.distal_radius_mm);
  i.read("posterior_radius_mm", &s.implants.posterior_radius_mm);
  i.read("lateral_condyle_offset_mm", &s.implants.lateral_condyle_offset_mm);
  i.read("condyle_coronal_radius_mm", &s.implants.condyle_coronal_radius_mm);
  i.read("condyle_track_mm", &s.implants.condyle_track_mm);
  i.read("tray_ap_mm", &s.implants.tray_ap_mm);
  i.read("tray_ml_mm", &s.implants.tray_ml_mm);
  i.read("insert_thickness_mm", &s.implants.insert_thickness_mm);
  i.read("dish_depth_mm", &s.implants.dish_depth_mm);
  i.read("eminence_height_mm", &s.implants.eminence_height_mm);
  i.read("box_width_mm", &s.implants.box_width_mm);
  i.read("post_width_mm", &s.implants.post_width_mm);
  i.read("post_length_mm", &s.implants.post_length_mm);
  i.read("post_height_mm", &s.implants.post_height_mm);
  i.read("post_offset_mm", &s.implants.post_offset_mm);

  // Component models from files: paths relative to this file's folder, each placed by its
  // component_from_mesh pose (see ImplantMeshFiles).
  const io::YamlSection meshes = r.child("implant_meshes");
  meshes.allowOnly({"units", "femoral_component", "tibial_tray", "tibial_insert"});
  if (const YAML::Node node = root["implant_meshes"]) {
    const std::string context = "simulator settings '" + path + "' implant_meshes";
    const std::string base = std::filesystem::absolute(path).parent_path().string();
    if (node["units"]) {
      s.implant_meshes.units =
          geometry::parseLengthUnit(io::required<std::string>(node, "units", context), context);
    }
    const auto readFile = [&](const char* key, ImplantMeshFile* file) {
      const YAML::Node component = node[key];
      if (!component) return;
      const std::string where = context + "." + key;
      io::YamlSection(component, where).allowOnly({"path", "component_from_mesh"});
      file->path = io::resolvePath(base, io::required<std::string>(component, "path", where));
      if (const YAML::Node pose = component["component_from_mesh"]) {
        file->component_from_mesh = io::readYamlPose(pose, where + ".component_from_mesh");
      }
    };
    readFile("femoral_component", &s.implant_meshes.femoral_component);
    readFile("tibial_tray", &s.implant_meshes.tibial_tray);
    readFile("tibial_insert", &s.implant_meshes.tibial_insert);
  }

  try {
    s.validate();
  } catch (const InputError& e) {
    throw InputError("simulator settings '" + path + "': " + e.what());
  }
  return s;
}

}  // namespace sim
}  // namespace fluoro_tracker
