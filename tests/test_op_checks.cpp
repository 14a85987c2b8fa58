// The gradient checks every registered op gets without a test of its own (graph/op_spec.h):
// each op of the registry, at the inputs a real timestep gives it (a spinning sphere sliding
// with friction into a tilted ground, with the displacement extension and every model
// extension, so that every op is in the graph and contact is active; the ops of the step's
// nonlinear iterations in the same scene with implicit contact and updated corotation, with
// Neo-Hookean and with corotated material), is
// checked in double for
//   - the dot-product test: its forward parts instantiated with Dual<double> (forward mode,
//     exact) against its adjoint parts, <y_bar, J x_dot> = <J^T y_bar, x_dot>;
//   - central finite differences of its forward against its adjoint;
//   - float against double: the float interpreter's outputs and input cotangents.
// Ops with a solver have no forward parts to differentiate: they get the FD and float checks.
// The generated CUDA of every part is checked against the interpreter on a GPU by
// GpuKernels.* (tests/test_gpu_kernels.cpp). One table is printed:
//   build/bin/ssc_tests --gtest_filter='OpChecks.*'
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fmt/format.h>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "graph/dual.h"
#include "graph/op_spec.h"
#include "models/sim/body.h"
#include "models/sim/scene.h"
#include "models/sim/simulation.h"
#include "ops/part.h"
#include "runtime/interpreter.h"
#include "runtime/static_arrays.h"

