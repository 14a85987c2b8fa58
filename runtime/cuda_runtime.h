// One timestep of a graph on the GPU, forward and adjoint, from generated kernels
// (codegen/) compiled with NVRTC (runtime/nvrtc_compiler.h) and launched through the
// driver API (runtime/cuda_driver.h).
//
// The constructor plans the graph, compiles every forward kernel in parallel (cached),
// loads the modules and uploads the static grid data (cell nodes, volume weights, the
// node<-(cell, corner) and node<-(point, side) incidence lists, band neighbours, and a
// node<-band list built here); the adjoint kernels and the cotangent buffers follow on
// first use of the adjoint. run() launches the planned kernels in order; an opaque solve
// becomes the Jacobi-PCG kernel sequence (element apply, node gather, and per iteration
// one block-per-item kernel doing the dot products, scalars, axpys and the direction
// update), every item of the batch frozen on the device at the iteration where its
// convergence test passes. Where the batch fits on the GPU at once, each solve is instead
// one persistent cooperative kernel (grid barriers between its phases) and the host reads
// the solves' outcomes once, after the step; otherwise the host checks the solver state
// every `check_every` iterations. The launches between two host reads are captured once
// as a CUDA graph and replayed. run_adjoint() does the same with the adjoint plan, on the forward values left
// on the device by the last run(): cotangents of the step's outputs in, cotangents of its
// inputs and state out, parameter cotangents accumulated over a backward pass. Dot
// products are summed in double in a fixed order (per-thread strided sums, then a fixed
// block tree): not the interpreter's order, but the same bits run to run. No atomics.
#pragma once
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "graph/graph.h"
#include "runtime/static_arrays.h"
#include "runtime/interpreter.h"
#include "runtime/nvrtc_compiler.h"
#include "runtime/step_backend.h"
#include "runtime/tensor_store.h"

namespace ssc {

class GpuUnavailable : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Empty when a GPU can run kernels, else "no usable GPU: <reason>".
std::string gpu_unavailable_reason();
// "NVIDIA H100 80GB HBM3 (sm_90)" for GPU `ordinal` (as the driver counts those
// CUDA_VISIBLE_DEVICES leaves), or the reason there is none.
std::string gpu_description(int ordinal = 0);
// The GPUs the driver lists (0 where there is no usable GPU).
int gpu_count();

struct GpuOptions {
  std::string real = "double";  // "double" or "float"
  int ordinal = 0;              // which GPU (the driver's numbering, after CUDA_VISIBLE_DEVICES)
  std::string arch;             // empty: the device's sm_XY
  bool fmad = false;            // --fmad (false: comparable with the interpreter)
  int check_every = 8;          // CG iterations between host checks of the solver state
  bool profile = false;         // synchronise after every launch and time it (no graphs)
  bool graphs = true;           // replay launch segments as CUDA graphs (SSC_GPU_GRAPHS=0: off)
  // Each solve as one persistent cooperative kernel (grid barriers, no host checks inside
  // a step) where the batch fits on the GPU at once; off, or when it does not fit: the
  // per-iteration kernels with host checks every check_every iterations
  // (SSC_GPU_GRID_SOLVES=0 turns it off).
  bool grid_solves = true;
  // The extension's grid solve: 1 phase per iteration (u evaluated at the neighbours; fewer
  // barriers, for latency), 2 phases (u read from the stored residual; less memory
  // traffic, for throughput), or 0: 2 where a thread owns two or more band nodes, i.e. for
  // large batches (SSC_GPU_EXTENSION_PHASES=1 or 2 overrides).
  int extension_phases = 0;
  // The time-step system's grid solve: 1 phase per iteration (every cell corner gathers its
  // node's forces itself; one barrier an iteration, for latency), 2 phases (the node update
  // storing u, a barrier, the element apply of u: fewer loads, for throughput), or 0: 1 where
  // every cell corner of an item has a thread of its own, else 2; never the batch alone, so
  // that an item's bits do not change with what runs beside it (SSC_GPU_NEWMARK_PHASES=1 or 2
  // overrides).
  int newmark_phases = 0;
  // The extension as one dense product G u and its adjoint as G^T band_u_bar where G
  // (runtime/band_operator.h) fits kDenseExtensionBytes; else, or off, or with
  // SSC_GPU_DENSE_EXTENSION=0, the extension's PCG.
  bool dense_extension = true;
  // Blocks per multiprocessor the persistent solves must fit (caps their registers): 0 picks
  // 3 where the batch wants more than four blocks per multiprocessor, else 1
  // (SSC_GPU_GRID_MIN_BLOCKS=n overrides).
  int grid_min_blocks = 0;
};

struct GpuKernelTiming {
  std::string name;
  int launches = 0;
  double ms = 0;
  int registers = 0;
};

class GpuTimestep : public StepBackend {
 public:
  // Throws GpuUnavailable when there is no usable GPU, NvrtcError when a kernel fails.
  GpuTimestep(const Graph& graph, const StaticArrays& grid, int batch, const SolverOptions& solver,
              const GpuOptions& options = {});
  ~GpuTimestep() override;
  GpuTimestep(const GpuTimestep&) = delete;
  GpuTimestep& operator=(const GpuTimestep&) = delete;

