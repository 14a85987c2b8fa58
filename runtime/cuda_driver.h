// The CUDA driver API, loaded at run time with dlopen("libcuda.so.1"), so that ssc
// builds and runs on machines without a GPU driver: there, cuda_driver() reports
// "no usable GPU: <reason>" instead of failing to start. Only the entry points the
// runtime uses are declared, with their ABI (_v2) names; types are the driver's.
#pragma once
#include <cstddef>
#include <string>

namespace ssc {
namespace cu {

using Result = int;
using Device = int;
using Context = struct CUctx_st*;
using Module = struct CUmod_st*;
using Function = struct CUfunc_st*;
using Stream = struct CUstream_st*;
using DevicePtr = unsigned long long;
using Graph = struct CUgraph_st*;
using GraphExec = struct CUgraphExec_st*;

struct Driver {
  Result (*Init)(unsigned);
  Result (*DeviceGetCount)(int*);
  Result (*DeviceGet)(Device*, int);
  Result (*DeviceGetName)(char*, int, Device);
  Result (*DeviceGetAttribute)(int*, int, Device);
  Result (*DevicePrimaryCtxRetain)(Context*, Device);
  Result (*DevicePrimaryCtxRelease)(Device);
  Result (*CtxSetCurrent)(Context);
  Result (*CtxSynchronize)();
  Result (*ModuleLoadData)(Module*, const void*);
  Result (*ModuleUnload)(Module);
  Result (*ModuleGetFunction)(Function*, Module, const char*);
  Result (*FuncGetAttribute)(int*, int, Function);
  Result (*MemAlloc)(DevicePtr*, size_t);
  Result (*MemFree)(DevicePtr);
  Result (*MemGetInfo)(size_t*, size_t*);  // free, total
  Result (*MemcpyHtoD)(DevicePtr, const void*, size_t);
  Result (*MemcpyDtoH)(void*, DevicePtr, size_t);
  Result (*MemcpyDtoD)(DevicePtr, DevicePtr, size_t);
  Result (*MemsetD8)(DevicePtr, unsigned char, size_t);
  Result (*LaunchKernel)(Function, unsigned, unsigned, unsigned, unsigned, unsigned, unsigned, unsigned, Stream,
                         void**, void**);
  Result (*GetErrorString)(Result, const char**);
  Result (*DriverGetVersion)(int*);
  // Streams and graphs (stream capture): optional, nullptr when the driver lacks them
  // (the runtime then launches every kernel directly).
  Result (*StreamCreate)(Stream*, unsigned);
  Result (*StreamDestroy)(Stream);
  Result (*StreamBeginCapture)(Stream, int);
  Result (*StreamEndCapture)(Stream, Graph*);
  Result (*GraphInstantiate)(GraphExec*, Graph, unsigned long long);
  Result (*GraphLaunch)(GraphExec, Stream);
  Result (*GraphExecDestroy)(GraphExec);
  Result (*GraphDestroy)(Graph);
  // Cooperative launches (grid barriers): optional as well.
  Result (*LaunchCooperativeKernel)(Function, unsigned, unsigned, unsigned, unsigned, unsigned, unsigned, unsigned,
                                    Stream, void**);
  Result (*OccupancyMaxActiveBlocksPerMultiprocessor)(int*, Function, int, size_t);
  // Launches with attributes (thread-block clusters) and function attributes: optional.
  Result (*LaunchKernelEx)(const struct LaunchConfig*, Function, void**, void**);
  Result (*FuncSetAttribute)(Function, int, int);
  bool has_cooperative() const { return LaunchCooperativeKernel && OccupancyMaxActiveBlocksPerMultiprocessor; }
  bool has_clusters() const { return LaunchKernelEx && FuncSetAttribute; }
  bool has_graphs() const {
    return StreamCreate && StreamDestroy && StreamBeginCapture && StreamEndCapture && GraphInstantiate && GraphLaunch &&
           GraphExecDestroy && GraphDestroy;
  }
};

// CUlaunchAttribute and CUlaunchConfig with the fields ssc sets (the driver's layout).
struct LaunchAttribute {
  int id;
  char pad[4];
  union {
    char bytes[64];
    struct {
      unsigned x, y, z;
    } cluster;
  } value;
};
struct LaunchConfig {
  unsigned grid_x, grid_y, grid_z, block_x, block_y, block_z, shared_bytes;
  Stream stream;
  LaunchAttribute* attrs;
  unsigned attr_count;
};
static_assert(sizeof(LaunchAttribute) == 72, "CUlaunchAttribute is 72 bytes");
constexpr int kLaunchAttrClusterDimension = 4;  // CU_LAUNCH_ATTRIBUTE_CLUSTER_DIMENSION

constexpr unsigned kStreamNonBlocking = 1;   // CU_STREAM_NON_BLOCKING
constexpr int kCaptureModeThreadLocal = 1;   // CU_STREAM_CAPTURE_MODE_THREAD_LOCAL

// Attribute ids (cuda.h values).
constexpr int kAttrComputeCapabilityMajor = 75, kAttrComputeCapabilityMinor = 76;
constexpr int kAttrMultiprocessorCount = 16, kAttrCooperativeLaunch = 95;
constexpr int kFuncAttrNumRegs = 4, kFuncAttrSharedSizeBytes = 1, kFuncAttrLocalSizeBytes = 3;
constexpr int kFuncAttrMaxDynamicSharedBytes = 8, kFuncAttrNonPortableClusterSize = 14;
constexpr int kAttrMaxSharedPerBlockOptin = 97;

// The loaded driver with cuInit done and at least one device, or nullptr; `why` then
// says what is missing (no libcuda, cuInit error, no device).
const Driver* driver(std::string* why);
// Throws std::runtime_error("<what>: <driver message>") when r != 0.
void check(Result r, const char* what);

}  // namespace cu
}  // namespace ssc
