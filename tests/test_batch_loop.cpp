// for_each_batch_item (runtime/batch_loop.h): every item runs once, a failure reaches the
// caller after all items ran, and a batch of one runs outside any OpenMP region, so that the
// item's own parallel loops are not nested regions (which start fresh threads every time).
#include <gtest/gtest.h>
#include <omp.h>

#include <atomic>
#include <stdexcept>
#include <vector>

#include "runtime/batch_loop.h"

namespace ssc {
namespace {

TEST(BatchLoop, SingleItemRunsOutsideAnyParallelRegion) {
  int calls = 0, level = -1, item = -1;
  for_each_batch_item(1, [&](int b) {
    ++calls;
    item = b;
    level = omp_get_level();
  });
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(item, 0);
  EXPECT_EQ(level, 0);
}

TEST(BatchLoop, EveryItemRunsOnceAndTheFailureIsRethrownAfterAll) {
  constexpr int kBatch = 7;
  std::vector<std::atomic<int>> runs(kBatch);
  for (auto& r : runs) r = 0;
  EXPECT_THROW(for_each_batch_item(kBatch,
                                   [&](int b) {
                                     ++runs[b];
                                     if (b == 3) throw std::runtime_error("item 3 failed");
                                   }),
               std::runtime_error);
  for (int b = 0; b < kBatch; ++b) EXPECT_EQ(runs[b].load(), 1) << "item " << b;
}

}  // namespace
}  // namespace ssc
