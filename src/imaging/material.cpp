#include "fluoro_tracker/imaging/material.h"

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace imaging {

std::vector<Material> materialPresets() {
  return {
      {"cocr", 1.0},              // Co-Cr-Mo, 8.3 g/cm^3
      {"titanium", 0.21},         // Ti-6Al-4V, 4.4 g/cm^3
      {"cortical_bone", 0.06},    // 1.9 g/cm^3
      {"cancellous_bone", 0.03},  // marrow-filled trabecular bone
      {"polyethylene", 0.018},    // UHMWPE insert, 0.94 g/cm^3
      {"soft_tissue", 0.02},      // muscle / water
  };
}

Material materialByName(const std::string& name) {
  std::string known;
  for (const auto& m : materialPresets()) {
    if (m.name == name) return m;
    known += (known.empty() ? "" : ", ") + m.name;
  }
  throw InputError("unknown material '" + name + "' (known: " + known + ")");
}

}  // namespace imaging
}  // namespace fluoro_tracker
