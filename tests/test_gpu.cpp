// The generated kernels on a GPU against the CPU interpreter (every test here but the CPU
// twin of the explosion test skips without a usable GPU; tools/device-check.sh runs them
// on the device machine):
//  - GpuForward: one forward step, double and float, every tensor compared; determinism;
//    the host-driven solves (grid solves off) too; Simulation's steps without the extension;
//    steps that keep the state on the device, and device checkpoints, against host steps;
//    an exploding simulation inside a gradient evaluation ends in a SimulationError;
//  - GpuProfile: per-kernel profile and step times of the torus and the teddy-sized body,
//    per-kernel times of batches of 32 (teddy-sized, dragon);
//  - GpuExtension: the extension's one- and two-phase grid solves give the same bits;
//  - GpuAdjoint: one adjoint step from random cotangents (every input and state
//    cotangent compared), determinism, and a whole trajectory's gradient per parameter
//    with the backward pass on the GPU against the interpreter's.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <random>

#include "models/grid/sim_grid.h"
#include "runtime/errors.h"
#include "models/sim/body.h"
#include "models/sim/gradient.h"
#include "models/sim/simulation.h"
#include "runtime/cuda_runtime.h"
#include "tests/gpu_test_support.h"
#include "tests/synthetic_frame_cost.h"

namespace ssc {
namespace {

// max |x - y| / max |x|
double relative_difference(const std::vector<double>& x, const std::vector<double>& y) {
  double diff = 0, norm = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    diff = std::max(diff, std::abs(x[i] - y[i]));
    norm = std::max(norm, std::abs(x[i]));
  }
  return norm > 0 ? diff / norm : diff;
}

// Returns the GPU's step outputs.
TensorStore<double> gpu_vs_interpreter(const std::string& real, double tolerance, GpuOptions go = {},
                                       const Scene& scene = torus_scene()) {
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid, 2, true);
  PhysicalParameters p = sim.parameters(1);
  p.youngs_modulus *= 1.7;  // batch items differ
  p.linear_velocity = Eigen::Vector3d(0.3, -1.0, 0.2);
  sim.set_parameters(1, p);
  for (int s = 0; s < 3; ++s) sim.step();  // a deformed, moving state
  Interpreter<double>& cpu = sim.interpreter();
  TensorStore<double> before = cpu.store();
  const SolverOptions so = gpu_options_against_interpreter(cpu.options(), real);
  go.real = real;
  GpuTimestep gpu(cpu.graph(), grid, 2, so, go);
  gpu.upload(before);
  gpu.run();
  TensorStore<double> got = before;
  gpu.download(got);
  cpu.run();
  // The step's outputs (u, v, band_u) against the tolerance; intermediates are printed:
  // the offset force -R K (R^T x - x) cancels for small rotations, so its relative error
  // is that of R (a few ULP from cbrt) amplified, not a property of the generated code.
  std::string which, all;
  double err = 0;
  std::map<std::string, double> rel_of;
  for (size_t t = 0; t < cpu.graph().tensors().size(); ++t) {
    const TensorInfo& info = cpu.graph().tensor(int(t));
    if (info.role != TensorInfo::Role::Intermediate) continue;
    const double rel = relative_difference(cpu.store().all(int(t)), got.all(int(t)));
    all += fmt::format(" {}={:.2g}", info.name, rel);
    rel_of[info.name] = rel;
    if ((info.name == "u" || info.name == "v" || info.name == "band_u") && rel >= err) {
      err = rel;
      which = info.name;
    }
  }
  // v = (u - u_prev) / (theta dt) - (1 - theta) / theta v_prev (ops/newmark.h): u holds the
  // initial pose's rigid displacement (max |u| 3.15 on the torus) and a step adds 1.3e-2 to it,
  // so u's error relative to max |u| reaches v amplified by A = max(|u|, |u_prev|) / (theta dt
  // max |v|), 378 here. v is held to u's own error plus four roundings (u, u_prev, their
  // difference, the update) times A, or to the tolerance where that is larger. Measured in
  // float, the same digits on an H200 and with Interpreter<float> on the CPU from the same
  // state: u 2.5e-7, v 1.05e-4 (v from that float u in double: 9.6e-5 = A 2.5e-7); bound 1.85e-4.
  const TimestepGraph& tg = sim.timestep_graph();
  double theta_dt = std::numeric_limits<double>::infinity();
  for (int b = 0; b < 2; ++b)
    theta_dt = std::min(theta_dt, cpu.store().data(tg.theta, b)[0] * cpu.store().data(tg.dt, b)[0]);
  const auto max_abs = [](const std::vector<double>& x) {
    double m = 0;
    for (double y : x) m = std::max(m, std::abs(y));
    return m;
  };
  const double amplification = std::max(max_abs(cpu.store().all(tg.u)), max_abs(cpu.store().all(tg.u_prev))) /
                               (theta_dt * max_abs(cpu.store().all(tg.v)));
  const double unit_roundoff = real == "float" ? std::ldexp(1.0, -24) : std::ldexp(1.0, -53);
  const double v_bound = std::max(tolerance, amplification * (rel_of.at("u") + 4 * unit_roundoff));
  std::printf("[ %s ] per-tensor relative error:%s\n", real.c_str(), all.c_str());
  std::printf("[ %s ] GPU vs interpreter: worst relative error %.3g (%s); v's amplification of u's error %.3g, "
              "its bound %.3g; CG iterations GPU %d/%d, CPU %d/%d; compile %.2f s for %d kernels\n",
              real.c_str(), err, which.c_str(), amplification, v_bound, gpu.cg_iterations()[0], gpu.cg_iterations()[1],
              cpu.report().cg_iterations[0], cpu.report().cg_iterations[1], gpu.compile_seconds(), gpu.kernel_count());
  // The same start (ops/galerkin_start.h) from sums in another order: the same CG path up to
  // rounding, so in double the same iteration count give or take one.
  if (real == "double")
    for (int b = 0; b < 2; ++b) EXPECT_NEAR(gpu.cg_iterations()[b], cpu.report().cg_iterations[b], 1) << "item " << b;
  EXPECT_LT(rel_of.at("u"), tolerance) << "u";
  EXPECT_LT(rel_of.at("band_u"), tolerance) << "band_u";
  EXPECT_LT(rel_of.at("v"), v_bound) << "v (amplification " << amplification << ")";
  // Determinism: a second run from the same inputs is bitwise equal.
  gpu.upload(before);
  gpu.run();
  TensorStore<double> again = before;
  gpu.download(again);
  for (size_t t = 0; t < cpu.graph().tensors().size(); ++t)
    EXPECT_TRUE(again.all(int(t)) == got.all(int(t))) << cpu.graph().tensor(int(t)).name;
  return got;
}

