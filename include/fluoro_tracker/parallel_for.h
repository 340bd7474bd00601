#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <future>
#include <vector>

namespace fluoro_tracker {

// Calls body(k) once for every k in [0, count): on the calling thread and, with `threads` > 1,
// on up to threads - 1 others started for the loop, which take the next index as each finishes
// one (so unequal items balance). For independent items whose results the caller keeps by index:
// the outcome is then the same as one thread's. What a body throws is rethrown here (the calling
// thread's first, else the first helper's), once every thread has stopped.
template <typename Body>
void parallelFor(std::size_t count, int threads, const Body& body) {
  std::atomic<std::size_t> next{0};
  const auto work = [&] {
    try {
      for (std::size_t k = next++; k < count; k = next++) body(k);
    } catch (...) {
      next = count;  // the other threads stop after their current item
      throw;
    }
  };
  const std::size_t helpers =
      threads > 1 && count > 1
          ? std::min<std::size_t>(static_cast<std::size_t>(threads) - 1, count - 1)
          : 0;
  std::vector<std::future<void>> started;
  started.reserve(helpers);
  for (std::size_t h = 0; h < helpers; ++h) started.push_back(std::async(std::launch::async, work));
  std::exception_ptr error;
  try {
    work();
  } catch (...) {
    error = std::current_exception();
  }
  for (auto& helper : started) {
    try {
      helper.get();
    } catch (...) {
      if (!error) error = std::current_exception();
    }
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace fluoro_tracker
