// contact_benchmark: speed of one articular contact evaluation (the dissertation: 0.2 s for two
// 5,000-triangle models on a 2.4 GHz Xeon; our bar: 0.5 ms on one core).
//
// For two pairs of surfaces, in contact as the registration sees them, prints the build time of
// the signed distance grid and BVHs, and the median time of one contact cost evaluation with
// its Jacobians (the registration's inner loop), of the measure alone, and of the full figures
// with FCL's collision and distance queries (once per frame, for reports).
#include <algorithm>
#include <chrono>
#include <iomanip>
#include <iostream>
#include <random>

#include "fluoro_tracker/constraints/articular_contact.h"
#include "fluoro_tracker/median.h"
#include "fluoro_tracker/registration/contact_cost.h"
#include "fluoro_tracker/sim/mesh_builder.h"
#include "fluoro_tracker/sim/trial_simulator.h"

using namespace fluoro_tracker;
using geometry::Pose;
using Clock = std::chrono::steady_clock;

namespace {

double milliseconds(Clock::time_point since) {
  return std::chrono::duration<double, std::milli>(Clock::now() - since).count();
}

void run(const std::string& name, const geometry::Mesh& parent, const geometry::Mesh& child,
         const std::vector<std::pair<Pose, Pose>>& poses, constraints::ContactMeasure measure) {
  constraints::ContactSettings settings;
  settings.measure = measure;
  const auto build_start = Clock::now();
  const constraints::ArticularContact contact(parent, child, settings);
  const double build_ms = milliseconds(build_start);

  std::vector<double> cost_ms;
  std::vector<double> figures_ms;
  std::vector<double> active;
  double penetration_mm = 0.0;
  for (const auto& [parent_pose, child_pose] : poses) {
    const registration::ContactCost cost(&contact, parent_pose, parent_pose.translation(),
                                         child_pose, child_pose.translation());
    active.push_back(static_cast<double>(cost.activeSamples()));
    const double increments[2][6] = {{1e-3, -2e-3, 1e-3, 1e-5, -2e-5, 1e-5},
                                     {-1e-3, 1e-3, 2e-3, -1e-5, 1e-5, 2e-5}};
    const double* parameters[2] = {increments[0], increments[1]};
    double residual = 0.0;
    double jacobian[2][6];
    double* jacobians[2] = {jacobian[0], jacobian[1]};
    const int repeats = 200;
    const auto start = Clock::now();
    for (int k = 0; k < repeats; ++k) cost.Evaluate(parameters, &residual, jacobians);
    cost_ms.push_back(milliseconds(start) / repeats);
    const auto figures_start = Clock::now();
    const auto figures = contact.figures(parent_pose, child_pose);
    figures_ms.push_back(milliseconds(figures_start));
    penetration_mm = std::max(penetration_mm, figures.max_depth_m * 1e3);
  }
  std::cout << std::fixed << std::setprecision(3) << name << ": " << parent.triangleCount() << " + "
            << child.triangleCount() << " triangles, measure "
            << constraints::contactMeasureName(measure) << "\n"
            << "  build (grid " << contact.grid().size().transpose() << ", BVHs): " << build_ms
            << " ms\n"
            << "  one cost evaluation with Jacobians: median " << median(cost_ms) << " ms ("
            << median(active) << " of " << contact.samples().size() << " samples near contact)\n"
            << "  figures with FCL collision/distance: median " << median(figures_ms)
            << " ms; deepest penetration over the poses " << penetration_mm << " mm\n";
}

}  // namespace

int main() {
  // The simulator's knee in contact through a flexion cycle, pressed 0.3 mm into the insert.
  sim::TrialSimulatorSettings s;
  s.motion.frames = 10;
  const sim::TrialSimulator simulator(s);
  std::vector<std::pair<Pose, Pose>> knee_poses;
  for (int f = 0; f < s.motion.frames; ++f) {
    const auto truth = simulator.truth(f);
    Pose tibia = truth.tibia;
    tibia.translation() += truth.tibia.linear() * Eigen::Vector3d(0.0, 0.0003, 0.0);
    knee_poses.emplace_back(truth.femur, tibia);
  }
  const auto& implants = simulator.implants();
  for (auto measure : {constraints::ContactMeasure::kQuasiVolume,
                       constraints::ContactMeasure::kPenetrationDepth}) {
    run("femoral component on tibial insert", implants.femoral_component, implants.tibial_insert,
        knee_poses, measure);
  }
  // Two spheres of 5,000 triangles each, overlapping by 1 mm (the dissertation's model size).
  const geometry::Mesh sphere = sim::uvSphere(0.02, 50, 50);
  std::vector<std::pair<Pose, Pose>> sphere_poses;
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int k = 0; k < 10; ++k) {
    const Eigen::Vector3d direction = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
    Pose other = Pose::Identity();
    other.translation() = 0.039 * direction;
    sphere_poses.emplace_back(Pose::Identity(), other);
  }
  run("two spheres", sphere, sphere, sphere_poses, constraints::ContactMeasure::kQuasiVolume);
  return 0;
}
