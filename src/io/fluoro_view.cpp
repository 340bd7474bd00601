#include "fluoro_tracker/io/fluoro_view.h"

namespace fluoro_tracker {
namespace io {

std::string fluoroViewName(std::size_t index, std::size_t count) {
  return count == 1 ? std::string("fluoro") : "fluoro" + std::to_string(index + 1);
}

std::string opticalFrameId(const std::string& view_name) {
  return view_name + "_optical";
}

std::string fixedFrameId(std::size_t count) {
  return count == 1 ? opticalFrameId(fluoroViewName(0, 1)) : std::string("lab");
}

}  // namespace io
}  // namespace fluoro_tracker
