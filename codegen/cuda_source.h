// CUDA C++ source of planned kernels (see kernel_plan.h). Every translation unit is
//   1. a prelude: SSC_BLOCK, `typedef <float|double> Real`, the embedded op headers
//      (ops/*.h, each under a `#line 1 "ops/<file>.h"` directive so that compiler
//      messages and line info point into the real headers), and small load/store helpers;
//   2. one `extern "C" __global__` kernel: thread (blockIdx.x * blockDim.x + threadIdx.x)
//      of batch item blockIdx.y loads through batch-offset pointers, runs the fused op
//      fragments in order, and stores its own outputs. Extent::Item kernels instead run
//      one block of SSC_ITEM threads per batch item (i = threadIdx.x) that reduce with
//      gen::block_sum (a fixed shuffle/shared-memory tree). No atomics.
// Only structure is baked in (op list, Real, block size); every run-time value (material,
// dt, theta, planes, tolerances, sizes) is a kernel parameter.
#pragma once
#include <string>

#include "codegen/kernel_plan.h"

namespace ssc {

struct CodegenOptions {
  std::string real = "double";  // "double" or "float"
  int block_size = 128;
  int item_block = kItemBlock;  // threads of an Extent::Item kernel (SSC_ITEM)
  // Blocks of a persistent grid kernel each multiprocessor must hold (the second
  // __launch_bounds__ argument, SSC_GRID_MIN_BLOCKS): more caps its registers.
  int grid_min_blocks = 1;
};

// The shared prelude (headers and helpers).
std::string kernel_prelude(const CodegenOptions& options);
// The __global__ function alone.
std::string kernel_function(const PlannedKernel& k);
// A complete translation unit for NVRTC.
std::string kernel_source(const PlannedKernel& k, const CodegenOptions& options);
// Threads per batch item as an expression of the size parameters.
std::string extent_count_expr(Extent e);

}  // namespace ssc
