#pragma once

#include <string>
#include <vector>

#include "fluoro_tracker/kinematics/knee_coordinates.h"

namespace fluoro_tracker {
namespace io {

// One row of the public kinematics CSV (docs: interfaces.md), one per joint per frame:
//   frame,stamp,joint,flexion_deg,adduction_deg,internal_rotation_deg,x_mm,y_mm,z_mm,status
// The angles and translations are kinematics::KneeCoordinates (Grood & Suntay; see there for
// the axes and signs), or for another joint type its own angles in the same columns
// (kinematics::inJointConvention); status is the worse of the two bones' (ok, suspect, lost).
struct KinematicsRecord {
  int frame = 0;
  double stamp = 0.0;
  std::string joint;
  kinematics::KneeCoordinates coordinates;
  std::string status = "ok";
};

extern const char kKinematicsCsvHeader[];

// Throws InputError naming the file if it cannot be written.
void writeKinematicsCsv(const std::string& path, const std::vector<KinematicsRecord>& records);
// Reads a kinematics CSV; columns after `status` are ignored. Throws InputError naming the file
// and line for a wrong header or a malformed row.
std::vector<KinematicsRecord> readKinematicsCsv(const std::string& path);

}  // namespace io
}  // namespace fluoro_tracker
