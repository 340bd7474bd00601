#include "fluoro_tracker/geometry/pose.h"

#include <algorithm>
#include <cmath>

#include <Eigen/SVD>

namespace fluoro_tracker {
namespace geometry {

Pose makePose(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation) {
  Pose pose = Pose::Identity();
  pose.linear() = rotation;
  pose.translation() = translation;
  return pose;
}

Pose makePose(const Eigen::Quaterniond& rotation, const Eigen::Vector3d& translation) {
  return makePose(rotation.normalized().toRotationMatrix(), translation);
}

Pose normalized(const Pose& pose) {
  // The nearest rotation (Frobenius norm): U·V^T of the SVD, with the sign fixed for det = +1.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(pose.linear(),
                                              Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  if ((u * svd.matrixV().transpose()).determinant() < 0.0) u.col(2) *= -1.0;
  return makePose(Eigen::Matrix3d(u * svd.matrixV().transpose()), pose.translation());
}

bool isValidPose(const Pose& pose, double tolerance) {
  if (!pose.matrix().allFinite()) return false;
  const Eigen::Matrix3d r = pose.linear();
  const double orthogonality_error =
      (r * r.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orthogonality_error > tolerance) return false;
  return std::abs(r.determinant() - 1.0) <= tolerance;
}

double degToRad(double degrees) {
  return degrees * M_PI / 180.0;
}
double radToDeg(double radians) {
  return radians * 180.0 / M_PI;
}

Eigen::Matrix3d rotationX(double angle) {
  return Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitX()).toRotationMatrix();
}
Eigen::Matrix3d rotationY(double angle) {
  return Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitY()).toRotationMatrix();
}
Eigen::Matrix3d rotationZ(double angle) {
  return Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

Eigen::Matrix3d rotationFromEulerZXY(const EulerZXY& a) {
  return rotationZ(a.z) * rotationX(a.x) * rotationY(a.y);
}

EulerZXY eulerZXYFromRotation(const Eigen::Matrix3d& r) {
  // R = Rz Rx Ry:
  //   r21 = sin x,  r01 = -sin z cos x,  r11 = cos z cos x,
  //   r20 = -cos x sin y,  r22 = cos x cos y.
  EulerZXY a;
  a.x = std::asin(std::clamp(r(2, 1), -1.0, 1.0));
  if (std::abs(r(2, 1)) < 1.0 - 1e-12) {
    a.z = std::atan2(-r(0, 1), r(1, 1));
    a.y = std::atan2(-r(2, 0), r(2, 2));
  } else {
    // Gimbal lock: only z + y (or z - y) is determined; put it all in z.
    a.y = 0.0;
    a.z = std::atan2(r(1, 0), r(0, 0));
  }
  return a;
}

Eigen::Matrix3d rotationFromEulerXYZ(const EulerXYZ& a) {
  return rotationX(a.x) * rotationY(a.y) * rotationZ(a.z);
}

EulerXYZ eulerXYZFromRotation(const Eigen::Matrix3d& r) {
  // R = Rx Ry Rz: r02 = sin y, r12 = -sin x cos y, r22 = cos x cos y, r01 = -cos y sin z,
  // r00 = cos y cos z.
  EulerXYZ a;
  a.y = std::asin(std::clamp(r(0, 2), -1.0, 1.0));
  if (std::abs(r(0, 2)) < 1.0 - 1e-12) {
    a.x = std::atan2(-r(1, 2), r(2, 2));
    a.z = std::atan2(-r(0, 1), r(0, 0));
  } else {
    a.z = 0.0;
    a.x = std::atan2(r(2, 1), r(1, 1));
  }
  return a;
}

double rotationAngleBetween(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle();
}

Pose jointTrackToOptical() {
  return makePose(Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal().toDenseMatrix(),
                  Eigen::Vector3d::Zero());
}

}  // namespace geometry
}  // namespace fluoro_tracker
