// The GPU of the device benchmarks that run their own kernels (bench_device_rates.cpp,
// bench_device_sync.cpp): device 0's primary context and kernels compiled from source with
// the runtime's NVRTC and driver API, as the generated kernels are.
#pragma once
#include <fmt/format.h>

#include <string>

#include "runtime/cuda_driver.h"
#include "runtime/nvrtc_compiler.h"

namespace ssc {

struct BenchDevice {
  const cu::Driver* d = nullptr;  // nullptr: no usable GPU, `why` says why
  cu::Context ctx = nullptr;
  int major = 0, minor = 0, multiprocessors = 0;
  std::string why;

  BenchDevice() {
    d = cu::driver(&why);
    if (!d) return;
    if (!nvrtc_available()) {
      why = "ssc was built without NVRTC";
      d = nullptr;
      return;
    }
    cu::Device device = 0;
    cu::check(d->DeviceGet(&device, 0), "cuDeviceGet");
    cu::check(d->DevicePrimaryCtxRetain(&ctx, device), "cuDevicePrimaryCtxRetain");
    cu::check(d->CtxSetCurrent(ctx), "cuCtxSetCurrent");
    d->DeviceGetAttribute(&major, cu::kAttrComputeCapabilityMajor, device);
    d->DeviceGetAttribute(&minor, cu::kAttrComputeCapabilityMinor, device);
    d->DeviceGetAttribute(&multiprocessors, cu::kAttrMultiprocessorCount, device);
  }

  // Kernel `name` of `source`, compiled for this device and loaded.
  cu::Function load(const char* name, const std::string& source) const {
    NvrtcOptions o;
    o.arch = fmt::format("sm_{}{}", major, minor);
    const CompiledKernel k = compile_kernel(name, source, o);
    cu::Module m = nullptr;
    cu::check(d->ModuleLoadData(&m, k.image.data()), "cuModuleLoadData");
    cu::Function f = nullptr;
    cu::check(d->ModuleGetFunction(&f, m, name), "cuModuleGetFunction");
    return f;
  }
};

}  // namespace ssc
