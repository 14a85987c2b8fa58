// Where the timestep runs: one interface for the CPU interpreter (runtime/interpreter.h,
// through InterpreterBackend) and the generated CUDA kernels (runtime/cuda_runtime.h), so that
// the simulation and gradient drivers (models/sim/) have no CPU/GPU branches.
//
// The host keeps a TensorStore<double> of every tensor (the interpreter's own store). A
// backend holds its working copy of the tensors ("the device"): for the interpreter that copy
// is the host store itself, so upload and download do nothing; for the GPU it is device
// memory. Snapshots, tensor copies and the adjoint's cotangents all stay where the steps run.
#pragma once
#include <cstddef>
#include <utility>
#include <vector>

#include "runtime/tensor_store.h"

namespace ssc {

class StepBackend {
 public:
  virtual ~StepBackend() = default;

  // Host -> backend: every input and state tensor (all batch items); backend -> host: one tensor.
  virtual void upload(const TensorStore<double>& store, bool intermediates = false) = 0;
  virtual void download(TensorStore<double>& store, int tensor) const = 0;
  // One forward step; SimulationError if a solve does not converge.
  virtual void run() = 0;
  // The step's first op_count ops alone: a tail of ops whose outputs nothing reads this step
  // is left out (the band extension at a step no cost observes). run_adjoint_prefix is its
  // adjoint.
  virtual void run_prefix(int op_count) = 0;
  // Copies between tensors of one size (from, to), all batch items: a step's outputs become
  // the next step's state.
  virtual void copy_tensors(const std::vector<std::pair<int, int>>& from_to) = 0;
  // Copies of tensors (all items) under a key, and their restoration; drop releases the key.
  virtual void save_snapshot(int key, const std::vector<int>& tensors) = 0;
  virtual void load_snapshot(int key, const std::vector<int>& tensors) = 0;
  virtual void drop_snapshot(int key) = 0;
  // Memory left for snapshots, bytes.
  virtual size_t free_device_memory() const = 0;
  // CG iterations of the last forward step's time-step solve, per batch item.
  virtual const std::vector<int>& cg_iterations() const = 0;

  // Reverse mode on the values of the last step run or loaded: clear_adjoints(true) zeroes every
  // cotangent, clear_adjoints(false) all but the inputs' (parameter cotangents accumulate);
  // set/get move one tensor's cotangent (all items; get's vector has the tensor's size);
  // chain_adjoints moves each (from, to) and clears every other non-input cotangent (the
  // next, earlier step of a backward pass).
  virtual void clear_adjoints(bool including_inputs) = 0;
  virtual void set_adjoint(int tensor, const std::vector<double>& all_items) = 0;
  virtual void get_adjoint(int tensor, std::vector<double>& all_items) const = 0;
  virtual void chain_adjoints(const std::vector<std::pair<int, int>>& from_to) = 0;
  virtual void run_adjoint() = 0;
  virtual void run_adjoint_prefix(int op_count) = 0;
};

}  // namespace ssc
