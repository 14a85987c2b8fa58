// dlopen loader of the CUDA driver API (see cuda_driver.h).
#include "runtime/cuda_driver.h"

#include <dlfcn.h>
#include <fmt/format.h>

#include <mutex>
#include <stdexcept>
#include <type_traits>

namespace ssc {
namespace cu {
namespace {

struct Loaded {
  Driver d{};
  bool ok = false;
  std::string why;
};

template <class F>
bool bind(void* lib, F& f, const char* name, std::string& why) {
  f = reinterpret_cast<F>(dlsym(lib, name));
  if (!f) why = fmt::format("libcuda.so.1 lacks {}", name);
  return f != nullptr;
}

Loaded load() {
  Loaded l;
  void* lib = dlopen("libcuda.so.1", RTLD_NOW | RTLD_LOCAL);
  if (!lib) {
    const char* e = dlerror();
    l.why = fmt::format("cannot load the CUDA driver (libcuda.so.1): {}", e ? e : "not found");
    return l;
  }
  Driver& d = l.d;
  std::string& w = l.why;
  const bool all = bind(lib, d.Init, "cuInit", w) && bind(lib, d.DeviceGetCount, "cuDeviceGetCount", w) &&
                   bind(lib, d.DeviceGet, "cuDeviceGet", w) && bind(lib, d.DeviceGetName, "cuDeviceGetName", w) &&
                   bind(lib, d.DeviceGetAttribute, "cuDeviceGetAttribute", w) &&
                   bind(lib, d.DevicePrimaryCtxRetain, "cuDevicePrimaryCtxRetain", w) &&
                   bind(lib, d.DevicePrimaryCtxRelease, "cuDevicePrimaryCtxRelease_v2", w) &&
                   bind(lib, d.CtxSetCurrent, "cuCtxSetCurrent", w) && bind(lib, d.CtxSynchronize, "cuCtxSynchronize", w) &&
                   bind(lib, d.ModuleLoadData, "cuModuleLoadData", w) && bind(lib, d.ModuleUnload, "cuModuleUnload", w) &&
                   bind(lib, d.ModuleGetFunction, "cuModuleGetFunction", w) &&
                   bind(lib, d.FuncGetAttribute, "cuFuncGetAttribute", w) && bind(lib, d.MemAlloc, "cuMemAlloc_v2", w) &&
                   bind(lib, d.MemFree, "cuMemFree_v2", w) && bind(lib, d.MemGetInfo, "cuMemGetInfo_v2", w) &&
                   bind(lib, d.MemcpyHtoD, "cuMemcpyHtoD_v2", w) &&
                   bind(lib, d.MemcpyDtoH, "cuMemcpyDtoH_v2", w) &&
                   bind(lib, d.MemcpyDtoD, "cuMemcpyDtoD_v2", w) && bind(lib, d.MemsetD8, "cuMemsetD8_v2", w) &&
                   bind(lib, d.LaunchKernel, "cuLaunchKernel", w) && bind(lib, d.GetErrorString, "cuGetErrorString", w) &&
                   bind(lib, d.DriverGetVersion, "cuDriverGetVersion", w);
  if (!all) return l;
  // Optional entry points (graphs): left null when absent.
  auto opt = [&](auto& f, const char* name) { f = reinterpret_cast<std::remove_reference_t<decltype(f)>>(dlsym(lib, name)); };
  opt(d.StreamCreate, "cuStreamCreate");
  opt(d.StreamDestroy, "cuStreamDestroy_v2");
  opt(d.StreamBeginCapture, "cuStreamBeginCapture_v2");
  opt(d.StreamEndCapture, "cuStreamEndCapture");
  opt(d.GraphInstantiate, "cuGraphInstantiateWithFlags");
  opt(d.GraphLaunch, "cuGraphLaunch");
  opt(d.GraphExecDestroy, "cuGraphExecDestroy");
  opt(d.GraphDestroy, "cuGraphDestroy");
  opt(d.LaunchCooperativeKernel, "cuLaunchCooperativeKernel");
  opt(d.OccupancyMaxActiveBlocksPerMultiprocessor, "cuOccupancyMaxActiveBlocksPerMultiprocessor");
  opt(d.LaunchKernelEx, "cuLaunchKernelEx");
  opt(d.FuncSetAttribute, "cuFuncSetAttribute");
  if (const Result r = d.Init(0); r != 0) {
    const char* s = nullptr;
    d.GetErrorString(r, &s);
    l.why = fmt::format("cuInit failed: {} ({})", s ? s : "unknown error", r);
    return l;
  }
  int n = 0;
  if (d.DeviceGetCount(&n) != 0 || n == 0) {
    l.why = "the CUDA driver reports no device";
    return l;
  }
  l.ok = true;
  return l;
}

}  // namespace

const Driver* driver(std::string* why) {
  static const Loaded l = load();
  if (!l.ok) {
    if (why) *why = l.why;
    return nullptr;
  }
  return &l.d;
}

void check(Result r, const char* what) {
  if (r == 0) return;
  const char* s = nullptr;
  if (const Driver* d = driver(nullptr)) d->GetErrorString(r, &s);
  throw std::runtime_error(fmt::format("{}: {} (CUDA error {})", what, s ? s : "unknown", r));
}

}  // namespace cu
}  // namespace ssc
