// The tape graph: a static list of ops over typed tensors, built once per scene and
// replayed every timestep (and, later, differentiated and compiled into kernels).
//
// Every tensor has a domain (what it is indexed by: cells, active nodes, contact
// points, band nodes, or one value per simulation = Scalar) and a component count, and
// is stored with a leading batch dimension: element (b, i, k) of a tensor lives at
// (b * count(domain) + i) * components + k. Tensors are functional: each is written by
// exactly one op (or is a graph input), which validate() checks, so no op can overwrite
// a value that another op (or a recorded adjoint) still needs.
//
// Every op declares its iteration domain and, per argument, its access kind: pointwise
// (same index), gather (reads other indices through an incidence list), scatter_add,
// reduction (all indices into one), or opaque (a solver that owns its loop). The kernel
// planner (codegen/) fuses by these declarations; the interpreter (runtime/) runs the
// op bodies of ops/ over their domains.
#pragma once
#include <string>
#include <vector>

#include "graph/op_spec.h"

namespace ssc {

enum class DType { Real, Int };

struct TensorInfo {
  std::string name;
  Domain domain = Domain::Node;
  int components = 1;
  DType dtype = DType::Real;
  enum class Role { Input, State, Intermediate } role = Role::Intermediate;
  int producer = -1;  // op index, -1 for graph inputs and states
};

struct OpArg {
  std::string slot;  // the spec's slot name
  int tensor = -1;
  Access access = Access::Pointwise;  // from the spec
};

struct OpNode {
  const OpSpec* spec = nullptr;  // from the registry (ops/registry.cpp)
  Domain domain;
  std::vector<OpArg> inputs;
  std::vector<OpArg> outputs;

  int input(const std::string& slot) const;   // tensor id bound to slot; throws if missing
  int output(const std::string& slot) const;
  bool bound(const std::string& slot) const;  // an (optional) slot has a tensor
  const std::string& name() const { return spec->name; }
};

class Graph;
// Components per index of an op's scratch buffer: its own count, or its like_slot's (1, an
// unused placeholder, when that optional slot is unbound).
int scratch_components(const Graph& g, const OpNode& op, const ScratchSpec& s);

class Graph {
 public:
  int add_tensor(const std::string& name, Domain domain, int components, TensorInfo::Role role,
                 DType dtype = DType::Real);
  int add_input(const std::string& name, Domain domain, int components, DType dtype = DType::Real) {
    return add_tensor(name, domain, components, TensorInfo::Role::Input, dtype);
  }
  int add_state(const std::string& name, Domain domain, int components) {
    return add_tensor(name, domain, components, TensorInfo::Role::State);
  }
  // Appends the registered op `op`; inputs bind its slots to tensors (their access kinds
  // come from the spec), outputs given as (slot, name, domain, components) are created here.
  struct NewOutput {
    std::string slot, name;
    Domain domain;
    int components;
  };
  int add_op(const std::string& op, std::vector<OpArg> inputs, const std::vector<NewOutput>& outputs);
  // Contact planes: the run-time extent of the per-plane tensors (n_plane of the parts).
  void set_plane_count(int n) { plane_count_ = n; }
  int plane_count() const { return plane_count_; }

  const std::vector<TensorInfo>& tensors() const { return tensors_; }
  const std::vector<OpNode>& ops() const { return ops_; }
  const TensorInfo& tensor(int id) const { return tensors_.at(id); }
  int find_tensor(const std::string& name) const;  // -1 if absent

  // Checks topological order, single assignment and domain consistency; throws
  // std::logic_error describing the first violation.
  void validate() const;
  // Human-readable listing of tensors and ops with their domains and access kinds.
  std::string describe() const;

 private:
  std::vector<TensorInfo> tensors_;
  std::vector<OpNode> ops_;
  int plane_count_ = 0;
};

}  // namespace ssc
