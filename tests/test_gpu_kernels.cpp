// Every generated kernel alone against the interpreter, on random inputs (skips without a
// usable GPU; tools/device-check.sh runs it on the device machine).
//
// The state is random: the torus turned as a whole by a random rotation of about a
// radian (every cell's corotation far from the identity, so no force is a cancelling
// difference), plus per-node noise, random velocities and, per batch item, random
// material parameters. The interpreter runs the step to fill every intermediate tensor.
// The plan's kernels are then taken in groups, the smallest runs of consecutive kernels
// that cover whole ops (a kernel may fuse parts of two ops; a solve is its stages): the
// device gets the interpreter's values of everything (the group's outputs poisoned with
// NaN, or in the adjoint the cotangents as they stand before the group's ops), runs the
// group alone, and every tensor (cotangent) the group writes must match the
// interpreter's after the same ops.
#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "codegen/kernel_plan.h"
#include "models/grid/sim_grid.h"
#include "models/sim/body.h"
#include "models/sim/simulation.h"
#include "tests/gpu_test_support.h"

namespace ssc {
namespace {

double relative_difference(const std::vector<double>& want, const std::vector<double>& got) {
  double diff = 0, norm = 0;
  for (size_t i = 0; i < want.size(); ++i) {
    diff = std::max(diff, std::isnan(got[i]) ? std::numeric_limits<double>::infinity() : std::abs(want[i] - got[i]));
    norm = std::max(norm, std::abs(want[i]));
  }
  return norm > 0 ? diff / norm : diff;
}

struct KernelGroup {
  int first = 0, last = 0;  // plan indices
  std::vector<int> ops;     // in the plan's order
  std::string names;
};

// Consecutive kernels until every op they touch has had its last kernel.
std::vector<KernelGroup> groups_of(const std::vector<PlannedKernel>& plan) {
  std::map<int, int> last_kernel;
  for (int k = 0; k < int(plan.size()); ++k)
    for (const Snippet& p : plan[k].parts) last_kernel[p.op] = k;
  std::vector<KernelGroup> out;
  KernelGroup g;
  int reach = -1;
  for (int k = 0; k < int(plan.size()); ++k) {
    if (g.ops.empty()) g.first = k;
    for (const Snippet& p : plan[k].parts) {
      if (std::find(g.ops.begin(), g.ops.end(), p.op) == g.ops.end()) g.ops.push_back(p.op);
      reach = std::max(reach, last_kernel[p.op]);
    }
    if (!plan[k].duplicate || plan[k].stage.empty()) g.names += " " + plan[k].name.substr(0, plan[k].name.find("__"));
    if (reach == k) {
      g.last = k;
      out.push_back(g);
      g = KernelGroup();
    }
  }
  return out;
}

// Tensors an op writes (forward) / whose cotangents its adjoint writes (its inputs').
std::set<int> written_by(const Graph& graph, const std::vector<int>& ops, bool adjoint) {
  std::set<int> t;
  for (int o : ops)
    for (const OpArg& a : adjoint ? graph.ops()[o].inputs : graph.ops()[o].outputs) t.insert(a.tensor);
  return t;
}

// The random state of the file comment, in a batch of two.
struct RandomStep {
  Scene scene;
  SimGrid grid;
  Simulation sim;

