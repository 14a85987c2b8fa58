// The CPU interpreter: runs a graph's ops in order for every batch item, in double (the
// reference) or float. It knows no op: it walks each op's spec (graph/op_spec.h), binds the
// arguments of every part (tensors, cotangents, static arrays, scratch buffers) and runs the
// part's function of ops/ over its extent; reductions are fixed-order sums, and ops with an
// implicit solve run the engine's solver schedule their spec names (runtime/solvers.h).
// Loops over a domain are split across threads with OpenMP; every index writes only its own
// outputs, and all sums are gathers or fixed-order reductions, so results are bitwise
// reproducible.
#pragma once
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "graph/graph.h"
#include "runtime/band_factor.h"
#include "runtime/static_arrays.h"
#include "runtime/tensor_store.h"

namespace ssc {

struct SolverOptions {
  double cg_tolerance = 1e-8;        // relative residual of the time-step solve
  int cg_max_iterations = 2000;
  double extension_tolerance = 1e-8;
  int extension_max_iterations = 5000;
  // A double time-step solve iterates on its operator with the element arithmetic in float,
  // eight cells at a time, and recomputes the residual in double (runtime/pcg.h,
  // jacobi_pcg_reliable). Off by default (docs/benchmarks.md: finite differences of such a run
  // carry float's rounding, and a solve to below double's attainable accuracy does not stop);
  // SSC_CPU_SINGLE_APPLY=1 turns it on.
  bool single_precision_cells = false;
};

// What the last run() reported, per batch item.
struct RunReport {
  std::vector<int> cg_iterations;          // the last time-step solve's
  std::vector<int> adjoint_cg_iterations;  // the last run_adjoint()'s time-step solves, summed
  std::vector<double> cg_residual;
  std::vector<int> extension_iterations;
};

DomainSizes domain_sizes(const StaticArrays& grid);

template <class Real>
class Interpreter {
 public:
  Interpreter(const Graph& graph, const StaticArrays& grid, int batch, const SolverOptions& options);

  TensorStore<Real>& store() { return store_; }
  const TensorStore<Real>& store() const { return store_; }
  const Graph& graph() const { return graph_; }
  const StaticArrays& grid() const { return grid_; }
  int batch() const { return store_.batch(); }
  const SolverOptions& options() const { return options_; }

  // Executes every op once. Throws SimulationError if a solve does not converge or
  // produces a non-finite value (naming the op and batch item).
  void run();
  // The first op_count ops alone (a tail whose outputs nothing reads is left out).
  void run_prefix(int op_count);
  const RunReport& report() const { return report_; }
  // One op alone (graph order is the caller's business): for tests of single kernels.
  void run_op(int op);

  // Reverse mode. adjoint() holds one cotangent per tensor, laid out like store().
  // run_adjoint() runs the ops' adjoints in reverse order on the values of the last
  // run(), accumulating (+=) into the adjoints of their inputs. Seed the adjoints of the
  // step's outputs first; clear_adjoints() zeroes all but the graph inputs' (parameter
  // gradients accumulate over steps) unless told otherwise.
  TensorStore<Real>& adjoint() { return adjoint_; }
  void clear_adjoints(bool including_inputs);
  void run_adjoint();
  void run_adjoint_prefix(int op_count);  // the adjoint of run_prefix(op_count)'s step
  void run_op_adjoint(int op);

  // ---- for the solver schedules (runtime/solvers.cpp) ----
  const Real* static_real(const std::string& name) const { return static_real_.at(name).data(); }
  RunReport& mutable_report() { return report_; }
  std::vector<Real>& extension_adjoint_guess(int b) { return extension_adjoint_guess_[b]; }
  // The band Laplacian's factor (runtime/band_factor.h), built on first use; nullptr where the
  // extension solves iteratively.
  const BandLaplacianFactor* band_laplacian_factor() { return band_factor_->get(grid_); }
  // The time-step adjoint solves of this run_adjoint() so far (none at its start and for
  // run_op_adjoint): their count and the largest right-hand side norm, their residual
  // reference (runtime/solvers.cpp, newmark_adjoint).
  struct AdjointSolves {
    int count = 0;
    double reference = 0;
  };
  AdjointSolves& adjoint_solves(int b) { return adjoint_solves_[b]; }
  // The first adjoint time-step solve's solutions at the two later steps of this backward pass
  // (empty until solved): that solve's warm start, in run_adjoint() only.
  struct AdjointWarmStart {
    std::vector<Real> later, before;
  };
  AdjointWarmStart* newmark_adjoint_warm_start(int b) {
    return warm_adjoint_solves_ ? &newmark_adjoint_warm_start_[b] : nullptr;
  }
  // A Real scratch buffer of op `op` for batch item b (a solver leaves its result there for
  // the op's adjoint parts).
  Real* scratch_real(int op, const std::string& key, int b) {
    Scratch& s = scratch_[op].at(key);
    return s.real.data() + s.stride * b;
  }

 private:
  struct Scratch {
    bool is_double = false;
    size_t stride = 0;  // per batch item
    std::vector<Real> real;
    std::vector<double> dbl;
    void* data(int b) { return is_double ? static_cast<void*>(dbl.data() + stride * b) : real.data() + stride * b; }
  };
  void execute(const OpNode& op);
  void execute_adjoint(const OpNode& op);
  void run_parts(int op, const std::vector<PartSpec>& parts, int b);
  void run_reduction(int op, const PartSpec& part, int b);
  void* bind(int op, const PartArg& a, int b);
  int extent_count(Extent e) const;

  const Graph& graph_;
  const StaticArrays& grid_;
  SolverOptions options_;
  TensorStore<Real> store_;
  TensorStore<Real> adjoint_;
  RunReport report_;
  DomainSizes sizes_;
  std::map<std::string, std::vector<Real>> static_real_;  // the real static arrays, in Real
  std::map<std::string, std::vector<int>> static_int_;
  std::vector<std::map<std::string, Scratch>> scratch_;  // per op, by key
  std::vector<std::vector<Real>> extension_adjoint_guess_;  // per batch item, warm start
  std::unique_ptr<BandFactorCache> band_factor_ = std::make_unique<BandFactorCache>();
  std::vector<AdjointWarmStart> newmark_adjoint_warm_start_;  // per batch item
  std::vector<AdjointSolves> adjoint_solves_;               // per batch item
  bool warm_adjoint_solves_ = false;
};

extern template class Interpreter<double>;
extern template class Interpreter<float>;

}  // namespace ssc
