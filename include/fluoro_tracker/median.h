#pragma once

#include <algorithm>
#include <vector>

namespace fluoro_tracker {

// The median of some values: the middle one, or the upper of the two middle ones for an even
// count; 0 for none. Takes a copy, which it reorders.
inline double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

}  // namespace fluoro_tracker
