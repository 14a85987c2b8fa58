// The interpreter's forward and reverse passes over op specs (see interpreter.h).
#include "runtime/interpreter.h"

#include <fmt/format.h>

#include <stdexcept>
#include <type_traits>

#include "ops/part.h"
#include "runtime/batch_loop.h"
#include "runtime/pcg.h"
#include "runtime/solvers.h"

namespace ssc {

DomainSizes domain_sizes(const StaticArrays& grid) {
  DomainSizes s;
  s.cell = grid.cell_count;
  s.node = grid.node_count;
  s.point = int(grid.contact_points.size());
  s.band = grid.band_count;
  return s;
}

template <class Real>
Interpreter<Real>::Interpreter(const Graph& graph, const StaticArrays& grid, int batch, const SolverOptions& options)
    : graph_(graph),
      grid_(grid),
      options_(options),
      store_(graph, domain_sizes(grid), batch),
      adjoint_(graph, domain_sizes(grid), batch),
      sizes_(domain_sizes(grid)) {
  graph_.validate();
  for (NamedStaticArray& a : named_static_arrays(grid)) {
    if (a.is_int)
      static_int_[a.name] = std::move(a.ints);
    else
      static_real_[a.name] = std::vector<Real>(a.reals.begin(), a.reals.end());
  }
  scratch_.resize(graph.ops().size());
  for (size_t o = 0; o < graph.ops().size(); ++o) {
    const OpSpec& spec = *graph.ops()[o].spec;
    for (const ScratchSpec& s : spec.scratch) {
      Scratch& buffer = scratch_[o][s.key];
      const int components = scratch_components(graph, graph.ops()[o], s);
      buffer.stride = size_t(sizes_.count(s.domain)) * components;
      buffer.is_double = spec.scratch_type(s.key) == "double";
      if (buffer.is_double)
        buffer.dbl.assign(buffer.stride * batch, 0.0);
      else
        buffer.real.assign(buffer.stride * batch, Real(0));
    }
  }
  extension_adjoint_guess_.assign(batch, {});
  newmark_adjoint_warm_start_.assign(batch, {});
}

template <class Real>
int Interpreter<Real>::extent_count(Extent e) const {
  switch (e) {
    case Extent::One: return 1;
    case Extent::Cell: return sizes_.cell;
    case Extent::Node: return sizes_.node;
    case Extent::Point: return sizes_.point;
    case Extent::Band: return sizes_.band;
    default: throw std::logic_error(fmt::format("interpreter: a part over extent {}", extent_name(e)));
  }
}

template <class Real>
void* Interpreter<Real>::bind(int o, const PartArg& a, int b) {
  const OpNode& op = graph_.ops()[o];
  switch (a.kind) {
    case PartArg::Kind::Value:
    case PartArg::Kind::Adjoint: {
      if (!op.bound(a.name)) return nullptr;  // an optional slot left unbound
      const SlotSpec* slot = op.spec->slot(a.name);
      const int t = slot->output ? op.output(a.name) : op.input(a.name);
      return (a.kind == PartArg::Kind::Value ? store_ : adjoint_).data(t, b);
    }
    case PartArg::Kind::Static:
      if (a.type == "int") return static_int_.at(a.name).data();
      return static_real_.at(a.name).data();
    case PartArg::Kind::Scratch:
      return scratch_[o].at(a.name).data(b);
  }
  return nullptr;
}

template <class Real>
void Interpreter<Real>::run_reduction(int o, const PartSpec& p, int b) {
  std::vector<double> totals;
  for (const PartArg& a : p.args) {
    if (a.kind != PartArg::Kind::Scratch) continue;
    const ScratchSpec& s = graph_.ops()[o].spec->scratch_spec(a.name);
    Scratch& buffer = scratch_[o].at(a.name);
    const int n = sizes_.count(s.domain);
    const int c = int(buffer.stride / std::max(1, n));
    for (int k = 0; k < c; ++k) {
      double sum = 0;
      for (int e = 0; e < n; ++e) sum += buffer.is_double ? buffer.dbl[buffer.stride * b + size_t(c) * e + k]
                                                          : double(buffer.real[buffer.stride * b + size_t(c) * e + k]);
      totals.push_back(sum);
    }
  }
  size_t next = 0;
  for (const PartArg& a : p.args) {
    if (a.kind == PartArg::Kind::Scratch) continue;
    Real* target = static_cast<Real*>(bind(o, a, b));
    const bool store = a.kind == PartArg::Kind::Value;  // a forward's output, else a cotangent
    const int t = store ? graph_.ops()[o].output(a.name) : graph_.ops()[o].input(a.name);
    for (int k = 0; k < graph_.tensor(t).components; ++k) {
      if (next >= totals.size()) throw std::logic_error("reduction " + p.label + ": more targets than sums");
      target[k] = store ? Real(totals[next++]) : target[k] + Real(totals[next++]);
    }
  }
  if (next != totals.size()) throw std::logic_error("reduction " + p.label + ": more sums than targets");
}

template <class Real>
void Interpreter<Real>::run_parts(int o, const std::vector<PartSpec>& parts, int b) {
  const OpNode& op = graph_.ops()[o];
  const ops::PartContext<Real> cx{Real(grid_.h), sizes_.cell, sizes_.node, sizes_.point, sizes_.band,
                                  graph_.plane_count()};
  std::vector<void*> args;
  for (const PartSpec& p : parts) {
    if (!p.requires_slot.empty() && !op.bound(p.requires_slot)) continue;
    if (p.function.name.empty()) {
      run_reduction(o, p, b);
      continue;
    }
    args.clear();
    for (const PartArg& a : p.args) args.push_back(bind(o, a, b));
    const PartLoop loop = std::is_same<Real, double>::value ? p.function.loop_double : p.function.loop_float;
    const long threshold = p.extent == Extent::Cell ? kCellParallelThreshold : kParallelThreshold;
    loop(extent_count(p.extent), &cx, args.data(), threshold);
  }
}

template <class Real>
void Interpreter<Real>::run() {
  run_prefix(int(graph_.ops().size()));
}

template <class Real>
void Interpreter<Real>::run_prefix(int op_count) {
  const int B = batch();
  report_.cg_iterations.assign(B, 0);
  report_.cg_residual.assign(B, 0.0);
  report_.extension_iterations.assign(B, 0);
  for (int o = 0; o < op_count; ++o) execute(graph_.ops().at(o));
}

template <class Real>
void Interpreter<Real>::run_op(int op) {
  const int B = batch();
  if (int(report_.cg_iterations.size()) != B) {
    report_.cg_iterations.assign(B, 0);
    report_.cg_residual.assign(B, 0.0);
    report_.extension_iterations.assign(B, 0);
  }
  execute(graph_.ops().at(op));
}

template <class Real>
void Interpreter<Real>::execute(const OpNode& op) {
  const int o = int(&op - graph_.ops().data());
  if (!op.spec->solver.empty()) {
    const SolverSchedule<Real>& s = solver_schedule<Real>(op.spec->solver);
    for_each_batch_item(batch(), [&](int b) { s.forward(*this, op, b); });
    return;
  }
  for_each_batch_item(batch(), [&](int b) { run_parts(o, op.spec->forward, b); });
}

template <class Real>
void Interpreter<Real>::clear_adjoints(bool including_inputs) {
  if (including_inputs) {  // a new backward pass
    extension_adjoint_guess_.assign(batch(), {});
    newmark_adjoint_warm_start_.assign(batch(), {});
  }
  for (size_t t = 0; t < graph_.tensors().size(); ++t)
    if (including_inputs || graph_.tensor(int(t)).role != TensorInfo::Role::Input)
      std::fill(adjoint_.all(int(t)).begin(), adjoint_.all(int(t)).end(), Real(0));
}

template <class Real>
void Interpreter<Real>::run_adjoint() {
  run_adjoint_prefix(int(graph_.ops().size()));
}

template <class Real>
void Interpreter<Real>::run_adjoint_prefix(int op_count) {
  adjoint_solves_.assign(batch(), {});
  report_.adjoint_cg_iterations.assign(batch(), 0);
  warm_adjoint_solves_ = true;
  for (int o = op_count - 1; o >= 0; --o) execute_adjoint(graph_.ops().at(o));
  warm_adjoint_solves_ = false;
}

template <class Real>
void Interpreter<Real>::run_op_adjoint(int op) {
  adjoint_solves_.assign(batch(), {});
  warm_adjoint_solves_ = false;
  report_.adjoint_cg_iterations.assign(batch(), 0);
  execute_adjoint(graph_.ops().at(op));
}

template <class Real>
void Interpreter<Real>::execute_adjoint(const OpNode& op) {
  const int o = int(&op - graph_.ops().data());
  // A solver's adjoint solve first (it leaves its solution in the op's scratch), then the
  // op's adjoint parts.
  const SolverSchedule<Real>* s = op.spec->solver.empty() ? nullptr : &solver_schedule<Real>(op.spec->solver);
  for_each_batch_item(batch(), [&](int b) {
    if (s) s->adjoint(*this, op, b);
    run_parts(o, op.spec->adjoint, b);
  });
}

template class Interpreter<double>;
template class Interpreter<float>;

}  // namespace ssc
