// Per-step benchmarks for the torus, the dragon and a teddy-sized body (and, for what they
// cost, the torus with every model extension on, "torus-extensions", with implicit contact,
// "torus-implicit", with the rotation updated in the step, "torus-updated", and with the
// Neo-Hookean material, "torus-neo-hookean"): forward and
// forward+adjoint steps on the CPU interpreter; on the GPU (when one is usable) the
// generated forward step, the generated adjoint step, and a whole 10-step J_SSC
// gradient evaluation per step (host cost and copies included), single
// and batched; one frame's J_SSC with its cotangents on the host. With SSC_PEER_SCENE set, also
// the JAX peer's dragon (tools/bench/peer-compare.sh), whose GPU steps are timed as an
// observed step (with the band extension, as GpuForwardStep times every body) and as an
// unobserved one (GpuUnobserved...: without it, what the peer computes; a fit runs the
// extension at observed steps only), and the peer's own gradient measure (a 40-step
// trajectory's J = sum |u_T|^2 with its gradient, per step; GpuTrajectoryGradient,
// CpuTrajectoryGradient). Figures go into docs/benchmarks.md.
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>

#include "models/sim/body.h"
#include "models/sim/deformed_surface.h"
#include "models/sim/gradient.h"
#include "models/sim/simulation.h"
#include "runtime/cuda_runtime.h"

