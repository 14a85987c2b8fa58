// Times whole cost-and-gradient evaluations (models/sim/gradient.h) of a scene against its
// observations, and its forward steps alone, with every batch item at one Young's modulus
// (1 % apart); on the GPU also one forward and one adjoint step, plain and profiled per
// kernel (GpuOptions::profile). For the diagnosis timing case (docs/diagnosis.md):
//   OUT=/tmp/d TIMING=1 STARTS=1 ITERATIONS=1 tools/diagnosis-benchmark.sh build-gpu cuda
//   build-gpu/bin/ssc_gradient_timing /tmp/d/timing_360_steps/fit.json /tmp/d/timing_360_steps/obs 16 1.25e5
// Usage: ssc_gradient_timing SCENE OBSERVATIONS BATCH YOUNGS_MODULUS [cpu]
#include <chrono>
#include <cstdio>
#include <string>

#include "models/cost/surface_constraint.h"
#include "models/sim/gradient.h"
#include "models/sim/problem.h"
#include "models/sim/simulation.h"
#include "runtime/cuda_runtime.h"

namespace {

using namespace ssc;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

void set_youngs_modulus(Simulation& sim, double E) {
  for (int b = 0; b < sim.batch(); ++b) {
    PhysicalParameters p = sim.parameters(b);
    p.youngs_modulus = E * (1 + 0.01 * b);
    sim.set_parameters(b, p);
  }
}

// One forward and one adjoint step after 100 steps on the CPU, on the GPU: plain, then profiled.
void step_profile(const Problem& p, int batch, double E) {
  Simulation cpu(p.scene, p.grid, batch, true);
  set_youngs_modulus(cpu, E);
  for (int s = 0; s < 100; ++s) cpu.step();
  const TimestepGraph& tg = cpu.timestep_graph();
  TensorStore<double>& store = cpu.interpreter().store();
  for (bool profile : {false, true}) {
    GpuOptions go;
    go.profile = profile;
    GpuTimestep gpu(tg.graph, p.grid, batch, cpu.interpreter().options(), go);
    gpu.upload(store);
    auto step = [&](bool adjoint) {
      if (!adjoint) return gpu.run();
      gpu.clear_adjoints(true);
      for (int t : {tg.u, tg.v, tg.band_u}) gpu.set_adjoint(t, store.all(t));
      gpu.run_adjoint();
    };
    step(false);
    step(true);
    double ms[2];
    for (int adjoint = 0; adjoint < 2; ++adjoint) {
      const auto t0 = Clock::now();
      for (int k = 0; k < 20; ++k) step(adjoint);
      ms[adjoint] = ms_since(t0) / 20;
    }
    std::printf("%s step: forward %.3f ms, adjoint %.3f ms (%d CG iterations in its time-step solves)\n",
                profile ? "profiled" : "plain", ms[0], ms[1], gpu.adjoint_cg_iterations()[0]);
    if (!profile) continue;
    double total = 0;
    for (const GpuKernelTiming& t : gpu.timings()) total += t.ms;
    for (const GpuKernelTiming& t : gpu.timings())
      std::printf("  %-60s %5d launches %8.4f ms/launch %5.1f %%\n", t.name.c_str(), t.launches, t.ms / t.launches,
                  100 * t.ms / total);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr, "usage: %s SCENE OBSERVATIONS BATCH YOUNGS_MODULUS [cpu]\n", argv[0]);
    return 1;
  }
  const Problem p = load_problem(argv[1], {}, argv[2]);
  const int batch = std::stoi(argv[3]);
  const double E = std::stod(argv[4]);
  const bool gpu = !(argc > 5 && std::string(argv[5]) == "cpu");
  Simulation sim(p.scene, p.grid, batch, true);
  set_youngs_modulus(sim, E);
  if (gpu) sim.use_gpu();
  const SurfaceConstraintCost cost(p.grid, p.phi_max);
  const int steps = p.frames.back().step;
  std::printf("%s, batch %d, E %.3g Pa, %d steps, %zu bytes a kept step\n", gpu ? "GPU" : "CPU", batch, E, steps,
              sim.step_bytes());
  for (int round = 0; round < 3; ++round) {
    GradientOptions o;
    auto t0 = Clock::now();
    const double J = evaluate_cost_gradient(sim, cost, p.frames, o)[0].cost;
    const double whole = ms_since(t0);
    sim.reset();
    t0 = Clock::now();
    for (int s = 0; s < steps; ++s) sim.step(false);
    sim.sync_host();
    const double forward = ms_since(t0);
    sim.reset();
    std::printf("cost and gradient %.1f ms (%.3f ms a step), forward steps alone %.1f ms (%.3f ms a step); J %.5g\n",
                whole, whole / steps, forward, forward / steps, J);
  }
  if (gpu) step_profile(p, batch, E);
}