TEST(GpuForward, DoubleMatchesInterpreter) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  gpu_vs_interpreter("double", 1e-10);
}

TEST(GpuForward, FloatMatchesInterpreter) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  gpu_vs_interpreter("float", 1e-4);
}

// The host-driven solves (used when a batch does not fit on the GPU at once).
TEST(GpuForward, HostDrivenSolvesMatchInterpreter) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  GpuOptions go;
  go.grid_solves = false;
  gpu_vs_interpreter("double", 1e-10, go);
}

// Fixed nodes (a Dirichlet box over the lowest quarter of the torus): the start's directions
// are zero there, so their element applies do not vanish as a translation's does.
TEST(GpuForward, FixedNodesMatchInterpreter) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  Scene scene = torus_scene();
  const SimGrid grid = build_body_grid(scene);
  Eigen::Vector3d lo = grid.node_start(0), hi = lo;
  for (int i = 1; i < grid.node_count; ++i) {
    lo = lo.cwiseMin(grid.node_start(i));
    hi = hi.cwiseMax(grid.node_start(i));
  }
  const Eigen::Vector3d margin = Eigen::Vector3d::Constant(1.0);
  scene.dirichlet.push_back({lo - margin, Eigen::Vector3d(hi.x() + 1, lo.y() + 0.25 * (hi.y() - lo.y()), hi.z() + 1)});
  for (const char* real : {"double", "float"})
    for (bool grid_solves : {true, false}) {
      SCOPED_TRACE(fmt::format("{}, grid solves {}", real, grid_solves));
      GpuOptions go;
      go.grid_solves = grid_solves;
      gpu_vs_interpreter(real, std::string(real) == "double" ? 1e-10 : 1e-4, go, scene);
    }
}