  // Copies every input and state tensor (all batch items) to the device; with
  // intermediates, every tensor (tests of single kernels).
  void upload(const TensorStore<double>& store, bool intermediates = false) override;
  // One forward step; throws SimulationError if a solve does not converge.
  void run() override;
  void run_prefix(int op_count) override;
  // Copies every tensor back (converted to double), or one tensor (all batch items).
  void download(TensorStore<double>& store) const;
  void download(TensorStore<double>& store, int tensor) const override;
  // Device copies between tensors of one size (from, to): the step's outputs become the
  // next step's state without a host round trip.
  void copy_tensors(const std::vector<std::pair<int, int>>& from_to) override;
  // Device snapshots of tensors (all batch items) under an integer key: the state
  // checkpoints of a backward pass, kept on the device. save_snapshot copies the tensors
  // in (the key's buffer is allocated on first use, or reused from a dropped one),
  // load_snapshot copies the same tensors back, drop_snapshot releases the key.
  void save_snapshot(int key, const std::vector<int>& tensors) override;
  void load_snapshot(int key, const std::vector<int>& tensors) override;
  void drop_snapshot(int key) override;
  // Bytes, as the driver reports them now, and the buffers of dropped snapshots kept for reuse.
  size_t free_device_memory() const override;

  // Adjoint of the step whose forward values the device holds: those the last run()
  // computed, or a kept step put back by load_snapshot (the adjoint reads no other state). clear_adjoints(true) zeroes every cotangent and starts a backward pass;
  // clear_adjoints(false), once per step, keeps the inputs' (parameter) cotangents, which
  // accumulate. set_adjoint seeds a tensor's cotangent (all batch items, as the store's
  // layout); get_adjoint reads one back.
  void clear_adjoints(bool including_inputs) override;
  void set_adjoint(int tensor, const std::vector<double>& all_items) override;
  void get_adjoint(int tensor, std::vector<double>& all_items) const override;
  // A copy of every cotangent on the device, and its restoration as the start of a
  // backward pass (a repeated adjoint step from the same seeds without uploads).
  void save_adjoints();
  void restore_adjoints();
  // The next (earlier) step of a backward pass, on the device: each (from, to) cotangent
  // moves (the previous state's become the step outputs'), every other non-input
  // cotangent is cleared.
  void chain_adjoints(const std::vector<std::pair<int, int>>& from_to) override;
  // One adjoint step; throws SimulationError if an adjoint solve does not converge.
  void run_adjoint() override;
  void run_adjoint_prefix(int op_count) override;
  // Kernels [first, last] of the forward (adjoint) plan alone, on what the device holds;
  // a solver stage among them launches its op's whole solve (tests of single kernels).
  void run_kernels(bool adjoint, int first, int last);

  const std::vector<int>& cg_iterations() const override;
  // The last run_adjoint()'s time-step solves' iterations, summed.
  const std::vector<int>& adjoint_cg_iterations() const;
  std::vector<GpuKernelTiming> timings() const;  // per kernel, with options.profile
  double compile_seconds() const;
  int kernel_count() const;
  // The largest batch whose solves all run as persistent kernels with the blocks per item a
  // batch of one gets. Up to it an item's values do not depend on the items beside it; a
  // larger batch gets fewer blocks per item or host-driven solves, which sum in other orders
  // (other bits). INT_MAX where grid solves are off (every batch then solves alike).
  int resident_items() const;

 private:
  struct Impl;  // runtime/cuda_timestep_impl.h
  std::unique_ptr<Impl> impl_;
};

}  // namespace ssc