  explicit RandomStep(const std::vector<std::string>& overrides = {})
      : scene(torus_scene(overrides)), grid(build_body_grid(scene)), sim(scene, grid, 2, true) {
    std::mt19937_64 rng(2026);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    std::normal_distribution<double> normal(0.0, 1.0);
    for (int b = 0; b < 2; ++b) {
      PhysicalParameters p = sim.parameters(b);
      p.youngs_modulus *= std::exp(0.7 * uniform(rng));
      p.poisson_ratio = 0.3 + 0.15 * uniform(rng);
      p.density *= std::exp(0.5 * uniform(rng));
      p.mass_damping = 0.05 * (1 + uniform(rng));
      p.stiffness_damping = 0.005 * (1 + uniform(rng));
      sim.set_parameters(b, p);
    }
    const TimestepGraph& tg = sim.timestep_graph();
    TensorStore<double>& st = sim.interpreter().store();
    const int n = grid.node_count;
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (int i = 0; i < n; ++i) centre += Eigen::Vector3d::Map(&grid.node_rest[3 * i]) / n;
    for (int b = 0; b < 2; ++b) {
      const Eigen::Vector3d axis = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
      const Eigen::Matrix3d Q = Eigen::AngleAxisd(0.8 + 0.4 * uniform(rng), axis).toRotationMatrix();
      const Eigen::Vector3d omega(uniform(rng), uniform(rng), uniform(rng));
      double* u = st.data(tg.u_prev, b);
      double* v = st.data(tg.v_prev, b);
      for (int i = 0; i < n; ++i) {
        const Eigen::Vector3d x = Eigen::Vector3d::Map(&grid.node_rest[3 * i]) - centre;
        const Eigen::Vector3d du = (Q - Eigen::Matrix3d::Identity()) * x, dv = omega.cross(Q * x);
        for (int k = 0; k < 3; ++k) {
          u[3 * i + k] = du[k] + 1e-3 * grid.h * normal(rng);
          v[3 * i + k] = dv[k] + 0.05 * normal(rng);
        }
      }
      // A state without history: no acceleration carried into the solve's start.
      if (tg.v_before >= 0) std::copy_n(v, 3 * n, st.data(tg.v_before, b));
    }
    sim.interpreter().run();
  }
};

// The torus as it is, with Coulomb friction at a ground it reaches (the friction op's kernels
// and the damped time-step solve), and with every extension (material regions, a stiffness
// gradient and air drag besides friction), and with the step's nonlinear iterations (implicit
// contact, updated rotation), and with the Neo-Hookean material (lagged rotation).
const std::vector<std::vector<std::string>> kVariants = {
    {},
    {"ground.friction=0.4", "ground.height=0.1"},
    {"ground.friction=0.4", "ground.height=0.1", "air_drag=20", "material.stiffness_gradient=[1.5,-0.5,0.8]",
     R"(material.regions=[{"normal":[1,0,0],"offset":0,"youngs_modulus":9000},{"min":[-1,-1,-1],"max":[0,0.3,0],"youngs_modulus":3000}])"},
    {"ground.friction=0.4", "ground.height=0.1", "air_drag=20", "solver.contact=\"implicit\"",
     "solver.corotation=\"updated\"", "solver.nonlinear_iterations=2"},
    {"ground.height=0.1", "material.model=\"neo_hookean\"", "solver.contact=\"implicit\"",
     "solver.nonlinear_iterations=2"}};

void each_forward_kernel(const std::string& real, double tolerance, const std::vector<std::string>& overrides) {
  RandomStep r(overrides);
  Interpreter<double>& cpu = r.sim.interpreter();
  const Graph& graph = cpu.graph();
  const KernelPlan plan = plan_kernels(graph);
  const TensorStore<double> reference = cpu.store();
  GpuOptions go;
  go.real = real;
  GpuTimestep gpu(graph, r.grid, 2, gpu_options_against_interpreter(cpu.options(), real), go);
  double worst = 0;
  for (const KernelGroup& g : groups_of(plan.forward)) {
    TensorStore<double> poisoned = reference;
    const std::set<int> outputs = written_by(graph, g.ops, false);
    for (int t : outputs)
      for (double& x : poisoned.all(t)) x = std::numeric_limits<double>::quiet_NaN();
    gpu.upload(poisoned, true);
    gpu.run_kernels(false, g.first, g.last);
    std::string line;
    for (int t : outputs) {
      const TensorInfo& info = graph.tensor(t);
      // Iteration counts are compared in double; a float solve may take a different count.
      if (real == "float" && info.name.find("iterations") != std::string::npos) continue;
      std::vector<double> got(reference.all(t).size());
      TensorStore<double> back = reference;
      gpu.download(back, t);
      const double rel = relative_difference(reference.all(t), back.all(t));
      line += fmt::format(" {}={:.2g}", info.name, rel);
      worst = std::max(worst, rel);
      EXPECT_LT(rel, tolerance) << info.name << " after kernels" << g.names;
    }
    std::printf("[ %s ] forward kernels [%d..%d]%s:%s\n", real.c_str(), g.first, g.last, g.names.c_str(), line.c_str());
  }
  std::printf("[ %s ] every forward kernel: worst relative error %.3g\n", real.c_str(), worst);
}

// The Neo-Hookean correction's theta-point cotangent is the difference of two nearly equal
// terms, (R K_s R^T - dy_NH/du)^T f_bar (ops/neo_hookean.h: the iteration's stiffness is
// scaled to approximate the tangent), each computed to float precision: relative to the small
// difference, float's error is up to about 1e-7 times the terms' ratio to it (measured 2.2e-2
// on the torus's random step, 1.1e-4 in the next iteration). Double shows no such loss
// (below 1e-10); the allowance is for float alone. The float cotangents of the mass and the
// mass damping after newmark_rhs also sum terms of both signs (measured 6.7e-5 and 9.6e-5 on
// the plain torus, 1.1e-4 with air drag and material regions, once the contact points moved
// onto the exact surface); they get 10x. The friction group gets none: its float cotangents of
// the friction values and of v_prev (5.3e-4 and 9.3e-4 with friction, 3.7e-3 and 1.1e-4 with
// air drag too, on an H200 and to the digit with Interpreter<float>) came from
// adj_plane_friction forming <G, P> as tr G - n.Gn, where C_bar's normal entry, which <G, P>
// does not contain, is up to 1.2e8 times the tangential ones; with <G, P> summed over P's
// stored entries (ops/friction.h) they are at 4e-7 at most, as in every other group.
double cancellation_allowance(const std::string& real, const std::string& kernels, const std::string& tensor) {
  if (real != "float") return 1.0;
  const bool correction = kernels.find("neo_hookean_correction") != std::string::npos;
  if (correction && tensor.rfind("u_theta", 0) == 0) return 1e3;
  const bool rhs = kernels.find("newmark_rhs") != std::string::npos;
  return rhs && (tensor == "mass" || tensor == "mass_damping") ? 10.0 : 1.0;
}

void each_adjoint_kernel(const std::string& real, double tolerance, const std::vector<std::string>& overrides) {
  RandomStep r(overrides);
  Interpreter<double>& cpu = r.sim.interpreter();
  const Graph& graph = cpu.graph();
  const TimestepGraph& tg = r.sim.timestep_graph();
  const KernelPlan plan = plan_kernels(graph);
  GpuOptions go;
  go.real = real;
  GpuTimestep gpu(graph, r.grid, 2, gpu_options_against_interpreter(cpu.options(), real), go);
  gpu.upload(cpu.store(), true);
  gpu.clear_adjoints(true);
  cpu.clear_adjoints(true);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int t : {tg.u, tg.v, tg.band_u})
    for (double& x : cpu.adjoint().all(t)) x = normal(rng);
  double worst = 0;
  for (const KernelGroup& g : groups_of(plan.adjoint)) {
    const TensorStore<double> before = cpu.adjoint();
    for (int o : g.ops) cpu.run_op_adjoint(o);
    for (size_t t = 0; t < graph.tensors().size(); ++t) gpu.set_adjoint(int(t), before.all(int(t)));
    gpu.run_kernels(true, g.first, g.last);
    std::string line;
    bool changed = false;
    for (int t : written_by(graph, g.ops, true)) {
      const std::vector<double>& want = cpu.adjoint().all(t);
      std::vector<double> got(want.size());
      gpu.get_adjoint(t, got);
      const double rel = relative_difference(want, got);
      changed |= relative_difference(want, before.all(t)) > 1e-6;
      line += fmt::format(" {}={:.2g}", graph.tensor(t).name, rel);
      worst = std::max(worst, rel);
      EXPECT_LT(rel, tolerance * cancellation_allowance(real, g.names, graph.tensor(t).name))
          << graph.tensor(t).name << " after adjoint kernels" << g.names;
    }
    EXPECT_TRUE(changed) << "adjoint kernels" << g.names << " changed no cotangent: the test could not fail";
    std::printf("[ %s ] adjoint kernels [%d..%d]%s:%s\n", real.c_str(), g.first, g.last, g.names.c_str(), line.c_str());
  }
  std::printf("[ %s ] every adjoint kernel: worst relative error %.3g\n", real.c_str(), worst);
}

TEST(GpuKernels, EachForwardKernelDouble) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  for (const auto& v : kVariants) each_forward_kernel("double", 1e-10, v);
}

