#pragma once

#include <Eigen/Geometry>

namespace fluoro_tracker {
namespace geometry {

// A rigid transform T_a_b: maps coordinates in frame b to frame a (p_a = T_a_b * p_b).
// Translations are in whatever length unit the caller uses; the ROS layer and the public
// files use metres, JointTrack files use millimetres.
using Pose = Eigen::Isometry3d;

Pose makePose(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation);
Pose makePose(const Eigen::Quaterniond& rotation, const Eigen::Vector3d& translation);

// The pose with its rotation replaced by the nearest rotation matrix (SVD), to stop
// round-off from accumulating over long chains of compositions.
Pose normalized(const Pose& pose);

// True if every element of the transform is finite and its rotation is orthonormal
// (within tolerance) with determinant +1.
bool isValidPose(const Pose& pose, double tolerance = 1e-6);

double degToRad(double degrees);
double radToDeg(double radians);

// Elementary rotations (right-handed, angle in radians).
Eigen::Matrix3d rotationX(double angle);
Eigen::Matrix3d rotationY(double angle);
Eigen::Matrix3d rotationZ(double angle);

// JointTrack's JT_EULER_312 convention: body-fixed rotations about z, then x, then y,
// i.e. R = Rz(z) * Rx(x) * Ry(y). Angles in radians.
struct EulerZXY {
  double z = 0.0;
  double x = 0.0;
  double y = 0.0;
};
Eigen::Matrix3d rotationFromEulerZXY(const EulerZXY& angles);
// Inverse of rotationFromEulerZXY with x in [-pi/2, pi/2]. At gimbal lock (|x| = pi/2) the
// split between z and y is not unique; y is then set to zero.
EulerZXY eulerZXYFromRotation(const Eigen::Matrix3d& rotation);

// Body-fixed x-y-z (Cardan) angles: R = Rx(x) * Ry(y) * Rz(z), radians, y in [-pi/2, pi/2].
struct EulerXYZ {
  double x = 0.0;
  double y = 0.0;
  double z = 0.0;
};
Eigen::Matrix3d rotationFromEulerXYZ(const EulerXYZ& angles);
EulerXYZ eulerXYZFromRotation(const Eigen::Matrix3d& rotation);

// Angle of the relative rotation between a and b (radians, in [0, pi]).
double rotationAngleBetween(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);

// Rotation that maps JointTrack's camera frame (x right, y up, z toward the X-ray source, so
// objects lie at negative z) into the ROS optical frame of the same fluoroscope (x right,
// y down, z from the source toward the detector): a half turn about x, diag(1, -1, -1).
// A pose T_jt_bone therefore becomes T_optical_bone = jointTrackToOptical() * T_jt_bone.
// The transform is its own inverse.
Pose jointTrackToOptical();

}  // namespace geometry
}  // namespace fluoro_tracker
