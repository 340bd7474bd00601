#include "fluoro_tracker/io/image_folder.h"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace io {
namespace {

bool isImageExtension(std::string extension) {
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (const char* known : {".tif", ".tiff", ".png", ".pgm", ".bmp", ".jpg", ".jpeg"}) {
    if (extension == known) return true;
  }
  return false;
}

bool isDigit(char c) {
  return std::isdigit(static_cast<unsigned char>(c)) != 0;
}

}  // namespace

bool naturalLess(const std::string& a, const std::string& b) {
  std::size_t i = 0;
  std::size_t j = 0;
  while (i < a.size() && j < b.size()) {
    if (isDigit(a[i]) && isDigit(b[j])) {
      // Compare the two digit runs by value: skip leading zeros, then longer is larger, then
      // digit by digit.
      std::size_t i_end = i;
      std::size_t j_end = j;
      while (i_end < a.size() && isDigit(a[i_end])) ++i_end;
      while (j_end < b.size() && isDigit(b[j_end])) ++j_end;
      std::size_t i_first = i;
      std::size_t j_first = j;
      while (i_first + 1 < i_end && a[i_first] == '0') ++i_first;
      while (j_first + 1 < j_end && b[j_first] == '0') ++j_first;
      const std::size_t i_digits = i_end - i_first;
      const std::size_t j_digits = j_end - j_first;
      if (i_digits != j_digits) return i_digits < j_digits;
      const int order = a.compare(i_first, i_digits, b, j_first, j_digits);
      if (order != 0) return order < 0;
      // Equal values: fewer leading zeros first, so that the order is total.
      if (i_end - i != j_end - j) return i_end - i < j_end - j;
      i = i_end;
      j = j_end;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i;
      ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

std::vector<std::string> listImageFiles(const std::string& folder) {
  namespace fs = std::filesystem;
  std::error_code error;
  if (!fs::is_directory(folder, error)) {
    throw InputError("image folder '" + folder + "' does not exist or is not a folder");
  }
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(folder, error)) {
    const std::string name = entry.path().filename().string();
    if (name.empty() || name[0] == '.') continue;
    if (!entry.is_regular_file(error)) continue;
    if (isImageExtension(entry.path().extension().string())) names.push_back(name);
  }
  if (error) throw InputError("cannot list image folder '" + folder + "': " + error.message());
  if (names.empty()) {
    throw InputError("image folder '" + folder +
                     "' holds no images (.tif, .tiff, .png, .pgm, .bmp, .jpg, .jpeg)");
  }
  std::sort(names.begin(), names.end(), naturalLess);
  std::vector<std::string> paths;
  paths.reserve(names.size());
  for (const std::string& name : names) paths.push_back((fs::path(folder) / name).string());
  return paths;
}

cv::Mat readFluoroImage(const std::string& path) {
  cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (image.empty()) throw InputError("cannot read image '" + path + "'");
  if (image.depth() != CV_8U && image.depth() != CV_16U) {
    throw InputError("image '" + path + "' has " + std::to_string(image.elemSize1() * 8) + "-bit " +
                     (image.depth() == CV_32F || image.depth() == CV_64F ? "float" : "signed") +
                     " pixels; expected 8- or 16-bit grey");
  }
  switch (image.channels()) {
    case 1:
      return image;
    case 2: {  // grey + alpha
      cv::Mat grey;
      cv::extractChannel(image, grey, 0);
      return grey;
    }
    case 3:
    case 4: {
      cv::Mat grey;
      cv::cvtColor(image, grey, image.channels() == 3 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGRA2GRAY);
      return grey;
    }
    default:
      throw InputError("image '" + path + "' has " + std::to_string(image.channels()) +
                       " channels; expected grey or colour");
  }
}

}  // namespace io
}  // namespace fluoro_tracker
