// A kernel's registers and static shared memory read from its CUBIN (an ELF64 file), for
// when ptxas' verbose report is missing from NVRTC's log: on the 32-core GPU machines NVRTC
// 13.0 returned empty logs for some or all kernels of a process, seemingly depending on which
// thread called it first (docs/benchmarks.md, "Kernel compilation"). The register count is the
// EIATTR_REGCOUNT attribute in ".nv.info" for the kernel's symbol (the sh_info of its
// ".text.<name>" section); the static shared memory is the size of its ".nv.shared.<name>"
// section less the 1 KB that sm_80 and later reserve. Stack and spills are not read. The
// test NvrtcCompile.AllExampleKernelsDoubleAndFloat checks both against ptxas' report.
#pragma once
#include <string>

namespace ssc {

struct CubinResources {
  bool found = false;  // the kernel's .text section and its register count are in the image
  int registers = 0, shared_bytes = 0;
};

CubinResources cubin_resources(const std::string& image, const std::string& kernel);

}  // namespace ssc