TEST(GpuKernels, EachForwardKernelFloat) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  for (const auto& v : kVariants) each_forward_kernel("float", 1e-4, v);
}

TEST(GpuKernels, EachAdjointKernelDouble) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  for (const auto& v : kVariants) each_adjoint_kernel("double", 1e-10, v);
}

TEST(GpuKernels, EachAdjointKernelFloat) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  for (const auto& v : kVariants) each_adjoint_kernel("float", 1e-4, v);
}

// The CPU half of the tests above, runnable anywhere: the random state steps, and the
// adjoint of every group changes some cotangent (so the GPU comparison can fail); and every
// group's adjoint in float arithmetic (Interpreter<float>, given the state and the cotangents
// rounded to float as the device is) meets EachAdjointKernelFloat's bound. The float CPU
// interpreter gave the float GPU's figures to the digit where an op's formula lost float's
// precision (the friction group, cancellation_allowance), so such a formula fails here too.
TEST(GpuKernels, RandomStateAndEveryAdjointGroupOnTheCpu) {
  for (const auto& variant : kVariants) {
  RandomStep r(variant);
  Interpreter<double>& cpu = r.sim.interpreter();
  const Graph& graph = cpu.graph();
  const TimestepGraph& tg = r.sim.timestep_graph();
  EXPECT_GT(cpu.report().cg_iterations[0], 0);
  Interpreter<float> single(graph, cpu.grid(), 2, cpu.options());
  for (int t = 0; t < cpu.store().tensor_count(); ++t)
    std::copy(cpu.store().all(t).begin(), cpu.store().all(t).end(), single.store().all(t).begin());
  cpu.clear_adjoints(true);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int t : {tg.u, tg.v, tg.band_u})
    for (double& x : cpu.adjoint().all(t)) x = normal(rng);
  for (const KernelGroup& g : groups_of(plan_kernels(graph).adjoint)) {
    const TensorStore<double> before = cpu.adjoint();
    for (int o : g.ops) cpu.run_op_adjoint(o);
    bool changed = false;
    for (int t : written_by(graph, g.ops, true))
      changed |= relative_difference(cpu.adjoint().all(t), before.all(t)) > 1e-6;
    EXPECT_TRUE(changed) << g.names;
    for (int t = 0; t < before.tensor_count(); ++t)
      std::copy(before.all(t).begin(), before.all(t).end(), single.adjoint().all(t).begin());
    for (int o : g.ops) single.run_op_adjoint(o);
    for (int t : written_by(graph, g.ops, true)) {
      const std::vector<float>& got = single.adjoint().all(t);
      const std::string& name = graph.tensor(t).name;
      EXPECT_LT(relative_difference(cpu.adjoint().all(t), std::vector<double>(got.begin(), got.end())),
                1e-4 * cancellation_allowance("float", g.names, name))
          << name << " after the float CPU interpreter's adjoint of" << g.names;
    }
  }
  }
}

TEST(GpuKernels, GroupsCoverThePlanOnce) {
  const Scene scene = torus_scene();
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid, 1, true);
  const KernelPlan plan = plan_kernels(sim.interpreter().graph());
  for (const auto* list : {&plan.forward, &plan.adjoint}) {
    const std::vector<KernelGroup> groups = groups_of(*list);
    ASSERT_FALSE(groups.empty());
    EXPECT_EQ(groups.front().first, 0);
    EXPECT_EQ(groups.back().last, int(list->size()) - 1);
    std::set<int> ops;
    for (size_t i = 0; i < groups.size(); ++i) {
      if (i > 0) {
        EXPECT_EQ(groups[i].first, groups[i - 1].last + 1);
      }
      for (int o : groups[i].ops) EXPECT_TRUE(ops.insert(o).second) << "op " << o << " in two groups";
    }
    EXPECT_EQ(ops.size(), sim.interpreter().graph().ops().size());
  }
}

}  // namespace
}  // namespace ssc
