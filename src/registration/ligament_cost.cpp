// The only translation unit that instantiates Ceres' automatic differentiation.
#include "fluoro_tracker/registration/ligament_cost.h"

#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>

#include "fluoro_tracker/constraints/glenohumeral_springs.h"

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

// A joint's two frames at the linearisation, with the bones' rotation centres: both moved by
// their increments.
struct JointFrames {
  geometry::Pose parent_frame;
  Eigen::Vector3d parent_centre;
  geometry::Pose child_frame;
  Eigen::Vector3d child_centre;

  template <typename T>
  struct Moved {
    Eigen::Matrix<T, 3, 3> parent_r;
    Eigen::Matrix<T, 3, 1> parent_o;
    Eigen::Matrix<T, 3, 3> child_r;
    Eigen::Matrix<T, 3, 1> child_o;
  };

  template <typename T>
  Moved<T> moved(const T* parent_increment, const T* child_increment) const {
    Moved<T> m;
    movedFrame(parent_frame, parent_centre, parent_increment, &m.parent_r, &m.parent_o);
    movedFrame(child_frame, child_centre, child_increment, &m.child_r, &m.child_o);
    return m;
  }

  // The moved child frame's rotation and origin in the moved parent frame.
  template <typename T>
  void relative(const T* parent_increment, const T* child_increment, Eigen::Matrix<T, 3, 3>* r,
                Eigen::Matrix<T, 3, 1>* t) const {
    const Moved<T> m = moved(parent_increment, child_increment);
    *r = m.parent_r.transpose() * m.child_r;
    *t = m.parent_r.transpose() * (m.child_o - m.parent_o);
  }
};

struct KneeLigamentResiduals {
  constraints::LigamentSettings settings;
  kinematics::Side side;
  JointFrames frames;  // the knee frames (JointModel::parentKneeFrame)

  template <typename T>
  bool operator()(const T* parent_increment, const T* child_increment, T* residuals) const {
    Eigen::Matrix<T, 3, 3> relative_r;
    Eigen::Matrix<T, 3, 1> relative_t;
    frames.relative(parent_increment, child_increment, &relative_r, &relative_t);
    T coordinates[6];
    kinematics::kneeCoordinatesInFemurFrame<T>(relative_r, relative_t, side, coordinates);
    constraints::ligamentResiduals(settings, coordinates, residuals);
    return true;
  }
};

struct GlenohumeralLigamentResiduals {
  constraints::LigamentSettings settings;
  kinematics::Side side;
  JointFrames frames;  // the anatomical frames

  template <typename T>
  bool operator()(const T* parent_increment, const T* child_increment, T* residuals) const {
    Eigen::Matrix<T, 3, 3> relative_r;
    Eigen::Matrix<T, 3, 1> relative_t;
    frames.relative(parent_increment, child_increment, &relative_r, &relative_t);
    kinematics::glenohumeralAsRight(side, &relative_r, &relative_t);
    constraints::glenohumeralSpringResiduals(settings, relative_r, relative_t, residuals);
    return true;
  }
};

struct LigamentBundleResiduals {
  std::vector<constraints::LigamentBundle> bundles;
  JointFrames frames;  // the bones' mesh frames

  template <typename T>
  bool operator()(const T* parent_increment, const T* child_increment, T* residuals) const {
    const auto m = frames.moved(parent_increment, child_increment);
    for (std::size_t i = 0; i < bundles.size(); ++i) {
      const auto& b = bundles[i];
      residuals[i] = b.residual<T>(m.parent_r * b.parent_insertion_m.cast<T>() + m.parent_o,
                                   m.child_r * b.child_insertion_m.cast<T>() + m.child_o);
    }
    return true;
  }
};

}  // namespace

ceres::CostFunction* makeLigamentBundleCost(const std::vector<constraints::LigamentBundle>& bundles,
                                            const geometry::Pose& parent_pose,
                                            const Eigen::Vector3d& parent_centre,
                                            const geometry::Pose& child_pose,
                                            const Eigen::Vector3d& child_centre) {
  if (bundles.empty()) return nullptr;
  return new ceres::AutoDiffCostFunction<LigamentBundleResiduals, ceres::DYNAMIC, 6, 6>(
      new LigamentBundleResiduals{bundles, {parent_pose, parent_centre, child_pose, child_centre}},
      static_cast<int>(bundles.size()));
}

ceres::CostFunction* makeKneeLigamentCost(const constraints::LigamentSettings& settings,
                                          kinematics::Side side, const geometry::Pose& parent_frame,
                                          const Eigen::Vector3d& parent_centre,
                                          const geometry::Pose& child_frame,
                                          const Eigen::Vector3d& child_centre) {
  return new ceres::AutoDiffCostFunction<KneeLigamentResiduals, 6, 6, 6>(new KneeLigamentResiduals{
      settings, side, {parent_frame, parent_centre, child_frame, child_centre}});
}

ceres::CostFunction* makeGlenohumeralLigamentCost(const constraints::LigamentSettings& settings,
                                                  kinematics::Side side,
                                                  const geometry::Pose& parent_frame,
                                                  const Eigen::Vector3d& parent_centre,
                                                  const geometry::Pose& child_frame,
                                                  const Eigen::Vector3d& child_centre) {
  return new ceres::AutoDiffCostFunction<GlenohumeralLigamentResiduals, 6, 6, 6>(
      new GlenohumeralLigamentResiduals{
          settings, side, {parent_frame, parent_centre, child_frame, child_centre}});
}

}  // namespace registration
}  // namespace fluoro_tracker
