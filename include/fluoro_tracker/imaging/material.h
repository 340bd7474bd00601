#pragma once

#include <string>
#include <vector>

namespace fluoro_tracker {
namespace imaging {

// Effective linear X-ray attenuation of a material for a fluoroscopy spectrum (~60 keV mean
// energy), per millimetre. Values follow NIST mass attenuation coefficients at 60 keV times
// typical densities; they set contrast, not dosimetry.
struct Material {
  std::string name;
  double attenuation_per_mm = 0.0;
};

// Presets: cocr (cobalt-chrome implant), titanium, cortical_bone, cancellous_bone,
// polyethylene, soft_tissue. Throws InputError listing the presets for an unknown name.
Material materialByName(const std::string& name);
std::vector<Material> materialPresets();

}  // namespace imaging
}  // namespace fluoro_tracker
