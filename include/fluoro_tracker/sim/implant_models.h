#pragma once

#include <string>

#include "fluoro_tracker/geometry/length_unit.h"
#include "fluoro_tracker/geometry/mesh.h"
#include "fluoro_tracker/geometry/pose.h"

namespace fluoro_tracker {
namespace sim {

// Synthetic total-knee components of realistic size, generated in code so that the demo and
// tests need no download. Lengths in metres. Frames follow the ISB convention used by the
// trial YAML: X anterior, Y superior, Z to the right (lateral for a right knee).
//
// Femoral component (femur frame): origin on the flexion axis, the centre of the posterior
// condylar arcs. A J-curved shell ~70 mm wide: anterior flange, distal and posterior condyles
// with a trochlear groove / intercondylar notch, inner box cuts (anterior, chamfers, distal,
// posterior), and a slightly smaller lateral condyle so that views are not mirror images. Each
// condyle is rounded in the coronal plane about its track, 21 mm from the midline.
//
// Tibial tray (tibia frame): origin at the centre of the tray's top surface; a 4 mm plate with a
// posterior cruciate notch and a 36 mm stem. Tibial insert: polyethylene on the tray, 10 mm
// thick, with two dished condylar tracks (the lateral one shallower by the lateral condyle's
// offset, so both condyles bear load) and a low central eminence that the femoral component's
// intercondylar region clears; nearly invisible in X-ray, it carries the contact.
struct KneeImplantSet {
  geometry::Mesh femoral_component;
  geometry::Mesh tibial_tray;
  geometry::Mesh tibial_insert;
  // The insert is the generated one, whose articular surface insertSurfaceHeight() describes.
  bool insert_generated = true;
};

struct KneeImplantDimensions {
  double width_mm = 70.0;                   // medial-lateral width of the femoral component
  double distal_radius_mm = 25.0;           // articular radius, distal and anterior
  double posterior_radius_mm = 23.0;        // articular radius, posterior condyles
  double lateral_condyle_offset_mm = 1.0;   // lateral condyle smaller by this much
  double condyle_coronal_radius_mm = 30.0;  // condyles' radius in the coronal plane; 0: flat
  double condyle_track_mm = 21.0;  // each condyle's (and insert track's) distance from midline
  double tray_ap_mm = 48.0;
  double tray_ml_mm = 74.0;
  double insert_thickness_mm = 10.0;
  double dish_depth_mm = 3.0;
  double eminence_height_mm = 1.5;  // insert's central eminence above the tracks' bottoms
};

KneeImplantSet makeKneeImplants(const KneeImplantDimensions& dimensions = {});

// A component's model read from a file (e.g. a vendor's CAD) instead of generated, and where its
// mesh frame lies in the component's frame above (`component_from_mesh`: a mesh point v is at
// component_from_mesh * v, metres); empty path: generated.
struct ImplantMeshFile {
  std::string path;
  geometry::Pose component_from_mesh = geometry::Pose::Identity();
};

struct ImplantMeshFiles {
  ImplantMeshFile femoral_component;
  ImplantMeshFile tibial_tray;
  // Without one the generated insert is used (shaped by KneeImplantDimensions: set tray_ap_mm,
  // tray_ml_mm, condyle_track_mm and lateral_condyle_offset_mm to fit the other components).
  ImplantMeshFile tibial_insert;
  geometry::LengthUnit units = geometry::LengthUnit::kMillimetre;

  bool any() const {
    return !femoral_component.path.empty() || !tibial_tray.path.empty() ||
           !tibial_insert.path.empty();
  }
};

// The generated set with each component that `files` names loaded and placed instead. Throws
// InputError naming the file for one that cannot be loaded (Mesh::load).
KneeImplantSet makeKneeImplants(const KneeImplantDimensions& dimensions,
                                const ImplantMeshFiles& files);

// Height (m, tibia frame) of the insert's articular surface above (x, z) (m), and whether
// (x, z) lies over the insert.
double insertSurfaceHeight(const KneeImplantDimensions& dimensions, double x, double z);
bool isOverInsert(const KneeImplantDimensions& dimensions, double x, double z);

}  // namespace sim
}  // namespace fluoro_tracker
