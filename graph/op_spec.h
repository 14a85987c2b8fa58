// An op spec: everything the engine needs to know about one differentiable op, declared
// once beside the op's math in its ops/ header and registered with one line in
// ops/registry.cpp. The CPU interpreter (runtime/) and the CUDA emitter (codegen/) walk
// specs; neither knows any op by name.
//
// An op has slots (its inputs and outputs, bound to graph tensors by name) and parts: the
// per-index functions of ops/ that its forward and its adjoint run, in order, each over an
// extent (cells, nodes, contact points, band nodes, or once). A part is one C++ function
//   template <class Real> SSC_HD void part(int i, const ops::PartContext<Real>& cx, A... args)
// whose arguments are named in the spec: a slot's value ("u_prev"), its cotangent
// ("d_u_prev"), a static array ("#cell_nodes"), or a scratch buffer ("$corner"); a trailing
// '^' marks an argument read at other indices than i (a gather, which the kernel planner
// must not fuse behind a write of it). Whether an argument is written, and its element type,
// are read from the function's signature (a pointer to non-const is written). The
// interpreter calls the function through a runner instantiated at registration; the emitter
// writes a call of the same function by name, so both run the same text.
//
// A reduction part has no function: it sums scratch buffers over their domain in a fixed
// order and adds the totals to cotangents of scalar slots (parameter gradients) or, in a
// forward, stores them in scalar output slots.
//
// Ops whose forward is an implicit solve name a solver schedule instead of parts
// ("newmark_pcg", "band_laplacian"); the engine owns those schedules (runtime/solvers.h,
// codegen/solver_snippets.cpp), which iterate the operator that the spec's slots define.
#pragma once
#include <string>
#include <utility>
#include <vector>

namespace ssc {

enum class Domain { Scalar, Cell, Node, Point, Band };
enum class Access { Pointwise, Gather, ScatterAdd, Reduction, Opaque };

const char* domain_name(Domain d);
const char* access_name(Access a);

// How many threads (per batch item) a kernel runs; the extents One..Band are a part's
// iteration domain. Len: solver vectors. Item: one block of SSC_ITEM threads per batch item
// that cooperates (strided loops, fixed-order block reductions); its fragments see
// i = threadIdx.x. Grid: a cooperative launch of gridDim.x blocks of SSC_GRID threads per
// batch item, all resident at once (persistent solver loops).
enum class Extent { One, Cell, Node, Point, Band, Len, Item, Grid };
const char* extent_name(Extent e);
Domain extent_domain(Extent e);

// Type-erased loop over a part's extent: args[k] is the k-th argument's pointer.
using PartLoop = void (*)(int count, const void* context, void* const* args, long parallel_threshold);

struct PartArg {
  enum class Kind { Value, Adjoint, Static, Scratch };
  Kind kind = Kind::Value;
  std::string name;      // slot, static array or scratch key (without the d_, #, $ marks)
  bool gather = false;   // read at indices other than the part's own
  bool write = false;    // from the function's signature
  std::string type;      // "Real", "int" or "double", from the function's signature
};

// A part's function as registered: its name in ops/ and its loops for the interpreter.
struct PartFunction {
  std::string name;  // e.g. "ops::contact_force_point"
  PartLoop loop_double = nullptr, loop_float = nullptr, loop_dual = nullptr;
  std::vector<std::pair<std::string, bool>> params;  // per argument: element type, written
};

struct PartSpec {
  std::string label;  // kernel-plan name of the fragment, e.g. "contact_force_gather"
  Extent extent = Extent::One;
  PartFunction function;        // empty name: a reduction part
  std::vector<PartArg> args;    // a reduction: its sources ($scratch) then targets (d_slot)
  std::string requires_slot;    // run only when this (optional) slot is bound
};

struct SlotSpec {
  std::string name;
  bool output = false;
  Access access = Access::Pointwise;  // how the op's parts read it
  bool optional = false;              // an input the graph may leave unbound
  bool differentiable = true;         // has (or, for an output, takes) a cotangent
};

struct ScratchSpec {
  std::string key;
  Domain domain = Domain::Node;
  int components = 1;       // per index; 0: as many as the slot `like_slot` has
  std::string like_slot;
};

struct OpSpec {
  std::string name;
  Domain domain = Domain::Node;
  std::vector<SlotSpec> slots;
  std::vector<ScratchSpec> scratch;
  std::vector<PartSpec> forward, adjoint;
  std::string solver;  // non-empty: an engine schedule runs the forward and the adjoint

  const SlotSpec* slot(const std::string& name) const;  // nullptr if absent
  const ScratchSpec& scratch_spec(const std::string& key) const;
  std::string scratch_type(const std::string& key) const;  // "Real" or "double", from its parts
};

// The registry (ops/registry.cpp): every op ssc knows.
const std::vector<OpSpec>& op_registry();
const OpSpec& op_spec(const std::string& name);  // throws std::logic_error naming the known ops

// ---- declaring parts (used by the specs in ops/) ----

// A part over `extent` calling `f` (SSC_PART(name)) with the arguments named in `args`.
PartSpec part(const std::string& label, Extent extent, PartFunction f, const std::vector<std::string>& args);
// A fixed-order sum of the scratch buffers `sources` added to the cotangents `targets` (d_slot)
// or stored in the scalar outputs `targets` (slot).
PartSpec reduction(const std::string& label, const std::vector<std::string>& sources,
                   const std::vector<std::string>& targets);
// The same part, run only when `slot` is bound.
PartSpec when_bound(PartSpec p, const std::string& slot);

SlotSpec in(const std::string& name, Access access = Access::Pointwise);
SlotSpec out(const std::string& name);
SlotSpec optional_in(const std::string& name, Access access = Access::Pointwise);
SlotSpec constant_in(const std::string& name, Access access = Access::Pointwise);  // not differentiated

}  // namespace ssc