// A graph without the extension (what `ssc simulate` runs), stepped through Simulation:
// after the first step the state stays on the device.
TEST(GpuForward, SimulationWithoutExtensionMatchesInterpreter) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  const Scene scene = torus_scene();
  const SimGrid grid = build_body_grid(scene);
  Simulation cpu(scene, grid, 1, false), gpu(scene, grid, 1, false);
  gpu.use_gpu();
  for (int s = 0; s < 6; ++s) {
    cpu.step();
    gpu.step();
  }
  const size_t n = 3 * size_t(grid.node_count);
  const std::vector<double> u_cpu(cpu.displacement(0), cpu.displacement(0) + n),
      u_gpu(gpu.displacement(0), gpu.displacement(0) + n), v_cpu(cpu.velocity(0), cpu.velocity(0) + n),
      v_gpu(gpu.velocity(0), gpu.velocity(0) + n);
  const double err = std::max(relative_difference(u_cpu, u_gpu), relative_difference(v_cpu, v_gpu));
  std::printf("[ double ] 6 steps without the extension, GPU vs interpreter: %.3g\n", err);
  EXPECT_LT(err, 1e-10);
}

// Steps that leave the state on the device, and device checkpoints, give the bits of
// steps that copy every state back; the host state is refused until synced.
TEST(GpuForward, DeviceOnlyStepsAndCheckpointsMatchHostSteps) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  const Scene scene = torus_scene();
  const SimGrid grid = build_body_grid(scene);
  Simulation host(scene, grid, 2, true), device(scene, grid, 2, true);
  for (Simulation* sim : {&host, &device}) {
    sim->use_gpu();
    PhysicalParameters p = sim->parameters(1);
    p.angular_velocity = Eigen::Vector3d(0.5, 2.0, -0.4);
    sim->set_parameters(1, p);
  }
  std::vector<std::vector<double>> at3;
  for (int s = 1; s <= 6; ++s) {
    host.step();
    if (s == 3)
      for (int b = 0; b < 2; ++b) at3.push_back(host.state(b).u);
    device.step(false);
    if (s == 3) device.save_checkpoint(7);
  }
  EXPECT_THROW(device.displacement(0), std::logic_error);
  device.sync_host();
  const size_t n = 3 * size_t(grid.node_count), nb = 3 * size_t(grid.band_count);
  for (int b = 0; b < 2; ++b) {
    EXPECT_EQ(std::vector<double>(host.displacement(b), host.displacement(b) + n),
              std::vector<double>(device.displacement(b), device.displacement(b) + n));
    EXPECT_EQ(std::vector<double>(host.velocity(b), host.velocity(b) + n),
              std::vector<double>(device.velocity(b), device.velocity(b) + n));
    EXPECT_EQ(std::vector<double>(host.band_displacement(b), host.band_displacement(b) + nb),
              std::vector<double>(device.band_displacement(b), device.band_displacement(b) + nb));
  }
  device.load_checkpoint(7);
  EXPECT_EQ(device.steps_taken(), 3);
  device.sync_host();
  for (int b = 0; b < 2; ++b)
    EXPECT_EQ(at3[b], std::vector<double>(device.displacement(b), device.displacement(b) + n));
  device.drop_checkpoint(7);
  EXPECT_THROW(device.load_checkpoint(7), std::logic_error);
}

// A weightless torus thrown at the ground explodes within a few steps: the gradient's
// forward pass (on the GPU the state stays on the device between frames) must end in a
// SimulationError that names a step, on either backend.
void exploding_gradient_fails_cleanly(bool gpu) {
  const Scene scene = torus_scene({"material.density=1e-6", "initial.linear_velocity=[0,-20,0]"});
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid, 1, true);
  if (gpu) sim.use_gpu();
  const FrameCostFunction cost = [](size_t, int, const double*, const double*, double*, double*) { return FrameCost(); };
  try {
    evaluate_trajectory_gradient(sim, {20, 40}, cost, {});
    ADD_FAILURE() << "the weightless torus did not fail";
  } catch (const SimulationError& e) {
    std::printf("[ %s ] exploding simulation: %s\n", gpu ? "cuda" : "cpu", e.what());
    EXPECT_NE(std::string(e.what()).find("step "), std::string::npos) << e.what();
  }
}

