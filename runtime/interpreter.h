// The CPU interpreter: runs a graph's ops in order, each op body (ops/) looped over its
// domain for every batch item, in double (the reference) or float. Loops over a domain
// are split across threads with OpenMP; every index writes only its own outputs, and
// all sums are gathers or fixed-order reductions, so results are bitwise reproducible.
#pragma once
#include <vector>

#include "graph/graph.h"
#include "runtime/static_arrays.h"
#include "runtime/tensor_store.h"

namespace ssc {

struct SolverOptions {
  double cg_tolerance = 1e-8;        // relative residual of the time-step solve
  int cg_max_iterations = 2000;
  double extension_tolerance = 1e-8;
  int extension_max_iterations = 5000;
};

// What the last run() reported, per batch item.
struct RunReport {
  std::vector<int> cg_iterations;
  std::vector<double> cg_residual;
  std::vector<int> extension_iterations;
  std::vector<int> degenerate_cells;  // cells whose rotation fell back to identity
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
  void run_op_adjoint(int op);

 private:
  void execute(const OpNode& op);
  void execute_item(const OpNode& op, int b);
  void execute_adjoint(const OpNode& op);
  void execute_adjoint_item(const OpNode& op, int b);

  const Graph& graph_;
  const StaticArrays& grid_;
  SolverOptions options_;
  TensorStore<Real> store_;
  TensorStore<Real> adjoint_;
  RunReport report_;
  std::vector<Real> point_t_;  // contact point edge parameters, in Real
  std::vector<Real> point_area_;   // contact point surface shares, in Real
  std::vector<int> point_nodes_;   // contact point edge nodes, 2 per point
  std::vector<Real> weights_;    // cut-cell volume weights, in Real
  std::vector<Real> node_rest_;  // rest positions of the active nodes, in Real
  std::vector<std::vector<Real>> extension_adjoint_guess_;  // per batch item, warm start
};

extern template class Interpreter<double>;
extern template class Interpreter<float>;

}  // namespace ssc
