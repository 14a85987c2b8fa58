// Per-op CUDA fragments (see op_snippets.h), generic over op specs: each part of a spec
// becomes one fragment that calls the part's function of ops/ (the function the interpreter
// runs) with the kernel's bindings; a reduction part becomes a block-per-item fixed-order sum.
#include "codegen/op_snippets.h"

#include <fmt/format.h>

#include <stdexcept>

#include "codegen/snippet_builder.h"

namespace ssc {

bool is_solver(const OpNode& op) { return !op.spec->solver.empty(); }

namespace {

using namespace snippet;

std::string scratch_name(const std::string& key, int op) { return key + "_op" + std::to_string(op); }

Snippet function_snippet(const Graph& g, int op, const PartSpec& p) {
  const OpNode& o = g.ops().at(op);
  Builder b(g, op, p.label, p.extent);
  std::string call = p.function.name + "<Real>(i, cx";
  for (const PartArg& a : p.args) {
    switch (a.kind) {
      case PartArg::Kind::Value:
      case PartArg::Kind::Adjoint: {
        if (!o.bound(a.name)) {
          call += ", nullptr";  // an optional slot left unbound
          continue;
        }
        const bool value = a.kind == PartArg::Kind::Value;
        if (value)
          b.t(a.name, a.write, a.gather);
        else
          b.a(a.name, a.write, a.gather);
        call += (value ? ", $" : ", $d_") + a.name;
        break;
      }
      case PartArg::Kind::Static:
        b.grid(a.name, a.type, a.gather);
        call += ", g_" + a.name;
        break;
      case PartArg::Kind::Scratch: {
        const ScratchSpec& sc = o.spec->scratch_spec(a.name);
        b.scratch(a.name, scratch_name(a.name, op), a.type, sc.domain, scratch_components(g, o, sc), a.write, a.gather);
        call += ", $" + a.name;
        break;
      }
    }
  }
  return b.code("const ops::PartContext<Real> cx{h, n_cell, n_node, n_point, n_band, n_plane};\n" + call + ");\n");
}

// Sums the scratch sources over their domains (per component, in a fixed order: strided per
// thread, then gen::block_sum) and adds the totals to the target cotangents in turn.
Snippet reduction_snippet(const Graph& g, int op, const PartSpec& p) {
  const OpNode& o = g.ops().at(op);
  Builder b(g, op, p.label, Extent::Item);
  b.barrier();
  std::string sums, adds;
  int total = 0;
  for (const PartArg& a : p.args) {
    if (a.kind == PartArg::Kind::Scratch) {
      const ScratchSpec& sc = o.spec->scratch_spec(a.name);
      const int c = scratch_components(g, o, sc);
      b.scratch(a.name, scratch_name(a.name, op), o.spec->scratch_type(a.name), sc.domain, c, false);
      sums += fmt::format("gen::reduction_shares(acc, ${}, {}, {}, {});\n", a.name, count_expr(sc.domain), c, total);
      total += c;
    }
  }
  int offset = 0;
  for (const PartArg& a : p.args) {
    if (a.kind == PartArg::Kind::Scratch) continue;
    const bool store = a.kind == PartArg::Kind::Value;  // a forward's output, else a cotangent
    const int c = g.tensor(store ? o.output(a.name) : o.input(a.name)).components;
    if (store) {
      b.t(a.name, true);
      adds += fmt::format("gen::reduction_store(acc, ${}, {}, {});\n", a.name, c, offset);
    } else {
      b.a(a.name, true);
      adds += fmt::format("gen::reduction_add(acc, $d_{}, {}, {});\n", a.name, c, offset);
    }
    offset += c;
  }
  if (offset != total)
    throw std::logic_error(fmt::format("codegen: reduction {} of op {} sums {} values into {}", p.label, o.name(), total,
                                       offset));
  return b.code(fmt::format("double acc[{}] = {{}};\n", total) + sums + fmt::format("gen::block_sum<{}>(acc);\n", total) +
                adds);
}

std::vector<Snippet> part_snippets(const Graph& g, int op, const std::vector<PartSpec>& parts) {
  const OpNode& o = g.ops().at(op);
  std::vector<Snippet> s;
  for (const PartSpec& p : parts) {
    if (!p.requires_slot.empty() && !o.bound(p.requires_slot)) continue;
    s.push_back(p.function.name.empty() ? reduction_snippet(g, op, p) : function_snippet(g, op, p));
  }
  return s;
}

}  // namespace

std::vector<Snippet> forward_snippets(const Graph& g, int op) {
  const OpNode& o = g.ops().at(op);
  if (is_solver(o)) return solver_snippets(g, op, false);
  return part_snippets(g, op, o.spec->forward);
}

std::vector<Snippet> adjoint_snippets(const Graph& g, int op) {
  const OpNode& o = g.ops().at(op);
  std::vector<Snippet> s = is_solver(o) ? solver_snippets(g, op, true) : std::vector<Snippet>{};
  for (Snippet& p : part_snippets(g, op, o.spec->adjoint)) s.push_back(p);  // after a solver's adjoint solve
  return s;
}

}  // namespace ssc
