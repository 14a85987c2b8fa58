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

namespace ssc {

enum class Domain { Scalar, Cell, Node, Point, Band };
enum class Access { Pointwise, Gather, ScatterAdd, Reduction, Opaque };
enum class DType { Real, Int };

enum class OpKind {
  Lame,               // scalar: (E, nu) -> (lambda, mu)
  NodeMass,           // node: rho * V_i
  Corotation,         // cell: u- gathered at 8 corners -> R, polar status
  CorotationForce,    // cell: R -> per-corner offset force
  ContactForce,       // point: edge-node states gathered -> per-point contact force
  NodeForce,          // node: gathers corner and point forces, adds gravity
  StiffnessApply,     // cell: R, nodal vector gathered -> per-corner K p
  NewmarkRhs,         // node: gathers K u- -> right-hand side
  NewmarkSolve,       // opaque: Jacobi-PCG on (a_m M + a_k K) u = b
  VelocityUpdate,     // node: theta-scheme velocity
  ExtensionSolve,     // opaque: band Laplacian with active nodes as Dirichlet values
};

const char* domain_name(Domain d);
const char* access_name(Access a);
const char* op_kind_name(OpKind k);

struct TensorInfo {
  std::string name;
  Domain domain = Domain::Node;
  int components = 1;
  DType dtype = DType::Real;
  enum class Role { Input, State, Intermediate } role = Role::Intermediate;
  int producer = -1;  // op index, -1 for graph inputs and states
};

struct OpArg {
  std::string slot;  // name the op body uses for it
  int tensor = -1;
  Access access = Access::Pointwise;
};

struct OpNode {
  OpKind kind;
  Domain domain;
  std::vector<OpArg> inputs;
  std::vector<OpArg> outputs;

  int input(const std::string& slot) const;   // tensor id bound to slot; throws if missing
  int output(const std::string& slot) const;
};

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
  // Appends an op; outputs given as (slot, name, domain, components) are created here.
  struct NewOutput {
    std::string slot, name;
    Domain domain;
    int components;
  };
  int add_op(OpKind kind, Domain domain, std::vector<OpArg> inputs, const std::vector<NewOutput>& outputs);

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
};

}  // namespace ssc
