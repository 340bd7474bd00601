#pragma once

#include <condition_variable>
#include <cstddef>
#include <exception>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "fluoro_tracker/imaging/edge_map.h"
#include "fluoro_tracker/registration/registrar.h"

namespace fluoro_tracker {
namespace registration {

// One frame's edge maps at each scale of a coarse-to-fine schedule, one map per view. With
// `background`, a second thread builds the maps of every scale but the first, in scale order,
// from the start, while the caller builds the first scale's and solves at it: on a second core
// the finer scales' maps are ready, or nearly, by the time the solver needs them (a
// full-resolution map is about a sixth of a crude-start registration's time; with this alone
// the crude starts' median fell from 29.9 to 24.9 ms on two cores). Without it, each scale's
// maps are built when taken. Either way the maps are the same: a map depends only on the frame,
// its region and its scale, never on the solve.
class EdgeMapPrefetch {
 public:
  // `views` and `rois` (one region per view) must outlive this object.
  EdgeMapPrefetch(const std::vector<ViewImage>& views, const imaging::EdgeMapSettings& settings,
                  const std::vector<cv::Rect>& rois, std::vector<double> scales, bool background);
  // Stops the builder after the map it is working on.
  ~EdgeMapPrefetch();
  EdgeMapPrefetch(const EdgeMapPrefetch&) = delete;
  EdgeMapPrefetch& operator=(const EdgeMapPrefetch&) = delete;

  // The maps of scales[index], once each: waits for them, and rethrows what building them threw
  // (e.g. InputError for an image that does not match its camera).
  std::vector<imaging::EdgeMap> take(std::size_t index);

 private:
  std::vector<imaging::EdgeMap> build(std::size_t index) const;
  void run();

  const std::vector<ViewImage>& views_;
  imaging::EdgeMapSettings settings_;
  const std::vector<cv::Rect>& rois_;
  std::vector<double> scales_;

  std::mutex mutex_;
  std::condition_variable built_;
  std::vector<std::optional<std::vector<imaging::EdgeMap>>> maps_;  // by scale, once built
  std::vector<std::exception_ptr> errors_;                          // by scale
  std::size_t next_ = 1;  // the first scale the builder has not finished (it starts at 1)
  bool stop_ = false;
  std::thread builder_;
};

}  // namespace registration
}  // namespace fluoro_tracker
