// Per-op code fragments for the CUDA generator: for every op kind of graph/, the body
// of its forward (and, separately, its adjoint) for one index of its domain, written as
// calls into the op headers of ops/ (the same functions the CPU interpreter loops), plus
// the parameters the fragment binds. Opaque ops (NewmarkSolve, ExtensionSolve) are split
// into solver stages: element apply over cells, node gathers and two block-per-item PCG
// kernels with fixed-order reductions (runtime/cuda_runtime.cpp drives them).
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

// How many threads (per batch item) a kernel runs. Item: one block of SSC_ITEM threads
// per batch item that cooperates (strided loops over the item's vectors, fixed-order
// block reductions); its fragments see i = threadIdx.x. Grid: a cooperative launch of
// gridDim.x blocks of SSC_GRID threads per batch item, chosen at run time, all resident
// at once; its fragments loop over their domains themselves (gen::grid_rank(),
// gen::grid_threads()) and synchronise the item's blocks with gen::grid_sync /
// gen::grid_sum (persistent solver loops).
enum class Extent { One, Cell, Node, Point, Band, Len, Item, Grid };
const char* extent_name(Extent e);
Domain extent_domain(Extent e);

constexpr int kItemBlock = 1024;  // threads of an Extent::Item block (SSC_ITEM)
constexpr int kGridBlock = 256;      // threads of an Extent::Grid block (SSC_GRID)
constexpr int kMaxGridBlocks = 256;  // blocks per batch item of an Extent::Grid kernel
constexpr int kMaxSolveLog = 8;      // solves per step whose final state is kept (s_cg_log)
constexpr int kMaxPlaneBars = 32;  // 4 cotangent values x ops::kMaxGroundPlanes

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

// Forward fragment of a non-opaque op.
Snippet forward_snippet(const Graph& g, int op);
// Solver stages of an opaque op, forward or adjoint, in launch order (the iteration
// kernels are marked "loop" in their stage).
std::vector<Snippet> solver_snippets(const Graph& g, int op, bool adjoint);
// The adjoint of one op as a sequence of fragments (per-element parts, node gathers,
// ordered reductions; for opaque ops including their solver stages).
std::vector<Snippet> adjoint_snippets(const Graph& g, int op);
bool is_opaque(OpKind k);

}  // namespace ssc
