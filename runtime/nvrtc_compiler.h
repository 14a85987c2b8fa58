// NVRTC compilation of generated kernels to CUBIN for one GPU architecture, with a
// content-addressed, versioned disk cache.
//
// Options are pinned: -std=c++17, --gpu-architecture=sm_XX, --generate-line-info, no
// fast math; --fmad=false on request (tests compare with the CPU interpreter, built with
// -ffp-contract=off). When NVRTC cannot emit CUBIN for the arch, PTX for compute_XX is
// the fallback (the driver JITs it on load). Registers, shared memory and spills come
// from ptxas' verbose log (no GPU needed), or where NVRTC left that out, registers and
// shared memory from the CUBIN (runtime/cubin_resources.h); the CUDA runtime refines them
// with cuFuncGetAttribute when a device exists.
//
// Cache: $SSC_KERNEL_CACHE, else $XDG_CACHE_HOME/ssc/kernels/v1, else
// ~/.cache/ssc/kernels/v1; files <key>.cubin (or .ptx), <key>.json (name, resources,
// log) and <key>.cu, key = SHA-256 of (source, options, arch, NVRTC version, ssc
// version). Files are published by writing a temporary file and renaming it, so
// concurrent processes never read a partial binary. SSC_KERNEL_CACHE=off disables it.
// SSC_DUMP_KERNELS=dir writes every compiled source (and the log) to dir.
#pragma once
#include <stdexcept>
#include <string>
#include <vector>

namespace ssc {

struct NvrtcOptions {
  std::string arch = "sm_90";
  bool fmad = true;       // false: --fmad=false (bitwise comparisons with the interpreter)
  bool line_info = true;  // --generate-line-info
  bool use_cache = true;
};

struct KernelResources {
  bool known = false;
  bool from_cubin = false;  // ptxas' report was missing: registers and shared memory from the CUBIN, stack and spills unknown
  int registers = 0, shared_bytes = 0, stack_bytes = 0, spill_store_bytes = 0, spill_load_bytes = 0;
};

struct CompiledKernel {
  std::string name;
  std::string image;  // CUBIN or PTX
  bool is_cubin = true;
  std::string key;
  std::string log;
  KernelResources resources;
  double compile_ms = 0;  // 0 when loaded from the cache
  bool from_cache = false;
};

class NvrtcError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

bool nvrtc_available();                // compiled with NVRTC (SSC_HAVE_NVRTC)
std::string nvrtc_version();           // "13.0", or "none"
std::vector<std::string> nvrtc_option_list(const NvrtcOptions& o);
std::string kernel_cache_dir();        // empty when disabled
std::string kernel_cache_key(const std::string& source, const NvrtcOptions& o);

// Compiles one kernel (entry point `name`). Throws NvrtcError naming the kernel, the
// path of the dumped source and the NVRTC log.
CompiledKernel compile_kernel(const std::string& name, const std::string& source, const NvrtcOptions& o);

struct KernelSource {
  std::string name, source;
};
// Compiles all kernels on `threads` threads (0: hardware concurrency), results in input
// order; the first failure is rethrown after all threads finish.
std::vector<CompiledKernel> compile_kernels(const std::vector<KernelSource>& kernels, const NvrtcOptions& o,
                                            int threads = 0);

// Parses ptxas' verbose output for one entry function.
KernelResources parse_ptxas_log(const std::string& log, const std::string& name);

}  // namespace ssc
