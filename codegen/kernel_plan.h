// The kernel plan: which ops of a graph fuse into which generated CUDA kernel, and why.
//
// The planner walks the ops in order (forward) or in reverse (adjoint) as a list of
// fragments (codegen/op_snippets.h) and appends each fragment to the current kernel
// unless one of the cut rules applies:
//   - domain change: the fragment iterates another domain (cell, node, point, band, one);
//   - gather of a buffer written in this kernel (read-after-write across threads), or a
//     write of a buffer the kernel gathers (write-after-read across threads);
//   - opaque op: NewmarkSolve and ExtensionSolve become solver sequences of their own
//     kernels (element apply, node gather, and per CG iteration one block-per-item
//     kernel: fixed-order dot products, scalars, axpys) that the runtime drives in a loop;
//   - reduction: an ordered (deterministic) sum into scalars is a kernel of its own.
// Every element-to-node transfer is a node-side gather over the incidence lists, so no
// kernel uses atomics. Kernel names are readable and carry a hash of their generated
// body: fwd_cell_corotation_corotation_force__1a2b3c4d (fwd_, adj_, or slv_ for solver
// kernels shared by forward and adjoint); equal names mean equal code.
#pragma once
#include <string>
#include <vector>

#include "codegen/op_snippets.h"
#include "graph/graph.h"

namespace ssc {

struct PlannedKernel {
  std::string name;    // unique per generated code
  std::string prefix;  // fwd, adj or slv
  Extent extent = Extent::One;
  std::vector<Snippet> parts;  // fused fragments, in execution order
  std::vector<int> ops;        // graph ops involved
  std::vector<KernelParam> params;
  std::string cut;    // why the kernel ends where it does
  std::string stage;  // solver stage (empty for plain fused kernels)
  bool duplicate = false;  // the same kernel already appears earlier in the plan

  // The label of the first part (solver kernels are looked up by it).
  const std::string& label() const { return parts.front().label; }
};

struct KernelPlan {
  std::vector<PlannedKernel> forward, adjoint;

  // Distinct kernels (forward then adjoint), each once.
  std::vector<const PlannedKernel*> unique_kernels() const;
  // First forward (adjoint) kernel whose first part has this label; nullptr if none.
  // The first kernel with this label; of op `op` where op >= 0 (a graph may solve twice).
  const PlannedKernel* find(bool adjoint, const std::string& label, int op = -1) const;
  // The kernels of the graph's first op_count ops alone, for a step that leaves out the tail of
  // ops from op_count on: forward, kernels [0, prefix_cut); adjoint (the ops reversed),
  // [prefix_cut, end). std::logic_error where a kernel holds ops of both sides or the tail's
  // kernels are not together.
  size_t prefix_cut(bool adjoint, int op_count) const;
  // Readable listing; sanitize_hashes replaces every __<hash8> by __########.
  std::string text(const Graph& g, bool sanitize_hashes = false) const;
};

KernelPlan plan_kernels(const Graph& g);

// The kernel body without its name (what the name's hash covers).
std::string kernel_signature_and_body(const PlannedKernel& k, const std::string& name);

}  // namespace ssc