TEST(GpuForward, ExplodingGradientFailsCleanlyOnTheCpu) { exploding_gradient_fails_cleanly(false); }

TEST(GpuForward, ExplodingGradientFailsCleanly) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  exploding_gradient_fails_cleanly(true);
}

TEST(GpuForward, ReportsMissingGpuCleanly) {
  const std::string why = gpu_unavailable_reason();
  if (why.empty()) GTEST_SKIP() << "a GPU is present: " << gpu_description();
  EXPECT_EQ(why.rfind("no usable GPU: ", 0), 0u) << why;
  const TimestepGraph t = build_timestep_graph(0, false);
  SimGrid grid;
  try {
    GpuTimestep gpu(t.graph, grid, 1, SolverOptions{});
    FAIL() << "expected GpuUnavailable";
  } catch (const GpuUnavailable& e) {
    EXPECT_EQ(std::string(e.what()).rfind("no usable GPU: ", 0), 0u) << e.what();
  }
}

void print_timings(const GpuTimestep& gpu, const char* real, const char* body) {
  for (const GpuKernelTiming& t : gpu.timings())
    std::printf("  %-7s %-12s %-52s %5d launches %8.4f ms/launch %4d regs\n", real, body, t.name.c_str(), t.launches,
                t.ms / t.launches, t.registers);
}

// Per-kernel launches and times (synchronised after every launch) of a forward and an
// adjoint step, and the unprofiled step times, for the torus and the teddy-sized body
// (and the per-kernel times of batches of 32 teddy-sized and dragon simulations).
TEST(GpuProfile, TorusAndTeddySteps) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  for (const char* body : {"torus", "teddy-sized"}) {
    const Scene scene = load_scene(std::string(SSC_SOURCE_DIR) + "/examples/" + body + ".json");
    const SimGrid grid = build_body_grid(scene);
    Simulation sim(scene, grid, 1, true);
    for (int s = 0; s < 5; ++s) sim.step();
    const TimestepGraph& tg = sim.timestep_graph();
    TensorStore<double>& store = sim.interpreter().store();
    for (const char* real : {"double", "float"}) {
      auto step = [&](GpuTimestep& gpu, bool adjoint) {
        if (!adjoint) return gpu.run();
        gpu.clear_adjoints(true);
        for (int t : {tg.u, tg.v, tg.band_u}) gpu.set_adjoint(t, store.all(t));
        gpu.run_adjoint();
      };
      GpuOptions go;
      go.real = real;
      GpuTimestep fast(tg.graph, grid, 1, sim.interpreter().options(), go);
      fast.upload(store);
      fast.run();
      for (int t : {tg.u, tg.v, tg.band_u}) fast.download(store, t);  // seeds: the step's own fields
      fast.upload(store);
      double ms[2];
      for (int adjoint = 0; adjoint < 2; ++adjoint) {
        step(fast, adjoint);
        const auto start = std::chrono::steady_clock::now();
        for (int k = 0; k < 10; ++k) step(fast, adjoint);
        ms[adjoint] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() / 10;
      }
      std::printf("[ %s ] %s step on %s: forward %.3f ms (%d CG iterations), adjoint %.3f ms (%d CG iterations), "
                  "%d cells, %d nodes, %d band nodes\n",
                  real, body, gpu_description().c_str(), ms[0], fast.cg_iterations()[0], ms[1],
                  fast.adjoint_cg_iterations()[0], grid.cell_count, grid.node_count, grid.band_count);
      go.profile = true;
      GpuTimestep gpu(tg.graph, grid, 1, sim.interpreter().options(), go);
      gpu.upload(store);
      step(gpu, false);
      step(gpu, true);
      print_timings(gpu, real, body);
    }
  }
  // A batch of 32 simulations (the perturbed starts of a reconstruction): the teddy-sized
  // body and the dragon (whole grid as band, as in the benchmarks).
  for (const char* body : {"teddy-sized", "dragon"}) {
    const std::string path = std::string(SSC_SOURCE_DIR) + "/examples/" + body + ".json";
    const Scene scene = std::string(body) == "dragon" ? load_scene(path, {"grid.band_width=0"}) : load_scene(path);
    const SimGrid grid = build_body_grid(scene);
    Simulation sim(scene, grid, 32, true);
    for (int s = 0; s < 2; ++s) sim.step();
    const TimestepGraph& tg = sim.timestep_graph();
    TensorStore<double>& store = sim.interpreter().store();
    GpuOptions go;
    go.profile = true;
    GpuTimestep gpu(tg.graph, grid, 32, sim.interpreter().options(), go);
    gpu.upload(store);
    gpu.run();
    gpu.clear_adjoints(true);
    for (int t : {tg.u, tg.v, tg.band_u}) gpu.set_adjoint(t, store.all(t));
    gpu.run_adjoint();
    print_timings(gpu, "double", (std::string(body) + " x32").c_str());
  }
}

