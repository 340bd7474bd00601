#include "fluoro_tracker/parallel_for.h"

#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

using fluoro_tracker::parallelFor;

TEST(ParallelFor, CallsTheBodyOnceForEveryIndex) {
  for (int threads : {1, 2, 4}) {
    for (std::size_t count : {0u, 1u, 2u, 37u}) {
      std::vector<std::atomic<int>> calls(count);
      parallelFor(count, threads, [&](std::size_t k) { ++calls[k]; });
      for (std::size_t k = 0; k < count; ++k) {
        EXPECT_EQ(calls[k], 1) << "threads " << threads << " count " << count << " index " << k;
      }
    }
  }
}

TEST(ParallelFor, OneThreadRunsOnTheCallerInOrderAndTwoUseAnother) {
  const std::thread::id caller = std::this_thread::get_id();
  std::vector<std::size_t> order;
  parallelFor(5, 1, [&](std::size_t k) {
    EXPECT_EQ(std::this_thread::get_id(), caller);
    order.push_back(k);
  });
  EXPECT_EQ(order, (std::vector<std::size_t>{0, 1, 2, 3, 4}));
  // Two items that each wait for the other to start can only finish on two threads.
  std::atomic<int> started{0};
  std::mutex mutex;
  std::set<std::thread::id> ids;
  parallelFor(2, 2, [&](std::size_t) {
    ++started;
    while (started < 2) std::this_thread::yield();
    const std::lock_guard<std::mutex> lock(mutex);
    ids.insert(std::this_thread::get_id());
  });
  EXPECT_EQ(ids.size(), 2u);
}

TEST(ParallelFor, RethrowsWhatABodyThrewAfterEveryThreadStopped) {
  for (int threads : {1, 2}) {
    std::atomic<int> running{0};
    std::atomic<int> finished{0};
    try {
      parallelFor(50, threads, [&](std::size_t k) {
        ++running;
        if (k == 3) {
          --running;
          throw std::runtime_error("item 3 failed");
        }
        ++finished;
        --running;
      });
      ADD_FAILURE() << "expected the body's exception";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "item 3 failed");
    }
    EXPECT_EQ(running, 0) << "threads " << threads;  // nothing still running when it returned
    EXPECT_LT(finished, 50);
  }
}
