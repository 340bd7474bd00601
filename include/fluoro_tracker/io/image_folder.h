#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace fluoro_tracker {
namespace io {

// The image files of a folder of fluoroscopy frames (one view of a trial, as JointTrack,
// Autoscoper and XMALab users keep them): regular files ending in .tif, .tiff, .png, .pgm,
// .bmp, .jpg or .jpeg (any case), in natural order, so that frame_9 comes before frame_10 and
// zero-padded names sort as they read. Hidden files are left out. Throws InputError for a
// folder that does not exist or holds no such file.
std::vector<std::string> listImageFiles(const std::string& folder);

// "frame_9.tif" < "frame_10.tif": runs of digits compare by value, the rest by character.
bool naturalLess(const std::string& a, const std::string& b);

// One frame as the tracker takes it: 8- or 16-bit grey (a colour or grey+alpha file is
// converted to grey at its bit depth). Throws InputError naming the file for an unreadable
// file or another pixel type (e.g. 32-bit float), which would otherwise be misread.
cv::Mat readFluoroImage(const std::string& path);

}  // namespace io
}  // namespace fluoro_tracker