// ---- adjoint ----

// Returns the GPU's cotangents of the inputs and states (empty for intermediates).
std::vector<std::vector<double>> adjoint_vs_interpreter(const std::string& real, double tolerance,
                                                        GpuOptions go = {}) {
  const Scene scene = torus_scene();
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid, 2, true);
  PhysicalParameters p = sim.parameters(1);
  p.youngs_modulus *= 0.6;  // batch items differ
  p.angular_velocity = Eigen::Vector3d(0.5, 2.0, -0.4);
  sim.set_parameters(1, p);
  for (int s = 0; s < 4; ++s) sim.step();
  const TimestepGraph& tg = sim.timestep_graph();
  Interpreter<double>& cpu = sim.interpreter();
  go.real = real;
  GpuTimestep gpu(cpu.graph(), grid, 2, gpu_options_against_interpreter(cpu.options(), real), go);
  gpu.upload(cpu.store());
  gpu.run();
  cpu.run();
  // Random cotangents of the step's outputs.
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  TensorStore<double>& adj = cpu.adjoint();
  auto seed_both = [&] {
    cpu.clear_adjoints(true);
    gpu.clear_adjoints(true);
    rng.seed(11);
    for (int t : {tg.u, tg.v, tg.band_u}) {
      for (double& x : adj.all(t)) x = normal(rng);
      gpu.set_adjoint(t, adj.all(t));
    }
  };
  seed_both();
  gpu.save_adjoints();
  cpu.run_adjoint();
  gpu.run_adjoint();
  std::string which, all;
  double worst = 0;
  std::vector<std::vector<double>> first(cpu.graph().tensors().size());
  for (size_t t = 0; t < cpu.graph().tensors().size(); ++t) {
    const TensorInfo& info = cpu.graph().tensor(int(t));
    if (info.role == TensorInfo::Role::Intermediate) continue;
    first[t] = adj.all(int(t));
    gpu.get_adjoint(int(t), first[t]);
    const double rel = relative_difference(adj.all(int(t)), first[t]);
    all += fmt::format(" {}={:.2g}", info.name, rel);
    if (rel >= worst) worst = rel, which = info.name;
  }
  std::printf("[ %s ] adjoint step, GPU vs interpreter, per input/state cotangent:%s\n", real.c_str(), all.c_str());
  std::printf("[ %s ] worst %.3g (%s); adjoint CG iterations GPU %d/%d\n", real.c_str(), worst, which.c_str(),
              gpu.adjoint_cg_iterations()[0], gpu.adjoint_cg_iterations()[1]);
  EXPECT_LT(worst, tolerance) << which;
  // Determinism: the same seeds (restored on the device, a fresh backward pass) give
  // bitwise the same cotangents.
  gpu.restore_adjoints();
  gpu.run_adjoint();
  for (size_t t = 0; t < first.size(); ++t) {
    if (first[t].empty()) continue;
    std::vector<double> again(first[t].size());
    gpu.get_adjoint(int(t), again);
    EXPECT_TRUE(again == first[t]) << cpu.graph().tensor(int(t)).name;
  }
  return first;
}

