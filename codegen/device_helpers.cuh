// Device helpers of the generated kernels: fixed-order block
// and grid reductions, warp shuffles and the grid barrier of the persistent solves. Not compiled on its own: codegen/cuda_source.cpp pastes it (embedded at
// build time like ops/, codegen/embed_headers.cmake) into every kernel's prelude after the ops
// and the Real typedef, and NVRTC compiles it there (every kernel is compiled by the tests).
#pragma once
#include "ops/contact.h"
#include "ops/corotation.h"
#include "ops/ssc_math.h"
namespace ssc {
namespace gen {
// The block's N totals in warp 0 (lane 0 holds them; the other lanes of warp 0 hold partial
// trees): each warp's values by a shuffle tree, the warp totals through part, then those (in
// warp order) by a shuffle tree in warp 0. All threads of the block must call it (one
// barrier); part is the caller's shared array, read by warp 0 after the barrier.
template <int N, int Threads>
__device__ inline void warp0_block_totals(double (&v)[N], double (&part)[N][Threads / 32], double (&s)[N]) {
  constexpr int kWarps = Threads / 32;
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
#pragma unroll
  for (int k = 0; k < N; ++k)
    for (int o = 16; o > 0; o >>= 1) v[k] += __shfl_down_sync(0xffffffffu, v[k], o);
  if (lane == 0)
#pragma unroll
    for (int k = 0; k < N; ++k) part[k][warp] = v[k];
  __syncthreads();
  if (warp == 0) {
#pragma unroll
    for (int k = 0; k < N; ++k) {
      s[k] = lane < kWarps ? part[k][lane] : 0.0;
      for (int o = 16; o > 0; o >>= 1) s[k] += __shfl_down_sync(0xffffffffu, s[k], o);
    }
  }
}

// Sums N doubles over the Threads threads of a block in a fixed order (warp0_block_totals).
// Every thread returns with the totals. All threads of the block must call it (it has barriers).
template <int N, int Threads = SSC_ITEM>
__device__ inline void block_sum(double (&v)[N]) {
  __shared__ double part[N][Threads / 32];
  __shared__ double total[N];
  double s[N];
  warp0_block_totals<N, Threads>(v, part, s);
  if (threadIdx.x == 0)
#pragma unroll
    for (int k = 0; k < N; ++k) total[k] = s[k];
  __syncthreads();
#pragma unroll
  for (int k = 0; k < N; ++k) v[k] = total[k];
  __syncthreads();  // part/total may be reused by the next call
}

// The reduction parts of op specs (graph/op_spec.h), one block of SSC_ITEM threads per batch
// item: each thread adds its strided share of a scratch source (c values per index, n
// indices) to acc[offset ..], block_sum totals them, and thread 0 adds the totals to the
// target cotangents (or, in a forward, stores them in the target outputs) in turn.
template <int N, class S>
__device__ inline void reduction_shares(double (&acc)[N], const S* source, int n, int c, int offset) {
  for (int e = threadIdx.x; e < n; e += SSC_ITEM)
    for (int k = 0; k < c; ++k) acc[offset + k] += double(source[c * e + k]);
}
template <int N, class R>
__device__ inline void reduction_add(const double (&acc)[N], R* target, int c, int offset) {
  if (threadIdx.x == 0)
    for (int k = 0; k < c; ++k) target[k] += R(acc[offset + k]);
}
template <int N, class R>
__device__ inline void reduction_store(const double (&acc)[N], R* target, int c, int offset) {
  if (threadIdx.x == 0)
    for (int k = 0; k < c; ++k) target[k] = R(acc[offset + k]);
}

// A vector from lane (this lane ^ mask) of the warp (all 32 lanes must take part).
template <class R>
__device__ inline Vec3<R> shfl_xor3(Vec3<R> v, int mask) {
  return make_vec3(__shfl_xor_sync(0xffffffffu, v.x, mask), __shfl_xor_sync(0xffffffffu, v.y, mask),
                   __shfl_xor_sync(0xffffffffu, v.z, mask));
}

// The double buffers of a solve that reads one while it writes the other.
template <class T>
__device__ __forceinline__ void swap_pointers(T*& a, T*& b) {
  T* const t = a;
  a = b;
  b = t;
}

// Extent::Grid: the threads of one batch item are gridDim.x blocks of SSC_GRID threads.
__device__ inline int grid_rank() { return blockIdx.x * SSC_GRID + threadIdx.x; }
__device__ inline int grid_threads() { return gridDim.x * SSC_GRID; }

__device__ inline unsigned long long load_acquire(const unsigned long long* p) {
  unsigned long long v;
  asm volatile("ld.acquire.gpu.global.u64 %0, [%1];" : "=l"(v) : "l"(p) : "memory");
  return v;
}
__device__ inline unsigned long long add_release(unsigned long long* p, unsigned long long v) {
  unsigned long long old;
  asm volatile("atom.release.gpu.global.add.u64 %0, [%1], %2;" : "=l"(old) : "l"(p), "l"(v) : "memory");
  return old;
}

// Barrier of the gridDim.x blocks of one batch item (all resident: cooperative launch).
// *bar counts arrivals and only grows: the barrier a block arrives at is complete when
// the count reaches the next multiple of gridDim.x (the same for every launch of one
// kernel over one problem, so the counter stays valid from launch to launch). Writes
// before the barrier (any block) are visible after it: release on arrival, acquire on
// leaving. One atomic and the polls per block; an item of one block only meets at
// __syncthreads (the counter stays untouched).
__device__ inline void grid_sync(unsigned long long* bar) {
  __syncthreads();
  if (gridDim.x == 1) return;
  if (threadIdx.x == 0) {
    const unsigned long long blocks = gridDim.x;
    const unsigned long long target = (add_release(bar, 1ull) / blocks + 1) * blocks;
    while (load_acquire(bar) < target) {
    }
  }
  __syncthreads();
}

// Sums N doubles over all threads of one batch item in a fixed order (warp trees, the warp
// totals in warp order by warp 0, then the block totals in block order by warp 0 of every
// block): every thread of every block returns with the same bits, the sums of block_sum
// followed by a tree over the blocks. partial holds N * gridDim.x doubles; consecutive calls
// must use different partial buffers unless a grid_sync separates them. Includes a grid_sync
// (writes of any thread before it are visible to every thread after it).
// Warp 0 alone publishes the block's total, arrives and polls (its lane 0 acquires; the
// block barrier after it passes that on), then loads every block's N totals at once.
// between() runs on every thread once all blocks have arrived, on the other warps while warp 0
// loads and sums the totals (warp 0 runs it after): it may load what other blocks wrote (the
// next phase's inputs), beside warp 0's loads. The shared arrays need no barrier at the end: part is
// read before this call's second barrier and written again after it; total is written again
// after the next call's first barrier, which every thread reaches after reading this call's.
// An item of one block returns with its block tree's totals (the block total plus zeros).
struct NoWork {
  __device__ __forceinline__ void operator()() const {}
};
template <int N, class Between = NoWork>
__device__ inline void grid_sum(double (&v)[N], double* partial, unsigned long long* bar, Between between = {}) {
  __shared__ double part[N][SSC_GRID / 32];
  __shared__ double total[N];
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  double s[N];
  warp0_block_totals<N, SSC_GRID>(v, part, s);
  const bool blocks = gridDim.x > 1;
  if (warp == 0 && blocks && lane == 0) {
#pragma unroll
    for (int k = 0; k < N; ++k) partial[N * blockIdx.x + k] = s[k];
    const unsigned long long count = gridDim.x;
    const unsigned long long target = (add_release(bar, 1ull) / count + 1) * count;
    while (load_acquire(bar) < target) {
    }
  }
  __syncthreads();
  if (warp != 0) between();
  if (warp == 0) {
    if (blocks) {
      constexpr int kMaxLoads = N <= 4 ? 8 : 1;  // blocks up to 256 loaded at once (small N); more in further rounds
#pragma unroll
      for (int k = 0; k < N; ++k) s[k] = 0;
      for (int j0 = lane; j0 < int(gridDim.x); j0 += 32 * kMaxLoads) {
        double q[kMaxLoads][N];
#pragma unroll
        for (int i = 0; i < kMaxLoads; ++i)
#pragma unroll
          for (int k = 0; k < N; ++k) {
            const int j = j0 + 32 * i;
            q[i][k] = j < int(gridDim.x) ? __ldcg(partial + N * j + k) : 0.0;
          }
#pragma unroll
        for (int i = 0; i < kMaxLoads; ++i)
#pragma unroll
          for (int k = 0; k < N; ++k)
            if (j0 + 32 * i < int(gridDim.x)) s[k] += q[i][k];
      }
#pragma unroll
      for (int k = 0; k < N; ++k)
        for (int o = 16; o > 0; o >>= 1) s[k] += __shfl_down_sync(0xffffffffu, s[k], o);
    }
    if (lane == 0)
#pragma unroll
      for (int k = 0; k < N; ++k) total[k] = s[k];
    between();
  }
  __syncthreads();
#pragma unroll
  for (int k = 0; k < N; ++k) v[k] = total[k];
}
}  // namespace gen
}  // namespace ssc
