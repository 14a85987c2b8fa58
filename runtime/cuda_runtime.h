// One forward timestep of a graph on the GPU, from generated kernels (codegen/) compiled
// with NVRTC (runtime/nvrtc_compiler.h) and launched through the driver API
// (runtime/cuda_driver.h).
//
// The constructor plans the graph, compiles every forward kernel in parallel (cached),
// loads the modules and uploads the static grid data (cell nodes, volume weights, the
// node<-(cell, corner) and node<-(point, side) incidence lists, band neighbours, and a
// node<-band list built here). run() launches the planned kernels in order; an opaque
// solve becomes the Jacobi-PCG kernel sequence (element apply, node gather, and per
// iteration one block-per-item kernel doing the dot products, scalars, axpys and the
// direction update), every item of the batch frozen on the device at the iteration where
// its convergence test passes, with a host check of the solver state every `check_every`
// iterations. The launches between two host checks are captured once as a CUDA graph and
// replayed. Dot products are summed in double in a fixed order (per-thread strided sums,
// then a fixed block tree): not the interpreter's order, but the same bits run to run.
// No atomics.
#pragma once
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "graph/graph.h"
#include "models/grid/sim_grid.h"
#include "runtime/interpreter.h"
#include "runtime/nvrtc_compiler.h"
#include "runtime/tensor_store.h"

namespace ssc {

class GpuUnavailable : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Empty when a GPU can run kernels, else "no usable GPU: <reason>".
std::string gpu_unavailable_reason();
// "NVIDIA H100 80GB HBM3 (sm_90)", or the reason there is none.
std::string gpu_description();

struct GpuOptions {
  std::string real = "double";  // "double" or "float"
  std::string arch;             // empty: the device's sm_XY
  bool fmad = false;            // --fmad (false: comparable with the interpreter)
  int check_every = 8;          // CG iterations between host checks of the solver state
  bool profile = false;         // synchronise after every launch and time it (no graphs)
  bool graphs = true;           // replay launch segments as CUDA graphs (SSC_GPU_GRAPHS=0: off)
  // Extension PCG loop in one block-per-item kernel, no host checks (SSC_GPU_FUSED_EXTENSION=0/1
  // overrides). Off: one SM is slower than the multi-block band apply for bands of ~10k
  // nodes (H200: torus double 6.18 ms on, 4.85 ms off).
  bool fused_extension = false;
};

struct GpuKernelTiming {
  std::string name;
  int launches = 0;
  double ms = 0;
  int registers = 0;
};

class GpuTimestep {
 public:
  // Throws GpuUnavailable when there is no usable GPU, NvrtcError when a kernel fails.
  GpuTimestep(const Graph& graph, const SimGrid& grid, int batch, const SolverOptions& solver,
              const GpuOptions& options = {});
  ~GpuTimestep();
  GpuTimestep(const GpuTimestep&) = delete;
  GpuTimestep& operator=(const GpuTimestep&) = delete;

  // Copies every input and state tensor (all batch items) to the device.
  void upload(const TensorStore<double>& store);
  // One forward step; throws SimulationError if a solve does not converge.
  void run();
  // Copies every tensor back (converted to double).
  void download(TensorStore<double>& store) const;

  const std::vector<int>& cg_iterations() const;
  std::vector<GpuKernelTiming> timings() const;  // per kernel, with options.profile
  double compile_seconds() const;
  int kernel_count() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ssc
