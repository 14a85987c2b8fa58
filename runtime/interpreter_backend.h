// The CPU interpreter as a StepBackend (runtime/step_backend.h): its tensors are the host
// store, so upload and download do nothing; snapshots are host copies.
#pragma once
#include <map>
#include <vector>

#include "runtime/interpreter.h"
#include "runtime/step_backend.h"

namespace ssc {

class InterpreterBackend : public StepBackend {
 public:
  explicit InterpreterBackend(Interpreter<double>& interpreter) : in_(interpreter) {}

  void upload(const TensorStore<double>&, bool) override {}
  void download(TensorStore<double>&, int) const override {}
  void run() override;
  void run_prefix(int op_count) override { in_.run_prefix(op_count); }
  void copy_tensors(const std::vector<std::pair<int, int>>& from_to) override;
  void save_snapshot(int key, const std::vector<int>& tensors) override;
  void load_snapshot(int key, const std::vector<int>& tensors) override;
  void drop_snapshot(int key) override { snapshots_.erase(key); }
  size_t free_device_memory() const override;
  const std::vector<int>& cg_iterations() const override { return in_.report().cg_iterations; }

  void clear_adjoints(bool including_inputs) override { in_.clear_adjoints(including_inputs); }
  void set_adjoint(int tensor, const std::vector<double>& all_items) override { in_.adjoint().all(tensor) = all_items; }
  void get_adjoint(int tensor, std::vector<double>& all_items) const override;
  void chain_adjoints(const std::vector<std::pair<int, int>>& from_to) override;
  void run_adjoint() override { in_.run_adjoint(); }
  void run_adjoint_prefix(int op_count) override { in_.run_adjoint_prefix(op_count); }

 private:
  Interpreter<double>& in_;
  std::map<int, std::vector<std::vector<double>>> snapshots_;
};

}  // namespace ssc
