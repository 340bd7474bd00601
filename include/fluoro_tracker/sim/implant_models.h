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
  // Posterior-stabilised design (the dissertation's chapter 3 implant type) when box_width_mm >
  // 0: the femoral component's condyles are separate from kBoxStartDeg around the condylar arc
  // on, leaving an open intercondylar box this wide, and the insert carries a post (an
  // elliptic cylinder standing at its rim height) that rises into the box. The box's side walls
  // are the condyles' inner faces: in a 16 mm box the default post has 1 mm of medial-lateral
  // play each side (room for the simulated motion's varus-valgus and axial turns), so contact
  // holds the joint's medial-lateral position where the dished tracks of the
  // cruciate-retaining design (0, the default: no box, no post) barely do. No cam, so past
  // about 100 deg of flexion the post leaves the box behind the posterior condyles; rollback is
  // the motion's own.
  double box_width_mm = 0.0;
  double post_width_mm = 14.0;   // medial-lateral
  double post_length_mm = 10.0;  // anterior-posterior
  double post_height_mm = 12.0;  // above the insert's rim
  // The post's centre, anterior (+) of the tray's centre. The simulated motion turns the femur
  // about its own flexion axis's midpoint, which rolls back 6 mm (KneeMotionSettings): a post
  // centred there keeps its play through 12 deg of axial rotation; one at the tray's centre
  // would meet the box's walls in deep flexion.
  double post_offset_mm = -6.0;

  bool posteriorStabilised() const { return box_width_mm > 0.0; }
  // Throws InputError naming the field (e.g. tracks beyond the component's half width, a post
  // wider than its box).
  void validate() const;
};

// Where the posterior-stabilised femoral component's box opens: this far around the condylar
// arc from anterior (0) through distal (90 deg); the anterior flange and trochlea before it span
// the full width.
constexpr double kBoxStartDeg = 50.0;

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
