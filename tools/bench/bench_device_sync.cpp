// What one iteration of a persistent solve pays to synchronise, apart from its arithmetic
// (issue 27): the grid barrier and grid sum of the cooperative solves (gen::grid_sync,
// gen::grid_sum, the very code of the generated kernels' prelude) against a thread-block
// cluster's hardware barrier and a sum over distributed shared memory, and one "phase"
// of each kind: every thread reads a value another block wrote before the barrier.
// A "neighbor" phase waits only for the blocks it reads from, as a solve whose blocks hold
// parts of a mesh could. Each launch runs `kSteps` of them back to back; the counter
// `per_step` is the time of one (launch overhead shared out over the steps).
#include <benchmark/benchmark.h>

#include <string>

#include "codegen/cuda_source.h"
#include "codegen/op_snippets.h"
#include "tools/bench/bench_device.h"

namespace ssc {
namespace {

constexpr int kSteps = 20000;
constexpr int kClusterBlock = 1024;

const char* const kSyncKernels = R"(
namespace bench {
__device__ inline unsigned cluster_rank() {
  unsigned r;
  asm volatile("mov.u32 %0, %%cluster_ctarank;" : "=r"(r));
  return r;
}
__device__ inline void cluster_sync() {
  asm volatile("barrier.cluster.arrive.release.aligned;\n\tbarrier.cluster.wait.acquire.aligned;" ::: "memory");
}
// The address of the same shared variable in block `rank` of the cluster.
template <class T>
__device__ inline T* map_rank(T* p, unsigned rank) {
  unsigned long long r;
  asm volatile("mapa.u64 %0, %1, %2;" : "=l"(r) : "l"(p), "r"(rank));
  return reinterpret_cast<T*>(r);
}
__device__ inline void store_release(unsigned long long* p, unsigned long long v) {
  asm volatile("st.release.gpu.global.u64 [%0], %1;" ::"l"(p), "l"(v) : "memory");
}
}  // namespace bench

extern "C" __global__ void __launch_bounds__(SSC_GRID) grid_barriers(double* bar, int steps) {
  for (int k = 0; k < steps; ++k) gen::grid_sync(reinterpret_cast<unsigned long long*>(bar));
}

extern "C" __global__ void __launch_bounds__(SSC_GRID) grid_sums(double* bar, double* partial, int steps, double* out) {
  double carry = 0;
  for (int k = 0; k < steps; ++k) {
    double v[3] = {double(threadIdx.x), carry, 1.0};
    gen::grid_sum<3>(v, partial + (k & 1) * 3 * gridDim.x, reinterpret_cast<unsigned long long*>(bar));
    carry = v[2] * 1e-30;
  }
  if (blockIdx.x == 0 && threadIdx.x == 0) out[0] = carry;
}

// x holds two buffers of gridDim.x * SSC_GRID doubles: a step reads, at another block,
// what that block wrote the step before, and writes its own.
extern "C" __global__ void __launch_bounds__(SSC_GRID) grid_phases(double* bar, double* x, int steps) {
  const int n = gridDim.x * SSC_GRID, me = blockIdx.x * SSC_GRID + threadIdx.x;
  const int other = ((blockIdx.x + 1) % gridDim.x) * SSC_GRID + (threadIdx.x * 7 + 3) % SSC_GRID;
  for (int k = 0; k < steps; ++k) {
    const double v = __ldcg(x + (k & 1) * n + other);
    x[((k + 1) & 1) * n + me] = v * 0.5 + 1.0;
    gen::grid_sync(reinterpret_cast<unsigned long long*>(bar));
  }
}

// The phase of grid_phases where a block waits only for the blocks it depends on, as a mesh
// partitioned into blocks would (here the blocks b - 2 .. b + 2, mod gridDim.x; a block reads
// b + 1's values): each block publishes the steps it has finished in its own flag (release,
// 128 bytes apart) and polls its neighbours' (acquire). flags must be zero at the launch.
extern "C" __global__ void __launch_bounds__(SSC_GRID) neighbor_phases(double* flags, double* x, int steps) {
  unsigned long long* flag = reinterpret_cast<unsigned long long*>(flags);
  const int n = gridDim.x * SSC_GRID, me = blockIdx.x * SSC_GRID + threadIdx.x;
  const int other = ((blockIdx.x + 1) % gridDim.x) * SSC_GRID + (threadIdx.x * 7 + 3) % SSC_GRID;
  const int neighbor = (int(blockIdx.x) + int(gridDim.x) + int(threadIdx.x) - 2) % int(gridDim.x);
  for (int k = 0; k < steps; ++k) {
    const double v = __ldcg(x + (k & 1) * n + other);
    x[((k + 1) & 1) * n + me] = v * 0.5 + 1.0;
    __syncthreads();
    if (threadIdx.x == 0) bench::store_release(flag + 16 * blockIdx.x, (unsigned long long)(k + 1));
    if (threadIdx.x < 5)
      while (gen::load_acquire(flag + 16 * neighbor) < (unsigned long long)(k + 1)) {
      }
    __syncthreads();
  }
}

extern "C" __global__ void __launch_bounds__(1024) cluster_barriers(int steps) {
  for (int k = 0; k < steps; ++k) bench::cluster_sync();
}

// A sum of three doubles over the cluster: block trees, each block's totals in its shared
// memory, one cluster barrier, every block adds the cluster's totals in rank order.
extern "C" __global__ void __launch_bounds__(1024) cluster_sums(int steps, double* out) {
  __shared__ double mine[2][3];
  __shared__ double total[3];
  unsigned blocks;
  asm volatile("mov.u32 %0, %%cluster_nctarank;" : "=r"(blocks));
  double carry = 0;
  for (int k = 0; k < steps; ++k) {
    double v[3] = {double(threadIdx.x), carry, 1.0};
    gen::block_sum<3, 1024>(v);
    if (threadIdx.x == 0)
      for (int j = 0; j < 3; ++j) mine[k & 1][j] = v[j];
    bench::cluster_sync();
    if (threadIdx.x < 32) {
      for (int j = 0; j < 3; ++j) {
        double s = threadIdx.x < blocks ? bench::map_rank(&mine[k & 1][j], threadIdx.x)[0] : 0.0;
        for (int o = 16; o > 0; o >>= 1) s += __shfl_down_sync(0xffffffffu, s, o);
        if (threadIdx.x == 0) total[j] = s;
      }
    }
    __syncthreads();
    carry = total[2] * 1e-30;
  }
  if (blockIdx.x == 0 && threadIdx.x == 0) out[0] = carry;
  bench::cluster_sync();  // no block leaves while another may still read its shared memory
}

// The phase of grid_phases with the vectors in the blocks' shared memory.
extern "C" __global__ void __launch_bounds__(1024) cluster_phases(int steps, double* out) {
  __shared__ double x[2][1024];
  unsigned blocks;
  asm volatile("mov.u32 %0, %%cluster_nctarank;" : "=r"(blocks));
  const unsigned me = bench::cluster_rank();
  x[0][threadIdx.x] = threadIdx.x;
  bench::cluster_sync();
  double* remote[2] = {bench::map_rank(&x[0][(threadIdx.x * 7 + 3) % 1024], (me + 1) % blocks),
                       bench::map_rank(&x[1][(threadIdx.x * 7 + 3) % 1024], (me + 1) % blocks)};
  for (int k = 0; k < steps; ++k) {
    const double v = *remote[k & 1];
    x[(k + 1) & 1][threadIdx.x] = v * 0.5 + 1.0;
    bench::cluster_sync();
  }
  if (me == 0 && threadIdx.x == 0) out[0] = x[0][0];
  bench::cluster_sync();
}
)";

const char* const kNames[] = {"grid_barriers", "grid_sums",      "grid_phases",    "cluster_barriers",
                              "cluster_sums",  "cluster_phases", "neighbor_phases"};
constexpr int kKernels = 7;
bool cluster_kernel(int k) { return k >= 3 && k <= 5; }

struct SyncDevice : BenchDevice {
  cu::Function f[kKernels] = {};
  cu::DevicePtr scratch = 0;  // barrier counter, partial sums, the phase vectors
  bool clusters = false;