TEST(GpuAdjoint, DoubleStepMatchesInterpreter) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  adjoint_vs_interpreter("double", 1e-10);
}

// Float against the double interpreter: the worst cotangent is stiffness_damping's w^T K u,
// which cancels. On an H200 it differed by 1.1e-3 with the forward solves' Galerkin start
// (ops/galerkin_start.h), 8.5e-4 in a build whose adjoint solves took that start too: float's
// u and w along other CG paths, within the solves' tolerance. Double agrees within 4e-12.
TEST(GpuAdjoint, FloatStepMatchesInterpreter) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  adjoint_vs_interpreter("float", 2e-3);
}

// The extension's two grid solves (one phase per iteration for latency, two for
// throughput) evaluate the same expressions: the same bits, forward and adjoint; each
// against the interpreter. The dense product (the default, runtime/band_operator.h) is off:
// the other tests check it.
TEST(GpuExtension, OneAndTwoPhaseGridSolvesGiveTheSameBits) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  GpuOptions one, two;
  one.extension_phases = 1;
  two.extension_phases = 2;
  one.dense_extension = two.dense_extension = false;
  const TensorStore<double> a = gpu_vs_interpreter("double", 1e-10, one), b = gpu_vs_interpreter("double", 1e-10, two);
  for (int t = 0; t < a.tensor_count(); ++t) EXPECT_TRUE(a.all(t) == b.all(t)) << "tensor " << t;
  const auto da = adjoint_vs_interpreter("double", 1e-10, one), db = adjoint_vs_interpreter("double", 1e-10, two);
  for (size_t t = 0; t < da.size(); ++t) EXPECT_TRUE(da[t] == db[t]) << "cotangent " << t;
}

// The time-step system's two grid solves (one phase per iteration, the node gathers at the
// cell corners, for latency; two, the node update storing u and the element apply of u, for
// throughput), each with its setup inside, are the same PCG iterates in another order of
// sums: each against the interpreter, forward and adjoint, in double and float.
TEST(GpuForward, OneAndTwoPhaseTimeStepSolvesMatchTheInterpreter) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  for (int phases : {1, 2}) {
    SCOPED_TRACE(fmt::format("{} phase(s) per iteration", phases));
    GpuOptions go;
    go.newmark_phases = phases;
    gpu_vs_interpreter("double", 1e-10, go);
    gpu_vs_interpreter("float", 1e-4, go);
    adjoint_vs_interpreter("double", 1e-10, go);
    adjoint_vs_interpreter("float", 2e-3, go);  // as FloatStepMatchesInterpreter
  }
}

