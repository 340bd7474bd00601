#include "fluoro_tracker/registration/edge_map_prefetch.h"

#include <utility>

namespace fluoro_tracker {
namespace registration {

EdgeMapPrefetch::EdgeMapPrefetch(const std::vector<ViewImage>& views,
                                 const imaging::EdgeMapSettings& settings,
                                 const std::vector<cv::Rect>& rois, std::vector<double> scales,
                                 bool background)
    : views_(views),
      settings_(settings),
      rois_(rois),
      scales_(std::move(scales)),
      maps_(scales_.size()),
      errors_(scales_.size()) {
  if (background && scales_.size() > 1) builder_ = std::thread(&EdgeMapPrefetch::run, this);
}

EdgeMapPrefetch::~EdgeMapPrefetch() {
  if (!builder_.joinable()) return;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  builder_.join();
}

std::vector<imaging::EdgeMap> EdgeMapPrefetch::build(std::size_t index) const {
  std::vector<imaging::EdgeMap> maps;
  maps.reserve(views_.size());
  for (std::size_t v = 0; v < views_.size(); ++v) {
    maps.emplace_back(views_[v].image, views_[v].camera, settings_, rois_[v], scales_[index]);
  }
  return maps;
}

void EdgeMapPrefetch::run() {
  for (std::size_t index = 1; index < scales_.size(); ++index) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      if (stop_) break;
    }
    std::optional<std::vector<imaging::EdgeMap>> maps;
    std::exception_ptr error;
    try {
      maps = build(index);
    } catch (...) {
      error = std::current_exception();
    }
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      maps_[index] = std::move(maps);
      errors_[index] = error;
      next_ = index + 1;
    }
    built_.notify_all();
  }
  // A taker waiting for a scale never started must not wait for ever.
  const std::lock_guard<std::mutex> lock(mutex_);
  next_ = scales_.size();
  built_.notify_all();
}

std::vector<imaging::EdgeMap> EdgeMapPrefetch::take(std::size_t index) {
  if (index == 0 || !builder_.joinable()) return build(index);
  std::unique_lock<std::mutex> lock(mutex_);
  built_.wait(lock, [&] { return next_ > index; });
  if (errors_[index]) std::rethrow_exception(errors_[index]);
  if (!maps_[index]) {
    lock.unlock();
    return build(index);  // taken already, or the builder stopped before it
  }
  std::vector<imaging::EdgeMap> maps = std::move(*maps_[index]);
  maps_[index].reset();
  return maps;
}

}  // namespace registration
}  // namespace fluoro_tracker