  SyncDevice() {
    if (!d) return;
    clusters = major >= 9 && d->has_clusters();
    const std::string source = kernel_prelude(CodegenOptions{}) + kSyncKernels;
    for (int k = 0; k < kKernels; ++k) {
      if (cluster_kernel(k) && !clusters) continue;
      f[k] = load(kNames[k], source);
      if (cluster_kernel(k))
        cu::check(d->FuncSetAttribute(f[k], cu::kFuncAttrNonPortableClusterSize, 1), "cuFuncSetAttribute");
    }
    cu::check(d->MemAlloc(&scratch, 8u << 20), "cuMemAlloc");
  }
};

SyncDevice* sync_device(benchmark::State& state, bool clusters) {
  static SyncDevice device;
  if (!device.d) {
    state.SkipWithError(("no usable GPU: " + device.why).c_str());
    return nullptr;
  }
  if (clusters && !device.clusters) {
    state.SkipWithError("this GPU or driver has no thread-block clusters");
    return nullptr;
  }
  cu::check(device.d->CtxSetCurrent(device.ctx), "cuCtxSetCurrent");
  return &device;
}

void report(benchmark::State& state) {
  state.counters["per_step"] = benchmark::Counter(double(kSteps) * double(state.iterations()),
                                                  benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// kind 0..2 and 6: grid_barriers, grid_sums, grid_phases, neighbor_phases over range(0) blocks
// of SSC_GRID threads.
void BM_GridSync(benchmark::State& state, int kind) {
  SyncDevice* g = sync_device(state, false);
  if (!g) return;
  unsigned blocks = unsigned(state.range(0));
  int steps = kSteps;
  cu::DevicePtr bar = g->scratch, out = g->scratch + 64, partial = g->scratch + 4096, x = g->scratch + (1u << 20);
  void* barrier_args[] = {&bar, &steps};
  void* sum_args[] = {&bar, &partial, &steps, &out};
  void* phase_args[] = {&bar, &x, &steps};
  cu::DevicePtr flags = partial;
  void* neighbor_args[] = {&flags, &x, &steps};
  void** args = kind == 0 ? barrier_args : kind == 1 ? sum_args : kind == 2 ? phase_args : neighbor_args;
  auto launch = [&] {
    cu::check(g->d->MemsetD8(bar, 0, 8), "cuMemsetD8");
    if (kind == 6) cu::check(g->d->MemsetD8(flags, 0, 128 * blocks), "cuMemsetD8");
    cu::check(g->d->LaunchCooperativeKernel(g->f[kind], blocks, 1, 1, kGridBlock, 1, 1, 0, nullptr, args), kNames[kind]);
    cu::check(g->d->CtxSynchronize(), kNames[kind]);
  };
  launch();
  for (auto _ : state) launch();
  report(state);
}

// kind 3..5: cluster_barriers, cluster_sums, cluster_phases, one cluster of range(0)
// blocks of 1024 threads.
void BM_ClusterSync(benchmark::State& state, int kind) {
  SyncDevice* g = sync_device(state, true);
  if (!g) return;
  const unsigned blocks = unsigned(state.range(0));
  int steps = kSteps;
  cu::DevicePtr out = g->scratch + 64;
  void* barrier_args[] = {&steps};
  void* out_args[] = {&steps, &out};
  void** args = kind == 3 ? barrier_args : out_args;
  cu::LaunchAttribute attr{};
  attr.id = cu::kLaunchAttrClusterDimension;
  attr.value.cluster = {blocks, 1, 1};
  cu::LaunchConfig config{blocks, 1, 1, kClusterBlock, 1, 1, 0, nullptr, &attr, 1};
  auto launch = [&] {
    cu::check(g->d->LaunchKernelEx(&config, g->f[kind], args, nullptr), kNames[kind]);
    cu::check(g->d->CtxSynchronize(), kNames[kind]);
  };
  launch();
  for (auto _ : state) launch();
  report(state);
}

BENCHMARK_CAPTURE(BM_GridSync, barrier, 0)->Name("GpuSync/grid_barrier")->Arg(8)->Arg(16)->Arg(32)->Arg(64)->Arg(128)
    ->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_GridSync, sum, 1)->Name("GpuSync/grid_sum3")->Arg(8)->Arg(16)->Arg(32)->Arg(64)->Arg(128)
    ->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_GridSync, phase, 2)->Name("GpuSync/grid_phase")->Arg(8)->Arg(16)->Arg(32)->Arg(64)->Arg(128)
    ->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_GridSync, neighbor_phase, 6)->Name("GpuSync/neighbor_phase")->Arg(8)->Arg(16)->Arg(32)->Arg(64)
    ->Arg(128)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_ClusterSync, barrier, 3)->Name("GpuSync/cluster_barrier")->Arg(2)->Arg(4)->Arg(8)->Arg(16)
    ->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_ClusterSync, sum, 4)->Name("GpuSync/cluster_sum3")->Arg(2)->Arg(4)->Arg(8)->Arg(16)
    ->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_ClusterSync, phase, 5)->Name("GpuSync/cluster_phase")->Arg(2)->Arg(4)->Arg(8)->Arg(16)
    ->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace ssc
