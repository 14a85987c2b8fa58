// Per-op code fragments for the CUDA generator: for every part of an op's spec
// (graph/op_spec.h), forward or adjoint, a call of the part's function of ops/ for one index
// of its extent (the same function the CPU interpreter loops), plus the parameters the
// fragment binds; reductions become block-per-item fixed-order sums. Ops with a solver are
// split into the solver's stages (solver_snippets.cpp): element apply over cells, node
// gathers and block-per-item or persistent grid PCG kernels with fixed-order reductions
// (runtime/cuda_runtime.cpp drives them).
//
// Conventions inside a fragment: `i` is the index in the domain, `b` the batch item,
// `h` the cell size; tensors are bound as t_<tensor> (values) and a_<tensor>
// (cotangents), static grid arrays as g_<name>, scratch buffers as s_<name>, solver
// vectors as v_<name>; pointers are already offset to batch item b. Run-time values
// (material, dt, theta, planes, tolerances) are always read through parameters.
#pragma once
#include <string>
#include <vector>

#include "graph/graph.h"

namespace ssc {

// Extents (graph/op_spec.h): Grid kernels' fragments loop over their domains themselves
// (gen::grid_rank(), gen::grid_threads()) and synchronise the item's blocks with
// gen::grid_sync / gen::grid_sum (persistent solver loops).

constexpr int kItemBlock = 1024;  // threads of an Extent::Item block (SSC_ITEM)
// Threads of an Extent::Grid block (SSC_GRID). 128 measured faster than 256 on the peer's
// dragon at batch 1 and 32 (docs/benchmarks.md, session 33).
constexpr int kGridBlock = 128;
constexpr int kMaxGridBlocks = 512;  // blocks per batch item of an Extent::Grid kernel
constexpr int kMaxGridSum = 20;      // doubles in one grid sum (the Galerkin start's, ops/galerkin_start.h)
constexpr int kMaxSolveLog = 8;      // solves per step whose final state is kept (s_cg_log)

struct KernelParam {
  enum class Kind { Tensor, Adjoint, Grid, Scratch, Vector, Value };
  Kind kind = Kind::Tensor;
  std::string name;    // identifier inside the kernel
  std::string type;    // "Real", "int" or "double"
  bool write = false;
  bool gather = false;  // read at indices other than the thread's own
  int tensor = -1;      // Tensor / Adjoint: graph tensor id
  std::string stride;   // per-batch stride (elements); empty: shared by the batch / by value
  Domain domain = Domain::Scalar;  // Scratch sizing: count(domain) * components per batch item
  int components = 1;
};

struct Snippet {
  std::string label;  // e.g. "corotation", "newmark_apply_cell"
  int op = -1;
  Extent extent = Extent::One;
  bool barrier = false;  // reduction or solver stage: a kernel of its own
  bool shared = false;   // solver kernel shared by forward and adjoint ("slv_" prefix)
  std::string stage;     // solver stage description for the plan, empty for plain ops
  std::vector<KernelParam> params;
  std::string code;
};

// The forward of one op as a sequence of fragments (its parts, or its solver's stages).
std::vector<Snippet> forward_snippets(const Graph& g, int op);
// Solver stages of an op with a solver, forward or adjoint (including the adjoint's
// parameter parts), in launch order (the iteration kernels are marked "loop" in their stage).
std::vector<Snippet> solver_snippets(const Graph& g, int op, bool adjoint);
// The adjoint of one op as a sequence of fragments (per-element parts, node gathers,
// ordered reductions; for ops with a solver its stages).
std::vector<Snippet> adjoint_snippets(const Graph& g, int op);
bool is_solver(const OpNode& op);

}  // namespace ssc