namespace ssc {
namespace {

using json = nlohmann::json;
using D = Dual<double>;

// variant 1: the step's nonlinear iterations (implicit contact, updated corotation, Neo-Hookean);
// variant 2: the same with the corotated material (each end of the step at its own rotation).
json check_scene(int variant = 0) {
  json j;
  j["object"] = {{"primitive", "sphere"}, {"radius", 0.3}, {"position", {0.05, 0.33, -0.03}}};
  j["grid"] = {{"cell_size", 0.1}, {"band_width", 2}};
  j["material"] = {{"youngs_modulus", 2e4}, {"poisson_ratio", 0.3}, {"density", 100},
                   {"mass_damping", 0.2},   {"stiffness_damping", 0.01}};
  j["material"]["regions"] = {{{"normal", {1, 0, 0}}, {"offset", 0.05}, {"youngs_modulus", 5e4}},
                              {{"min", {-0.3, 0.3, -0.3}}, {"max", {0.0, 0.5, 0.3}}, {"youngs_modulus", 1e4}}};
  j["material"]["stiffness_gradient"] = {0.5, -0.3, 0.2};
  j["air_drag"] = 30.0;
  j["gravity"] = {0, -9.81, 0};
  j["initial"] = {{"linear_velocity", {0.4, -1.2, 0.25}}, {"angular_velocity", {1.5, -2.0, 3.0}}};
  j["ground"] = {{"planes",
                  {{{"height", 0.0}, {"normal", {0.15, 1.0, -0.1}}, {"stiffness", 3e5}, {"friction", 0.4}},
                   {{"height", -0.35}, {"normal", {1, 0.2, 0}}, {"stiffness", 1e5}, {"friction", 0.2}}}}};
  j["time"] = {{"dt", 0.01}, {"steps", 4}, {"theta", 0.6}};
  j["solver"] = {{"tolerance", 1e-13}, {"max_iterations", 5000}, {"extension_tolerance", 1e-13}};
  if (variant >= 1) {
    j["solver"]["contact"] = "implicit";
    j["solver"]["corotation"] = "updated";
    j["solver"]["nonlinear_iterations"] = 2;
  }
  if (variant == 1) j["material"]["model"] = "neo_hookean";
  return j;
}

struct CheckedStep {
  Scene scene;
  SimGrid grid;
  std::unique_ptr<Simulation> sim;
};

// The sphere after four steps (in contact), with the step recomputed so that every tensor
// holds the values of one consistent step.
CheckedStep& setup(int variant = 0) {
  static CheckedStep s[3];
  if (!s[variant].sim) {
    CheckedStep& x = s[variant];
    x.scene = parse_scene(check_scene(variant), "op_checks.json");
    x.grid = build_body_grid(x.scene);
    x.sim = std::make_unique<Simulation>(x.scene, x.grid, 1, true);
    for (int n = 0; n < 4; ++n) x.sim->step();
    x.sim->recompute_step();
  }
  return s[variant];
}

struct Slot {
  std::string name;
  int tensor;
};

std::vector<Slot> differentiable(const Graph& g, const OpNode& op, bool outputs) {
  std::vector<Slot> out;
  for (const OpArg& a : outputs ? op.outputs : op.inputs) {
    const SlotSpec* s = op.spec->slot(a.slot);
    if (s->differentiable && g.tensor(a.tensor).dtype == DType::Real) out.push_back({a.slot, a.tensor});
  }
  return out;
}

double dot(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
  return s;
}

// The op's forward parts in forward mode: inputs carry x_dot, the outputs' tangents come back.
std::vector<std::vector<double>> dual_forward(const Graph& g, const StaticArrays& grid, int o,
                                              const TensorStore<double>& store,
                                              const std::vector<std::vector<double>>& x_dot,
                                              const std::vector<Slot>& inputs) {
  const OpNode& op = g.ops()[o];
  const DomainSizes sizes = domain_sizes(grid);
  std::map<std::string, std::vector<D>> values, reals, scratch;
  std::map<std::string, std::vector<int>> ints;
  for (const OpArg& a : op.inputs) {
    const std::vector<double>& v = store.all(a.tensor);
    std::vector<D>& d = values[a.slot];
    d.assign(v.begin(), v.end());
    for (size_t k = 0; k < inputs.size(); ++k)
      if (inputs[k].name == a.slot)
        for (size_t i = 0; i < d.size(); ++i) d[i].d = x_dot[k][i];
  }
  for (const OpArg& a : op.outputs) values[a.slot].assign(store.all(a.tensor).size(), D(0.0));
  for (NamedStaticArray& a : named_static_arrays(grid)) {
    if (a.is_int)
      ints[a.name] = a.ints;
    else
      reals[a.name].assign(a.reals.begin(), a.reals.end());
  }
  for (const ScratchSpec& s : op.spec->scratch) {
    const int c = scratch_components(g, op, s);
    scratch[s.key].assign(size_t(sizes.count(s.domain)) * c, D(0.0));
  }
  const ops::PartContext<D> cx{D(grid.h), sizes.cell, sizes.node, sizes.point, sizes.band, g.plane_count()};
  for (const PartSpec& p : op.spec->forward) {
    if (!p.requires_slot.empty() && !op.bound(p.requires_slot)) continue;
    if (p.function.name.empty()) {  // a forward reduction: its scratch sources' sums, in turn
      std::vector<D> totals;
      for (const PartArg& a : p.args)
        if (a.kind == PartArg::Kind::Scratch) {
          const std::vector<D>& v = scratch.at(a.name);
          const int c = scratch_components(g, op, op.spec->scratch_spec(a.name));
          for (int k = 0; k < c; ++k) {
            D sum(0.0);
            for (size_t e = k; e < v.size(); e += c) sum = sum + v[e];
            totals.push_back(sum);
          }
        }
      size_t next = 0;
      for (const PartArg& a : p.args)
        if (a.kind == PartArg::Kind::Value)
          for (D& t : values.at(a.name)) t = totals.at(next++);
      continue;
    }
    std::vector<void*> args;
    for (const PartArg& a : p.args) {
      switch (a.kind) {
        case PartArg::Kind::Value: args.push_back(op.bound(a.name) ? values.at(a.name).data() : nullptr); break;
        case PartArg::Kind::Static:
          args.push_back(a.type == "int" ? static_cast<void*>(ints.at(a.name).data()) : reals.at(a.name).data());
          break;
        case PartArg::Kind::Scratch: args.push_back(scratch.at(a.name).data()); break;
        case PartArg::Kind::Adjoint: ADD_FAILURE() << "a forward part takes a cotangent"; return {};
      }
    }
    const int n = p.extent == Extent::One ? 1 : sizes.count(extent_domain(p.extent));
    p.function.loop_dual(n, &cx, args.data(), 1L << 40);
  }
  std::vector<std::vector<double>> y_dot;
  for (const Slot& s : differentiable(g, op, true)) {
    std::vector<double> d;
    for (const D& v : values.at(s.name)) d.push_back(v.d);
    y_dot.push_back(d);
  }
  return y_dot;
}

struct CheckRow {
  std::string op, forward_parts, adjoint_parts;
  double dot = -1, fd = -1, float_out = -1, float_adj = -1;  // -1: not applicable
};

std::string part_labels(const OpSpec& s, bool adjoint) {
  std::string out = s.solver.empty() ? "" : "solver " + s.solver;
  std::set<std::string> seen;
  for (const PartSpec& p : adjoint ? s.adjoint : s.forward)
    if (seen.insert(p.label + (p.function.name.empty() ? "(sum)" : "")).second)
      out += (out.empty() ? "" : ", ") + p.label + (p.function.name.empty() ? "(sum)" : "");
  return out;
}

constexpr double kDotLimit = 1e-10, kFdLimit = 1e-6, kFloatLimit = 2e-3;

TEST(OpChecks, EveryRegisteredOpIsInTheCheckedGraph) {
  std::set<std::string> used;
  for (int variant : {0, 1, 2})
    for (const OpNode& op : setup(variant).sim->timestep_graph().graph.ops()) used.insert(op.name());
  CheckedStep& s = setup();
  for (const OpSpec& spec : op_registry())
    EXPECT_TRUE(used.count(spec.name)) << "op " << spec.name
                                       << " is registered but the checked timestep graph does not use it";
  EXPECT_GT(s.grid.contact_points.size(), 0u);
}

// A kept step's adjoint runs after later steps have overwritten the forward's scratch buffers
// (they are not tensors): an adjoint part may read a scratch buffer only after an adjoint
// part (or the solver's adjoint) has written it.
TEST(OpChecks, NoAdjointReadsTheForwardsScratch) {
  for (const OpSpec& spec : op_registry()) {
    std::set<std::string> written;
    if (!spec.solver.empty()) written.insert("w");  // the adjoint solve's solution
    for (const PartSpec& p : spec.adjoint)
      for (const PartArg& a : p.args) {
        if (a.kind != PartArg::Kind::Scratch) continue;
        if (a.write && !p.function.name.empty()) {
          written.insert(a.name);
          continue;
        }
        EXPECT_TRUE(written.count(a.name)) << spec.name << ": adjoint part " << p.label << " reads scratch $" << a.name
                                           << " before an adjoint part writes it";
      }
  }
}

TEST(OpChecks, EveryPartOfEveryOpAgainstDualNumbersFiniteDifferencesAndFloat) {
  std::mt19937_64 rng(20261124);
  std::normal_distribution<double> normal;
  std::vector<CheckRow> rows;
  std::set<std::string> checked;  // each op and binding once, in the first graph that has it
  for (int variant : {0, 1, 2}) {
  CheckedStep& s = setup(variant);
  const Graph& g = s.sim->timestep_graph().graph;
  Interpreter<double>& in = s.sim->interpreter();
  SolverOptions loose = in.options();
  loose.cg_tolerance = 1e-6;
  loose.extension_tolerance = 1e-6;
  Interpreter<float> fl(g, s.grid, 1, loose);
  for (int o = 0; o < int(g.ops().size()); ++o) {
    const OpNode& op = g.ops()[o];
    std::string binding = op.name();  // each op once per set of bound optional slots
    for (const SlotSpec& slot : op.spec->slots)
      if (slot.optional && op.bound(slot.name)) binding += " +" + slot.name;
    if (!checked.insert(binding).second) continue;
    CheckRow row{binding, part_labels(*op.spec, false), part_labels(*op.spec, true)};
    const std::vector<Slot> inputs = differentiable(g, op, false), outputs = differentiable(g, op, true);
    // Directions scaled to each input's size, cotangents to each output's.
    auto rms = [](const std::vector<double>& v) {
      double q = 0;
      for (double x : v) q += x * x;
      return std::sqrt(q / std::max<size_t>(1, v.size())) + 1e-30;
    };
    std::vector<std::vector<double>> x_dot, y_bar, x_bar;
    for (const Slot& x : inputs) {
      // Per entry, scaled to the entry (a plane's normal and its stiffness differ by 1e5).
      const std::vector<double>& v = in.store().all(x.tensor);
      const double floor = 1e-3 * rms(v);
      std::vector<double> d(v.size());
      for (size_t i = 0; i < v.size(); ++i) d[i] = (std::abs(v[i]) + floor) * normal(rng);
      x_dot.push_back(d);
    }
    in.run_op(o);
    for (const Slot& y : outputs) {
      const double scale = 1 / rms(in.store().all(y.tensor));
      std::vector<double> d(in.store().all(y.tensor).size());
      for (double& v : d) v = scale * normal(rng);
      y_bar.push_back(d);
    }
    in.clear_adjoints(true);
    for (size_t k = 0; k < outputs.size(); ++k) in.adjoint().all(outputs[k].tensor) = y_bar[k];
    in.run_op_adjoint(o);
    double reverse = 0, reverse_scale = 0;
    for (size_t k = 0; k < inputs.size(); ++k) {
      x_bar.push_back(in.adjoint().all(inputs[k].tensor));
      reverse += dot(x_bar.back(), x_dot[k]);
      for (size_t i = 0; i < x_dot[k].size(); ++i) reverse_scale += std::abs(x_bar.back()[i] * x_dot[k][i]);
    }
    reverse_scale = std::max(reverse_scale, 1e-300);
    // Dual-number forward mode.
    if (op.spec->solver.empty()) {
      const auto y_dot = dual_forward(g, s.grid, o, in.store(), x_dot, inputs);
      double forward = 0;
      for (size_t k = 0; k < outputs.size(); ++k) forward += dot(y_bar[k], y_dot[k]);
      row.dot = std::abs(forward - reverse) / reverse_scale;
      EXPECT_LT(row.dot, kDotLimit) << op.name() << ": <y_bar, J x_dot> " << forward << " vs <J^T y_bar, x_dot> " << reverse;
    }
    // Central differences (relative step 1e-7 of each entry: with friction a contact point near
    // its smoothing velocity has a curvature of order 1/eps, measured 1.3e-6 at a step of 1e-6).
    {
      const double h = 1e-7;
      std::vector<std::vector<double>> saved;
      for (const Slot& x : inputs) saved.push_back(in.store().all(x.tensor));
      double sums[2] = {0, 0};
      for (int side = 0; side < 2; ++side) {
        for (size_t k = 0; k < inputs.size(); ++k)
          for (size_t i = 0; i < saved[k].size(); ++i)
            in.store().all(inputs[k].tensor)[i] = saved[k][i] + (side ? -h : h) * x_dot[k][i];
        in.run_op(o);
        for (size_t k = 0; k < outputs.size(); ++k) sums[side] += dot(y_bar[k], in.store().all(outputs[k].tensor));
      }
      for (size_t k = 0; k < inputs.size(); ++k) in.store().all(inputs[k].tensor) = saved[k];
      in.run_op(o);
      const double fd = (sums[0] - sums[1]) / (2 * h);
      row.fd = std::abs(fd - reverse) / reverse_scale;
      EXPECT_LT(row.fd, kFdLimit) << op.name() << ": FD " << fd << " vs adjoint " << reverse;
    }
    // Float against double, at the same inputs and cotangents.
    {
      for (const OpArg& a : op.inputs) {
        const std::vector<double>& v = in.store().all(a.tensor);
        fl.store().all(a.tensor).assign(v.begin(), v.end());
      }
      fl.run_op(o);
      double err = 0, size = 1e-300;
      for (const Slot& y : outputs) {
        const std::vector<double>& yd = in.store().all(y.tensor);
        const std::vector<float>& yf = fl.store().all(y.tensor);
        for (size_t i = 0; i < yd.size(); ++i) {
          err = std::max(err, std::abs(double(yf[i]) - yd[i]));
          size = std::max(size, std::abs(yd[i]));
        }
      }
      row.float_out = err / size;
      fl.clear_adjoints(true);
      for (size_t k = 0; k < outputs.size(); ++k) fl.adjoint().all(outputs[k].tensor).assign(y_bar[k].begin(), y_bar[k].end());
      fl.run_op_adjoint(o);
      err = 0, size = 1e-300;
      for (size_t k = 0; k < inputs.size(); ++k) {
        const std::vector<float>& xf = fl.adjoint().all(inputs[k].tensor);
        for (size_t i = 0; i < xf.size(); ++i) {
          err = std::max(err, std::abs(double(xf[i]) - x_bar[k][i]));
          size = std::max(size, std::abs(x_bar[k][i]));
        }
      }
      row.float_adj = err / size;
      EXPECT_LT(row.float_out, kFloatLimit) << op.name() << " forward, float vs double";
      EXPECT_LT(row.float_adj, kFloatLimit) << op.name() << " adjoint, float vs double";
    }
    rows.push_back(row);
  }
  }
  auto cell = [](double v) { return v < 0 ? std::string("      -") : fmt::format("{:8.1e}", v); };
  std::printf("\nop checks (relative errors; limits: dot %.0e, FD %.0e, float %.0e)\n", kDotLimit, kFdLimit, kFloatLimit);
  std::printf("%-54s %-9s %-9s %-9s %-9s  %s\n", "op (+ its bound optional inputs)", "dot", "FD", "float", "float adj", "parts (forward | adjoint)");
  for (const CheckRow& r : rows)
    std::printf("%-54s %-9s %-9s %-9s %-9s  %s | %s\n", r.op.c_str(), cell(r.dot).c_str(), cell(r.fd).c_str(),
                cell(r.float_out).c_str(), cell(r.float_adj).c_str(), r.forward_parts.c_str(), r.adjoint_parts.c_str());
}

}  // namespace
}  // namespace ssc
