#pragma once

#include <cstddef>
#include <string>

#include "fluoro_tracker/geometry/xray_camera.h"
#include "fluoro_tracker/imaging/lens_distortion.h"

namespace fluoro_tracker {
namespace io {

// A fluoroscope view as bags and trials name it (docs/interfaces.md): "fluoro" when there is
// one view, "fluoro1", "fluoro2", ... when there are several. Its topics are
// /<name>/image_raw and /<name>/camera_info, its optical frame <name>_optical, and the
// camera's worldFromCamera() places that frame in the trial's fixed frame.
struct FluoroView {
  std::string name;
  geometry::XrayCamera camera;
  // The lens distortion its frames carry (an uncorrected image intensifier); none by default.
  imaging::LensDistortion distortion;
};

// The name of view `index` (from 0) of `count` views.
std::string fluoroViewName(std::size_t index, std::size_t count);
// "<view name>_optical".
std::string opticalFrameId(const std::string& view_name);
// The fixed frame of a trial with `count` views: the single view's optical frame, or "lab",
// to which /tf_static ties every view's optical frame.
std::string fixedFrameId(std::size_t count);

}  // namespace io
}  // namespace fluoro_tracker
