// The only translation unit that instantiates Ceres' automatic differentiation.
#include "fluoro_tracker/registration/ligament_cost.h"

#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>

namespace fluoro_tracker {
namespace registration {
namespace {

// A frame moved by an increment [w, t] about centre c: R' = R(w) R, o' = R(w)(o - c) + c + t.
template <typename T>
void movedFrame(const geometry::Pose& frame, const Eigen::Vector3d& centre, const T* increment,
                Eigen::Matrix<T, 3, 3>* rotation, Eigen::Matrix<T, 3, 1>* origin) {
  T r[9];  // column-major
  ceres::AngleAxisToRotationMatrix(increment, ceres::ColumnMajorAdapter3x3(r));
  const Eigen::Map<const Eigen::Matrix<T, 3, 3>> delta(r);
  *rotation = delta * frame.linear().cast<T>();
  const Eigen::Matrix<T, 3, 1> offset = (frame.translation() - centre).cast<T>();
  *origin = delta * offset + centre.cast<T>() +
            Eigen::Matrix<T, 3, 1>(increment[3], increment[4], increment[5]);
}

struct KneeLigamentResiduals {
  constraints::LigamentSettings settings;
  kinematics::Side side;
  geometry::Pose parent_frame;
  Eigen::Vector3d parent_centre;
  geometry::Pose child_frame;
  Eigen::Vector3d child_centre;

  template <typename T>
  bool operator()(const T* parent_increment, const T* child_increment, T* residuals) const {
    Eigen::Matrix<T, 3, 3> parent_r;
    Eigen::Matrix<T, 3, 1> parent_o;
    Eigen::Matrix<T, 3, 3> child_r;
    Eigen::Matrix<T, 3, 1> child_o;
    movedFrame(parent_frame, parent_centre, parent_increment, &parent_r, &parent_o);
    movedFrame(child_frame, child_centre, child_increment, &child_r, &child_o);
    const Eigen::Matrix<T, 3, 3> relative_r = parent_r.transpose() * child_r;
    const Eigen::Matrix<T, 3, 1> relative_t = parent_r.transpose() * (child_o - parent_o);
    T coordinates[6];
    kinematics::kneeCoordinatesInFemurFrame<T>(relative_r, relative_t, side, coordinates);
    constraints::ligamentResiduals(settings, coordinates, residuals);
    return true;
  }
};

}  // namespace

ceres::CostFunction* makeKneeLigamentCost(const constraints::LigamentSettings& settings,
                                          kinematics::Side side, const geometry::Pose& parent_frame,
                                          const Eigen::Vector3d& parent_centre,
                                          const geometry::Pose& child_frame,
                                          const Eigen::Vector3d& child_centre) {
  return new ceres::AutoDiffCostFunction<KneeLigamentResiduals, 6, 6, 6>(new KneeLigamentResiduals{
      settings, side, parent_frame, parent_centre, child_frame, child_centre});
}

}  // namespace registration
}  // namespace fluoro_tracker
