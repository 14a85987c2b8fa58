// The GPU's measured ceilings, the floors that docs/benchmarks.md holds the steps
// against: device memory bandwidth (a grid-stride copy of 2 x 2 GiB of doubles, bytes
// read plus written) and the FP64 rate (eight independent fma chains per thread, enough
// threads for every SM). The kernels go through the same NVRTC and driver-API runtime
// as the generated ones; each timed iteration is one launch and a synchronisation.
#include <benchmark/benchmark.h>

#include <string>

#include "tools/bench/bench_device.h"

namespace ssc {
namespace {

const char* const kRateKernels = R"(
extern "C" __global__ void rate_copy(const double* __restrict__ a, double* __restrict__ b, long long n) {
  const long long stride = (long long)gridDim.x * blockDim.x;
  for (long long i = (long long)blockIdx.x * blockDim.x + threadIdx.x; i < n; i += stride) b[i] = a[i];
}
extern "C" __global__ void rate_fma(double* out, int iterations, double a, double c) {
  double x[8];
  for (int k = 0; k < 8; ++k) x[k] = threadIdx.x + k;
  for (int it = 0; it < iterations; ++it)
#pragma unroll
    for (int k = 0; k < 8; ++k) x[k] = fma(x[k], a, c);
  double s = 0;
  for (int k = 0; k < 8; ++k) s += x[k];
  if (s == 1234.5) out[0] = s;  // never true for these inputs; keeps the chains alive
}
)";

// The device and the two kernels, set up once.
struct RateDevice : BenchDevice {
  cu::Function copy = nullptr, fma = nullptr;

  RateDevice() {
    if (!d) return;
    copy = load("rate_copy", kRateKernels);
    fma = load("rate_fma", kRateKernels);
  }
};

// One warm-up launch of f, then one launch and a synchronisation per timed iteration.
void time_launches(benchmark::State& state, const RateDevice& g, cu::Function f, unsigned blocks, void** args,
                   const char* what) {
  auto launch = [&] {
    cu::check(g.d->LaunchKernel(f, blocks, 1, 1, 256, 1, 1, 0, nullptr, args, nullptr), what);
    cu::check(g.d->CtxSynchronize(), what);
  };
  launch();
  for (auto _ : state) launch();
}

RateDevice* rate_device(benchmark::State& state) {
  static RateDevice device;
  if (!device.d) state.SkipWithError(("no usable GPU: " + device.why).c_str());
  return device.d ? &device : nullptr;
}

void BM_GpuRateCopy(benchmark::State& state) {
  RateDevice* g = rate_device(state);
  if (!g) return;
  cu::check(g->d->CtxSetCurrent(g->ctx), "cuCtxSetCurrent");
  long long n = 256LL << 20;  // 2 GiB of doubles per buffer
  cu::DevicePtr a = 0, b = 0;
  cu::check(g->d->MemAlloc(&a, size_t(n) * 8), "cuMemAlloc");
  cu::check(g->d->MemAlloc(&b, size_t(n) * 8), "cuMemAlloc");
  cu::check(g->d->MemsetD8(a, 0, size_t(n) * 8), "cuMemsetD8");
  void* args[] = {&a, &b, &n};
  time_launches(state, *g, g->copy, unsigned(g->multiprocessors) * 8, args, "rate_copy");
  state.SetBytesProcessed(state.iterations() * n * 16);
  g->d->MemFree(a);
  g->d->MemFree(b);
}

void BM_GpuRateFp64(benchmark::State& state) {
  RateDevice* g = rate_device(state);
  if (!g) return;
  cu::check(g->d->CtxSetCurrent(g->ctx), "cuCtxSetCurrent");
  cu::DevicePtr out = 0;
  cu::check(g->d->MemAlloc(&out, 8), "cuMemAlloc");
  int iterations = 8192;
  double a = 0.999999, c = 1e-7;
  void* args[] = {&out, &iterations, &a, &c};
  const unsigned blocks = unsigned(g->multiprocessors) * 16;
  time_launches(state, *g, g->fma, blocks, args, "rate_fma");
  const double flops = 2.0 * 8 * iterations * double(blocks) * 256;
  state.counters["fp64_flops"] = benchmark::Counter(flops * double(state.iterations()), benchmark::Counter::kIsRate);
  g->d->MemFree(out);
}

BENCHMARK(BM_GpuRateCopy)->Name("GpuRate/copy_bandwidth")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_GpuRateFp64)->Name("GpuRate/fp64_fma")->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace ssc