// A whole trajectory (12 steps, frames at 4, 8 and 12, contact, checkpointing every 5
// steps) with a cost linear in u and quadratic in the band: the GPU backward pass against
// the interpreter's, per parameter.
void trajectory_gradient_matches_interpreter(std::vector<std::string> overrides, const char* label) {
  overrides.push_back("solver.tolerance=1e-12");
  overrides.push_back("solver.extension_tolerance=1e-13");
  const Scene scene = torus_scene(overrides);
  const SimGrid grid = build_body_grid(scene);
  const FrameCostFunction cost = synthetic_frame_cost(grid);
  // CPU and GPU with state checkpoints every 5 steps (recomputed segments); the GPU again
  // with every step kept whole on the device (the default for short runs).
  GradientOptions checkpoints, whole;
  checkpoints.checkpoint_every = 5;
  std::vector<CostGradient> results[3];
  for (int run = 0; run < 3; ++run) {
    Simulation sim(scene, grid, 2, true);
    if (run > 0) sim.use_gpu();
    PhysicalParameters p = sim.parameters(1);
    p.youngs_modulus *= 1.4;
    p.linear_velocity = Eigen::Vector3d(0.4, -1.5, 0.1);
    sim.set_parameters(1, p);
    results[run] = evaluate_trajectory_gradient(sim, {4, 8, 12}, cost, run < 2 ? checkpoints : whole);
  }
  for (int b = 0; b < 2; ++b) {
    EXPECT_EQ(results[1][b].cost, results[2][b].cost);
    const ParameterGradient &r = results[1][b].gradient, &k = results[2][b].gradient;
    EXPECT_TRUE(r.youngs_modulus == k.youngs_modulus && r.poisson_ratio == k.poisson_ratio && r.density == k.density &&
                r.mass_damping == k.mass_damping && r.stiffness_damping == k.stiffness_damping &&
                r.gravity == k.gravity && r.linear_velocity == k.linear_velocity &&
                r.angular_velocity == k.angular_velocity && r.plane_height == k.plane_height &&
                r.plane_normal == k.plane_normal && r.input == k.input)
        << "item " << b << ": steps kept whole on the device differ from recomputed steps";
  }
  for (int b = 0; b < 2; ++b) {
    const ParameterGradient &c = results[0][b].gradient, &g = results[1][b].gradient;
    std::vector<std::pair<std::string, std::pair<double, double>>> pairs = {
        {"youngs_modulus", {c.youngs_modulus, g.youngs_modulus}},
        {"poisson_ratio", {c.poisson_ratio, g.poisson_ratio}},
        {"density", {c.density, g.density}},
        {"mass_damping", {c.mass_damping, g.mass_damping}},
        {"stiffness_damping", {c.stiffness_damping, g.stiffness_damping}}};
    for (int k = 0; k < 3; ++k) {
      pairs.push_back({fmt::format("gravity[{}]", k), {c.gravity[k], g.gravity[k]}});
      pairs.push_back({fmt::format("linear_velocity[{}]", k), {c.linear_velocity[k], g.linear_velocity[k]}});
      pairs.push_back({fmt::format("angular_velocity[{}]", k), {c.angular_velocity[k], g.angular_velocity[k]}});
    }
    ASSERT_EQ(c.plane_height.size(), g.plane_height.size());
    for (size_t k = 0; k < c.plane_height.size(); ++k) {
      pairs.push_back({"plane_height", {c.plane_height[k], g.plane_height[k]}});
      for (int j = 0; j < 3; ++j) pairs.push_back({fmt::format("plane_normal[{}]", j), {c.plane_normal[k][j], g.plane_normal[k][j]}});
      pairs.push_back({"friction", {c.input_entry("friction", 2 * int(k)), g.input_entry("friction", 2 * int(k))}});
    }
    double worst = 0;
    std::string which;
    for (const auto& [name, v] : pairs) {
      const double rel = std::abs(v.first - v.second) / std::max(std::abs(v.first), 1e-12);
      if (rel >= worst) worst = rel, which = name;
    }
    std::printf("[ double ] trajectory gradient%s, item %d: cost CPU %.12g GPU %.12g; worst parameter relative "
                "difference %.3g (%s)\n", label, b,
                results[0][b].cost, results[1][b].cost, worst, which.c_str());
    EXPECT_LT(worst, 1e-8) << label << " " << which;
  }
}

TEST(GpuAdjoint, TrajectoryGradientMatchesInterpreter) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  trajectory_gradient_matches_interpreter({}, "");
}

TEST(GpuAdjoint, FrictionTrajectoryGradientMatchesInterpreter) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  trajectory_gradient_matches_interpreter({"ground.friction=0.4"}, " with friction");
}

TEST(GpuAdjoint, ExtensionsTrajectoryGradientMatchesInterpreter) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  trajectory_gradient_matches_interpreter(
      {"ground.friction=0.4", "air_drag=20", "material.stiffness_gradient=[1.5,-0.5,0.8]",
       R"(material.regions=[{"normal":[1,0,0],"offset":0,"youngs_modulus":9000}])", "solver.contact=\"implicit\"",
       "solver.corotation=\"updated\"", "solver.nonlinear_iterations=2"},
      " with every extension, implicit contact and updated rotation");
}

TEST(GpuAdjoint, NeoHookeanTrajectoryGradientMatchesInterpreter) {
  SKIP_WITHOUT_GPU();
  test_cache_root();
  trajectory_gradient_matches_interpreter({"material.model=\"neo_hookean\"", "solver.contact=\"implicit\"",
                                           "solver.nonlinear_iterations=3"},
                                          " with the Neo-Hookean material and implicit contact");
}

}  // namespace
}  // namespace ssc
