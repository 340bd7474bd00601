#pragma once

#include <memory>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "../test_support.h"
#include "fluoro_tracker/geometry/mesh.h"
#include "fluoro_tracker/io/jointtrack_calibration.h"
#include "fluoro_tracker/io/jts_file.h"
#include "fluoro_tracker/registration/registrar.h"

namespace fluoro_tracker {
namespace test_support {

// The real JointTrack Kneel study in ../shared/data: its three frames (clinical fluoroscopy:
// table edges, soft tissue, a marker plate), each with its camera and the lab's reference
// poses (femoral component, tibial tray; optical frame), and a registrar for its knee.
struct KneelStudy {
  struct Frame {
    std::string name;
    cv::Mat image;  // empty if it could not be read
    geometry::XrayCamera camera;
    std::vector<geometry::Pose> reference;
  };
  std::vector<Frame> frames;
  std::shared_ptr<const registration::Registrar> registrar;

  KneelStudy() {
    const std::string dir = sharedData("jointtrack_kneel/");
    const auto calibration = io::readJointTrackCalibration(dir + "calibration.txt");
    const geometry::Mesh femur = geometry::Mesh::load(dir + "KR_right_7_fem.stl");
    const geometry::Mesh tibia = geometry::Mesh::load(dir + "KR_right_6_tib.stl");
    const auto femur_poses = io::readJtsFile(dir + "fem.jts");
    const auto tibia_poses = io::readJtsFile(dir + "tib.jts");
    // The knee's envelope with flexion free: these meshes' medial-lateral axes point the other
    // way, so their flexion comes out negative; no insert, so no contact.
    registration::JointModel knee;
    knee.name = "knee";
    knee.parent = 0;
    knee.child = 1;
    knee.ligaments.bounds[0] = {-180.0, 180.0};
    registrar = std::make_shared<const registration::Registrar>(
        std::vector<registration::BoneModel>{
            {"femur", std::make_shared<imaging::SilhouetteModel>(femur), 1.0},
            {"tibia", std::make_shared<imaging::SilhouetteModel>(tibia), 1.0}},
        registration::RegistrationSettings(), std::vector<registration::JointModel>{knee});
    for (const std::string name : {"0160", "0170", "0180"}) {
      const std::size_t f = frames.size();
      Frame frame;
      frame.name = name;
      frame.image = cv::imread(dir + "AT_K1_V1_" + name + ".tif", cv::IMREAD_UNCHANGED);
      if (!frame.image.empty()) {
        frame.camera = io::cameraFromJointTrack(calibration, frame.image.cols, frame.image.rows);
      }
      frame.reference = {io::opticalFromJointTrack(*femur_poses[f]),
                         io::opticalFromJointTrack(*tibia_poses[f])};
      frames.push_back(std::move(frame));
    }
  }
};

}  // namespace test_support
}  // namespace fluoro_tracker
