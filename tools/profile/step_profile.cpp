// Where the CPU step of a scene goes: its forward steps timed whole (wall and process CPU
// time per step, best of three 40-step runs from the start) and op by op (after each step,
// every op run once more through Interpreter::run_op on that step's inputs), with the time-step
// solve's CG iterations (their average and step by step). Batch 1, the interpreter in double;
// threads as OMP_NUM_THREADS says.
// Usage: ssc_step_profile SCENE [STEPS]   (docs/benchmarks.md, issue 27's CPU step)
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <vector>

#include "models/sim/body.h"
#include "models/sim/simulation.h"

namespace {

double cpu_ms() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

double wall_ms() { return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

}  // namespace

int main(int argc, char** argv) {
  using namespace ssc;
  if (argc < 2) {
    std::fprintf(stderr, "usage: ssc_step_profile SCENE [STEPS]\n");
    return 1;
  }
  const Scene scene = load_scene(argv[1]);
  const SimGrid grid = build_body_grid(scene);
  const int steps = argc > 2 ? std::atoi(argv[2]) : 40;
  Simulation sim(scene, grid, 1, false);
  double best_wall = 1e300, best_cpu = 1e300;
  long iterations = 0;
  std::vector<int> by_step(steps);
  for (int run = 0; run < 3; ++run) {
    sim.reset();
    iterations = 0;
    const double w0 = wall_ms(), c0 = cpu_ms();
    for (int s = 0; s < steps; ++s) {
      sim.step();
      by_step[s] = sim.last_report().cg_iterations[0];
      iterations += by_step[s];
    }
    best_wall = std::min(best_wall, (wall_ms() - w0) / steps);
    best_cpu = std::min(best_cpu, (cpu_ms() - c0) / steps);
  }
  std::printf("%d cells, %d nodes; per step (best of 3 runs of %d steps): wall %.2f ms, CPU %.2f ms; %.2f CG "
              "iterations a step\n",
              grid.cell_count, grid.node_count, steps, best_wall, best_cpu, double(iterations) / steps);
  std::printf("CG iterations by step:");
  for (int n : by_step) std::printf(" %d", n);
  std::printf("\n");
  Interpreter<double>& in = sim.interpreter();
  const auto& ops = sim.timestep_graph().graph.ops();
  std::vector<double> op_cpu(ops.size(), 0.0);
  sim.reset();
  for (int s = 0; s < steps; ++s) {
    sim.step();
    for (size_t o = 0; o < ops.size(); ++o) {
      const double c0 = cpu_ms();
      in.run_op(int(o));
      op_cpu[o] += cpu_ms() - c0;
    }
  }
  std::printf("op by op, CPU ms a step:\n");
  for (size_t o = 0; o < ops.size(); ++o) std::printf("  %-28s %8.3f\n", ops[o].name().c_str(), op_cpu[o] / steps);
  return 0;
}