namespace ssc {
namespace {

struct Body {
  Scene scene;
  SimGrid grid;
};

Body& body(const std::string& name) {
  static std::map<std::string, std::unique_ptr<Body>> cache;
  auto& b = cache[name];
  if (!b) {
    b = std::make_unique<Body>();
    if (name == "teddy")
      b->scene = load_scene(std::string(SSC_SOURCE_DIR) + "/examples/teddy-sized.json");
    else if (name == "peer-dragon")  // the JAX peer's scene, exactly its settings (tools/bench/peer-compare.sh)
      b->scene = load_scene(std::getenv("SSC_PEER_SCENE"));
    else if (name == "torus-implicit")
      b->scene = load_scene(std::string(SSC_SOURCE_DIR) + "/examples/torus.json",
                            {"grid.band_width=0", "solver.contact=\"implicit\""});
    else if (name == "torus-updated")
      b->scene = load_scene(std::string(SSC_SOURCE_DIR) + "/examples/torus.json",
                            {"grid.band_width=0", "solver.corotation=\"updated\""});
    else if (name == "torus-neo-hookean")
      b->scene = load_scene(std::string(SSC_SOURCE_DIR) + "/examples/torus.json",
                            {"grid.band_width=0", "material.model=\"neo_hookean\""});
    else if (name == "torus-extensions")
      b->scene = load_scene(std::string(SSC_SOURCE_DIR) + "/examples/torus.json",
                            {"grid.band_width=0", "ground.friction=0.4", "air_drag=1.2",
                             "material.stiffness_gradient=[0.5,0,0]",
                             R"(material.regions=[{"normal":[1,0,0],"offset":0,"youngs_modulus":5000}])"});
    else
      b->scene = load_scene(std::string(SSC_SOURCE_DIR) + "/examples/" + name + ".json", {"grid.band_width=0"});
    b->grid = build_body_grid(b->scene);
  }
  return *b;
}

void report_size(benchmark::State& state, const Body& b) {
  state.counters["cells"] = b.grid.cell_count;
  state.counters["nodes"] = b.grid.node_count;
  state.counters["band"] = b.grid.band_count;
}

void BM_CpuForwardStep(benchmark::State& state, const std::string& name) {
  Body& b = body(name);
  Simulation sim(b.scene, b.grid, int(state.range(0)), false);
  double cg = 0;
  long steps = 0;
  for (auto _ : state) {
    if (sim.steps_taken() >= 40) sim.reset();
    sim.step();
    cg += sim.last_report().cg_iterations[0];
    ++steps;
  }
  report_size(state, b);
  state.counters["cg_iter"] = cg / double(steps);
  state.counters["batch"] = double(state.range(0));
}

// Every other surface point of the body's own 10th step.
ObservedFrame tenth_step_frame(const Body& b) {
  const DeformedSurface surface(b.grid);
  ObservedFrame frame;
  frame.step = 10;
  Simulation ref(b.scene, b.grid, 1, false);
  for (int i = 0; i < 10; ++i) ref.step();
  const auto pos = surface.positions(ref.displacement(0));
  for (size_t i = 0; i < pos.size(); i += 2) frame.points.push_back(pos[i]);
  return frame;
}

// A 10-step J_SSC evaluation with its full adjoint (forward pass, adjoint; the cost on the
// host) against tenth_step_frame, on the CPU interpreter (gpu_real empty) or the GPU. Per
// step: the `step_ms` counter.
void gradient_steps(benchmark::State& state, Body& b, int batch, const std::string& gpu_real) {
  Simulation sim(b.scene, b.grid, batch, true);
  if (!gpu_real.empty()) sim.use_gpu(gpu_real);
  const ObservedFrame frame = tenth_step_frame(b);
  const SurfaceConstraintCost cost(b.grid, 2 * b.grid.h);
  evaluate_cost_gradient(sim, cost, {frame});  // warm-up (on a GPU: kernels loaded, graphs captured)
  for (auto _ : state) benchmark::DoNotOptimize(evaluate_cost_gradient(sim, cost, {frame}));
  state.counters["step_ms"] = benchmark::Counter(10e-3, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  report_size(state, b);
  state.counters["batch"] = batch;
}

void BM_CpuGradientStep(benchmark::State& state, const std::string& name) { gradient_steps(state, body(name), 1, ""); }

// One frame's J_SSC and its cotangents on the host (what a gradient evaluation does per
// frame and batch item), for the frame of gradient_steps at the state it was taken from.
void BM_CpuFrameCost(benchmark::State& state, const std::string& name) {
  Body& b = body(name);
  const ObservedFrame frame = tenth_step_frame(b);
  Simulation sim(b.scene, b.grid, 1, true);
  for (int i = 0; i < 10; ++i) sim.step();
  const SurfaceConstraintCost cost(b.grid, 2 * b.grid.h);
  std::vector<double> u_bar(3 * size_t(b.grid.node_count)), band_bar(3 * size_t(b.grid.band_count));
  FrameCost fc;
  for (auto _ : state)
    fc = cost.evaluate(frame.points, 1.0, sim.displacement(0), sim.band_displacement(0), u_bar.data(), band_bar.data());
  report_size(state, b);
  state.counters["points"] = fc.points;
  state.counters["matched"] = fc.matched;
}

bool gpu_or_skip(benchmark::State& state) {
  const std::string why = gpu_unavailable_reason();
  if (!why.empty()) state.SkipWithError(why.c_str());
  return why.empty();
}

// The body advanced 5 steps (deformed, rotated, in contact) in every batch item.
std::unique_ptr<Simulation> deformed_batch(Body& b, int batch) {
  auto sim = std::make_unique<Simulation>(b.scene, b.grid, batch, true);
  Simulation single(b.scene, b.grid, 1, true);
  for (int i = 0; i < 5; ++i) single.step();
  for (int k = 0; k < batch; ++k) sim->set_state(k, single.state(0), 5);
  return sim;
}

void BM_GpuForwardStep(benchmark::State& state, const std::string& name, const std::string& real, bool observed) {
  if (!gpu_or_skip(state)) return;
  Body& b = body(name);
  const int batch = int(state.range(0));
  std::unique_ptr<Simulation> sim = deformed_batch(b, batch);
  GpuOptions options;
  options.real = real;
  GpuTimestep gpu(sim->timestep_graph().graph, b.grid, batch, sim->interpreter().options(), options);
  gpu.upload(sim->interpreter().store());
  const int unobserved = sim->timestep_graph().extension_op;
  auto step = [&] { observed ? gpu.run() : gpu.run_prefix(unobserved); };
  for (int k = 0; k < 2; ++k) step();  // graphs captured, first-check length settled
  for (auto _ : state) step();
  report_size(state, b);
  state.counters["cg_iter"] = gpu.cg_iterations().empty() ? 0 : gpu.cg_iterations()[0];
  state.counters["batch"] = batch;
  state.counters["compile_s"] = gpu.compile_seconds();
}

// One adjoint step on the device after one forward step, from seeds already on the device
// (restored by a device copy, so the extension's adjoint solve starts cold every time);
// the seeds are the step's own u, v and band_u (smooth fields).
void BM_GpuAdjointStep(benchmark::State& state, const std::string& name, const std::string& real, bool observed) {
  if (!gpu_or_skip(state)) return;
  Body& b = body(name);
  const int batch = int(state.range(0));
  std::unique_ptr<Simulation> sim = deformed_batch(b, batch);
  const TimestepGraph& tg = sim->timestep_graph();
  GpuOptions options;
  options.real = real;
  GpuTimestep gpu(tg.graph, b.grid, batch, sim->interpreter().options(), options);
  TensorStore<double>& store = sim->interpreter().store();
  gpu.upload(store);
  gpu.run();
  for (int t : {tg.u, tg.v, tg.band_u}) gpu.download(store, t);
  gpu.clear_adjoints(true);
  for (int t : {tg.u, tg.v, tg.band_u})
    if (observed || t != tg.band_u) gpu.set_adjoint(t, store.all(t));
  gpu.save_adjoints();
  auto adjoint_step = [&] {
    gpu.restore_adjoints();
    observed ? gpu.run_adjoint() : gpu.run_adjoint_prefix(tg.extension_op);
  };
  for (int k = 0; k < 2; ++k) adjoint_step();  // kernels loaded, graphs captured, first-check length settled
  for (auto _ : state) adjoint_step();
  report_size(state, b);
  state.counters["cg_iter"] = gpu.adjoint_cg_iterations()[0];
  state.counters["batch"] = batch;
}

// Forward steps as a fit runs them, averaged over a 40-step trajectory from rest (the peer's
// measure, and CpuForwardStep's): Simulation on the GPU, the state kept on the device, no
// extension (no cost observes the steps). The single-step benchmarks above repeat one step,
// and since the solve starts from the carried-on acceleration (ops/newmark.h) one step's CG
// iterations can be far from the trajectory's. The reported time is a step's.
void BM_GpuUnobservedRollout(benchmark::State& state, const std::string& name, const std::string& real) {
  if (!gpu_or_skip(state)) return;
  Body& b = body(name);
  const int batch = int(state.range(0));
  constexpr int kSteps = 40;
  Simulation sim(b.scene, b.grid, batch, true);
  sim.use_gpu(real);
  long iterations = 0;
  auto rollout = [&] {
    sim.reset();
    iterations = 0;
    for (int s = 0; s < kSteps; ++s) {
      sim.step(false, false);
      iterations += sim.backend().cg_iterations()[0];
    }
    sim.sync_host();
  };
  rollout();  // kernels compiled, graphs captured
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    rollout();
    state.SetIterationTime(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / kSteps);
  }
  report_size(state, b);
  state.counters["cg_iter"] = double(iterations) / kSteps;
  state.counters["batch"] = batch;
}

// The peer's gradient measure: J = sum |u_T|^2 after T = 40 steps from rest and its gradient
// (forward pass with every step kept, backward pass), as a fit runs them on the GPU; the time
// per step. The step T is observed (the extension runs there, once); the adjoint time-step
// solves warm-start from the later step's solution, the peer's transposed solves from zero.
// On the CPU interpreter where gpu_real is empty.
void trajectory_gradient(benchmark::State& state, const std::string& name, const std::string& gpu_real) {
  Body& b = body(name);
  const int batch = int(state.range(0));
  constexpr int kSteps = 40;
  Simulation sim(b.scene, b.grid, batch, true);
  if (!gpu_real.empty()) sim.use_gpu(gpu_real);
  auto last_adjoint_iterations = [&] {
    return sim.on_gpu() ? sim.gpu()->adjoint_cg_iterations()[0] : sim.last_report().adjoint_cg_iterations[0];
  };
  const size_t n3 = 3 * size_t(b.grid.node_count);
  const FrameCostFunction final_displacement = [n3](size_t, int, const double* u, const double*, double* u_bar,
                                                    double*) {
    FrameCost fc;
    for (size_t i = 0; i < n3; ++i) {
      fc.cost += u[i] * u[i];
      if (u_bar) u_bar[i] += 2 * u[i];
    }
    return fc;
  };
  // on_step is called before each backward step: the adjoint iterations of the one before.
  long adjoint_iterations = 0;
  GradientOptions options;
  options.on_step = [&](int done, int total) {
    if (done > total / 2 + 1) adjoint_iterations += last_adjoint_iterations();
  };
  auto gradient = [&] {
    adjoint_iterations = 0;
    std::vector<CostGradient> g = evaluate_trajectory_gradient(sim, {kSteps}, final_displacement, options);
    adjoint_iterations += last_adjoint_iterations();
    return g;
  };
  std::vector<CostGradient> g = gradient();  // kernels compiled, graphs captured
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    g = gradient();
    state.SetIterationTime(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / kSteps);
  }
  report_size(state, b);
  state.counters["adjoint_cg_iter"] = double(adjoint_iterations) / kSteps;
  state.counters["dJdE"] = g[0].gradient.youngs_modulus;
  state.counters["batch"] = batch;
}

void BM_GpuTrajectoryGradient(benchmark::State& state, const std::string& name, const std::string& real) {
  if (gpu_or_skip(state)) trajectory_gradient(state, name, real);
}
void BM_CpuTrajectoryGradient(benchmark::State& state, const std::string& name) { trajectory_gradient(state, name, ""); }

void BM_GpuGradientStep(benchmark::State& state, const std::string& name, const std::string& real) {
  if (gpu_or_skip(state)) gradient_steps(state, body(name), int(state.range(0)), real);
}

void register_all() {
  for (const std::string name : {"torus", "dragon", "teddy"}) {
    benchmark::RegisterBenchmark(("CpuForwardStep/" + name).c_str(), BM_CpuForwardStep, name)
        ->Arg(1)->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("CpuGradientStep/" + name).c_str(), BM_CpuGradientStep, name)
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("CpuFrameCost/" + name).c_str(), BM_CpuFrameCost, name)
        ->Unit(benchmark::kMillisecond)->UseRealTime();
    for (const std::string real : {"double", "float"}) {
      benchmark::RegisterBenchmark(("GpuForwardStep/" + name + "/" + real).c_str(), BM_GpuForwardStep, name, real, true)
          ->Arg(1)->Arg(8)->Arg(32)->Arg(128)->Unit(benchmark::kMillisecond)->UseRealTime();
      benchmark::RegisterBenchmark(("GpuAdjointStep/" + name + "/" + real).c_str(), BM_GpuAdjointStep, name, real, true)
          ->Arg(1)->Arg(8)->Arg(32)->Arg(128)->Unit(benchmark::kMillisecond)->UseRealTime();
    }
    benchmark::RegisterBenchmark(("GpuGradientStep/" + name + "/double").c_str(), BM_GpuGradientStep, name,
                                 std::string("double"))
        ->Arg(1)->Arg(32)->Unit(benchmark::kMillisecond)->UseRealTime();
  }
  // The JAX peer's dragon where SSC_PEER_SCENE names its scene (tools/bench/peer-compare.sh).
  if (const char* peer = std::getenv("SSC_PEER_SCENE"); peer && *peer) {
    const std::string name = "peer-dragon";
    benchmark::RegisterBenchmark(("CpuForwardStep/" + name).c_str(), BM_CpuForwardStep, name)
        ->Arg(1)->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("CpuGradientStep/" + name).c_str(), BM_CpuGradientStep, name)
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("CpuTrajectoryGradient/" + name).c_str(), BM_CpuTrajectoryGradient, name)
        ->Arg(1)->Unit(benchmark::kMillisecond)->UseManualTime();
    for (const std::string real : {"double", "float"}) {
      benchmark::RegisterBenchmark(("GpuForwardStep/" + name + "/" + real).c_str(), BM_GpuForwardStep, name, real, true)
          ->Arg(1)->Arg(32)->Unit(benchmark::kMillisecond)->UseRealTime();
      benchmark::RegisterBenchmark(("GpuAdjointStep/" + name + "/" + real).c_str(), BM_GpuAdjointStep, name, real, true)
          ->Arg(1)->Arg(32)->Unit(benchmark::kMillisecond)->UseRealTime();
      benchmark::RegisterBenchmark(("GpuUnobservedForwardStep/" + name + "/" + real).c_str(), BM_GpuForwardStep, name,
                                   real, false)
          ->Arg(1)->Arg(32)->Unit(benchmark::kMillisecond)->UseRealTime();
      benchmark::RegisterBenchmark(("GpuUnobservedAdjointStep/" + name + "/" + real).c_str(), BM_GpuAdjointStep, name,
                                   real, false)
          ->Arg(1)->Arg(32)->Unit(benchmark::kMillisecond)->UseRealTime();
      benchmark::RegisterBenchmark(("GpuUnobservedRollout/" + name + "/" + real).c_str(), BM_GpuUnobservedRollout, name,
                                   real)
          ->Arg(1)->Arg(32)->Unit(benchmark::kMillisecond)->UseManualTime();
      benchmark::RegisterBenchmark(("GpuTrajectoryGradient/" + name + "/" + real).c_str(), BM_GpuTrajectoryGradient,
                                   name, real)
          ->Arg(1)->Arg(32)->Unit(benchmark::kMillisecond)->UseManualTime();
    }
  }
  // torus-extensions: friction, two stiffness fields, air drag
  for (const std::string ext : {"torus-extensions", "torus-implicit", "torus-updated", "torus-neo-hookean"}) {
    benchmark::RegisterBenchmark(("CpuForwardStep/" + ext).c_str(), BM_CpuForwardStep, ext)->Arg(1)->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("GpuForwardStep/" + ext + "/double").c_str(), BM_GpuForwardStep, ext, std::string("double"), true)
        ->Arg(1)->Arg(32)->Unit(benchmark::kMillisecond)->UseRealTime();
    benchmark::RegisterBenchmark(("GpuAdjointStep/" + ext + "/double").c_str(), BM_GpuAdjointStep, ext, std::string("double"), true)
        ->Arg(1)->Arg(32)->Unit(benchmark::kMillisecond)->UseRealTime();
  }
}

}  // namespace
}  // namespace ssc

int main(int argc, char** argv) {
  ssc::register_all();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
