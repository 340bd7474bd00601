#include "fluoro_tracker/constraints/ligament_bundle.h"

#include <algorithm>
#include <cmath>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace constraints {

void LigamentBundle::validate() const {
  const std::string context = "ligament bundle '" + name + "': ";
  if (name.empty()) throw InputError("ligament bundle: every bundle needs a name");
  if (!parent_insertion_m.allFinite() || !child_insertion_m.allFinite()) {
    throw InputError(context + "insertion points must be finite");
  }
  if (!(std::isfinite(slack_length_m) && slack_length_m > 0.0)) {
    throw InputError(context + "slack length must be > 0");
  }
  if (!(std::isfinite(stiffness_per_mm) && stiffness_per_mm >= 0.0)) {
    throw InputError(context + "stiffness_per_mm must be >= 0");
  }
}

double LigamentBundle::length(const geometry::Pose& parent, const geometry::Pose& child) const {
  return (parent * parent_insertion_m - child * child_insertion_m).norm();
}

double LigamentBundle::stretchMm(const geometry::Pose& parent, const geometry::Pose& child) const {
  return std::max(0.0, (length(parent, child) - slack_length_m) * 1000.0);
}

double maxStretchMm(const std::vector<LigamentBundle>& bundles, const geometry::Pose& parent,
                    const geometry::Pose& child) {
  double worst = 0.0;
  for (const auto& b : bundles) worst = std::max(worst, b.stretchMm(parent, child));
  return worst;
}

}  // namespace constraints
}  // namespace fluoro_tracker
