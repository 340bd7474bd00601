#include "fluoro_tracker/io/mayacam_calibration.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <map>

#include "fluoro_tracker/input_error.h"
#include "text_lines.h"

namespace fluoro_tracker {
namespace io {
namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

}  // namespace

MayaCamCalibration readMayaCamCalibration(const std::string& path) {
  const auto lines = detail::readTrimmedLines(path, "MayaCam calibration");
  // Group the file into blocks: a header line followed by value lines up to a blank line.
  std::map<std::string, std::vector<std::string>> blocks;
  std::string current;
  for (const auto& line : lines) {
    if (line.empty()) {
      current.clear();
    } else if (current.empty()) {
      current = lower(line);
      if (blocks.count(current)) {
        throw InputError("MayaCam calibration '" + path + "': block '" + line + "' appears twice");
      }
      blocks[current];
    } else {
      blocks[current].push_back(line);
    }
  }
  const auto block = [&](const std::string& name, std::size_t rows) {
    auto it = blocks.find(name);
    if (it == blocks.end()) {
      throw InputError("MayaCam calibration '" + path + "': missing block '" + name +
                       "' (is this a MayaCam 2.0 file?)");
    }
    if (it->second.size() != rows) {
      throw InputError("MayaCam calibration '" + path + "': block '" + name + "' has " +
                       std::to_string(it->second.size()) + " line(s), expected " +
                       std::to_string(rows));
    }
    return it->second;
  };
  const std::string context = "MayaCam calibration '" + path + "'";
  MayaCamCalibration c;
  const auto size = detail::parseNumbers(block("image size", 1)[0], 2, context + " image size");
  c.image_height = static_cast<int>(size[0]);
  c.image_width = static_cast<int>(size[1]);
  if (c.image_width <= 0 || c.image_height <= 0 || size[0] != std::floor(size[0]) ||
      size[1] != std::floor(size[1])) {
    throw InputError(context + ": image size must be two positive whole numbers");
  }
  const auto k = block("camera matrix", 3);
  const auto r = block("rotation", 3);
  for (int row = 0; row < 3; ++row) {
    const auto kr =
        detail::parseNumbers(k[row], 3, context + " camera matrix row " + std::to_string(row + 1));
    const auto rr =
        detail::parseNumbers(r[row], 3, context + " rotation row " + std::to_string(row + 1));
    for (int col = 0; col < 3; ++col) {
      c.camera_matrix(row, col) = kr[col];
      c.rotation(row, col) = rr[col];
    }
  }
  const auto t = block("translation", 3);
  for (int i = 0; i < 3; ++i) {
    c.translation_mm[i] =
        detail::parseNumbers(t[i], 1, context + " translation line " + std::to_string(i + 1))[0];
  }
  const double orthogonality =
      (c.rotation * c.rotation.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orthogonality > 1e-4 || c.rotation.determinant() < 0.0) {
    throw InputError(context + ": rotation is not a proper rotation matrix (orthogonality error " +
                     std::to_string(orthogonality) + ")");
  }
  return c;
}

void writeMayaCamCalibration(const std::string& path, const MayaCamCalibration& c) {
  std::ofstream out(path);
  if (!out) throw InputError("cannot write MayaCam calibration '" + path + "'");
  out << std::setprecision(12);
  out << "image size\n" << c.image_height << "," << c.image_width << "\n\n";
  const auto matrix = [&out](const Eigen::Matrix3d& m) {
    for (int row = 0; row < 3; ++row)
      out << m(row, 0) << "," << m(row, 1) << "," << m(row, 2) << "\n";
  };
  out << "camera matrix\n";
  matrix(c.camera_matrix);
  out << "\nrotation\n";
  matrix(c.rotation);
  out << "\ntranslation\n"
      << c.translation_mm.x() << "\n"
      << c.translation_mm.y() << "\n"
      << c.translation_mm.z() << "\n";
  if (!out) throw InputError("failed while writing MayaCam calibration '" + path + "'");
}

geometry::XrayCamera cameraFromMayaCam(const MayaCamCalibration& c, const std::string& frame_id) {
  const Eigen::Matrix3d& k = c.camera_matrix;
  geometry::XrayCamera camera = geometry::XrayCamera::fromCameraInfo(
      c.image_width, c.image_height,
      {k(0, 0), k(0, 1), k(0, 2), k(1, 0), k(1, 1), k(1, 2), k(2, 0), k(2, 1), k(2, 2)}, frame_id);
  const geometry::Pose camera_from_world = geometry::makePose(c.rotation, 1e-3 * c.translation_mm);
  camera.setWorldFromCamera(camera_from_world.inverse());
  return camera;
}

}  // namespace io
}  // namespace fluoro_tracker
