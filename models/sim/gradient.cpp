// Adjoint driver over a whole simulation (see gradient.h).
#include "models/sim/gradient.h"

#include <cmath>
#include <map>
#include <set>
#include <stdexcept>

#include "runtime/batch_loop.h"
#include "runtime/step_backend.h"

namespace ssc {
namespace {

struct FrameSeed {
  std::vector<double> u_bar, band_bar;
};

// 0: every step kept whole (no recomputation); k > 0: the state of every k-th step.
// The budget is at most half the memory free now where the steps run (gradient.h).
int choose_checkpoint_interval(Simulation& sim, int steps, const GradientOptions& o) {
  if (o.checkpoint_every > 0) return o.checkpoint_every;
  constexpr double kHostBudget = 2e9;
  double budget = 0.5 * double(sim.backend().free_device_memory());
  if (o.memory_budget_bytes > 0)
    budget = std::min(budget, o.memory_budget_bytes);
  else if (!sim.on_gpu())
    budget = std::min(budget, kHostBudget);
  if (double(steps) * double(sim.step_bytes()) <= budget) return 0;
  const SimGrid& g = sim.grid();
  const double bytes = double(steps + 1) * sim.batch() * 8.0 * (6.0 * g.node_count + 3.0 * g.band_count);
  return bytes <= budget ? 1 : std::max(1, int(std::ceil(std::sqrt(double(steps)))));
}

}  // namespace

std::vector<CostGradient> evaluate_cost_gradient(Simulation& sim, const SurfaceConstraintCost& cost,
                                                 const std::vector<ObservedFrame>& frames,
                                                 const GradientOptions& options) {
  std::vector<int> steps;
  for (const ObservedFrame& f : frames) steps.push_back(f.step);
  return evaluate_trajectory_gradient(
      sim, steps,
      [&](size_t f, int, const double* u, const double* band, double* ub, double* bb) {
        return cost.evaluate(frames[f].points, frames[f].weight, u, band, ub, bb);
      },
      options);
}

std::vector<CostGradient> evaluate_trajectory_gradient(Simulation& sim, const std::vector<int>& frame_steps,
                                                       const FrameCostFunction& cost, const GradientOptions& options) {
  const SimGrid& g = sim.grid();
  const TimestepGraph& tg = sim.timestep_graph();
  if (tg.band_u < 0) throw std::logic_error("evaluate_cost_gradient needs a simulation built with extension");
  const int B = sim.batch();
  int steps = 0;
  std::multimap<int, size_t> frames_at;
  for (size_t f = 0; f < frame_steps.size(); ++f) {
    steps = std::max(steps, frame_steps[f]);
    frames_at.emplace(frame_steps[f], f);
  }
  const int K = choose_checkpoint_interval(sim, steps, options);
  // Only an observed step needs the band extension (the cost reads its band, and its band
  // cotangent is zero elsewhere); its warm start is then the last observed step's band.
  auto extends = [&](int t) { return frames_at.count(t) > 0; };

  std::vector<CostGradient> results(B);
  for (auto& r : results) r.frames.resize(frame_steps.size());
  // seeds[b][step] for the frames' cotangents
  std::vector<std::map<int, FrameSeed>> seeds(B);
  auto take_frame_costs = [&](int t) {
    auto range = frames_at.equal_range(t);
    if (range.first == range.second) return;
    auto item_costs = [&](int b) {
      for (auto it = range.first; it != range.second; ++it) {
        FrameSeed* seed = nullptr;
        if (options.gradient) {
          seed = &seeds[b][t];
          seed->u_bar.resize(3 * size_t(g.node_count), 0.0);
          seed->band_bar.resize(3 * size_t(g.band_count), 0.0);
        }
        const double* band = sim.band_displacement(b);  // at t = 0 the start's (the initial pose's, or 0)
        const FrameCost fc = cost(it->second, b, sim.displacement(b), band, seed ? seed->u_bar.data() : nullptr,
                                  seed ? seed->band_bar.data() : nullptr);
        results[b].frames[it->second] = fc;
        results[b].cost += fc.cost;
      }
    };
    // Batch items in parallel (the cost is const; each item writes its own seeds and results).
    for_each_batch_item(B, item_costs);
  };

  // The forward pass keeps the state on the device between frames (GPU) and, where the
  // steps run, either every step whole (K = 0, keyed by the step number: the backward pass
  // recomputes nothing) or the state after every K-th step (keyed by its step number).
  std::set<int> saved;
  struct ReleaseCheckpoints {  // also when a step fails
    Simulation& sim;
    ~ReleaseCheckpoints() { sim.clear_checkpoints(); }
  } release{sim};
  auto checkpoint = [&](int t) {
    sim.save_checkpoint(t);
    saved.insert(t);
  };
  sim.reset();
  if (options.gradient && K > 0) checkpoint(0);
  take_frame_costs(0);
  for (int t = 1; t <= steps; ++t) {
    if (options.gradient && K == 0)
      sim.step_and_keep(t, extends(t));
    else
      sim.step(false, extends(t));
    if (options.gradient && K > 0 && t % K == 0) checkpoint(t);
    if (frames_at.count(t) || t == steps) sim.sync_host();  // also checks for an explosion
    take_frame_costs(t);
    if (options.on_step) options.on_step(t, options.gradient ? 2 * steps : steps);
  }
  if (!options.gradient) return results;

  // The backward pass runs where the steps run (the interpreter's adjoint, or the generated
  // adjoint kernels on the GPU): the state's cotangents stay there from step to step, the
  // host adds the frames' seeds and reads the parameters' cotangents at the end.
  TensorStore<double>& adj = sim.interpreter().adjoint();
  StepBackend& backend = sim.backend();
  backend.clear_adjoints(true);
  const size_t n3 = 3 * size_t(g.node_count), b3 = 3 * size_t(g.band_count);
  for (int t = steps; t >= 1; --t) {
    if (options.on_step) options.on_step(2 * steps - t + 1, 2 * steps);
    if (K == 0) {
      sim.load_step(t);
      sim.drop_checkpoint(t);
    } else {
      if (!saved.count(t - 1)) {  // recompute the checkpoint segment below t from its first state
        const int base = ((t - 1) / K) * K;
        sim.load_checkpoint(base);
        for (int s = base + 1; s < t; ++s) {
          sim.step(false, extends(s));
          checkpoint(s);
        }
      }
      sim.load_checkpoint(t - 1);
      sim.recompute_step(extends(t));
      sim.drop_checkpoint(t - 1);  // no later (earlier-step) iteration needs it
      saved.erase(t - 1);
    }
    if (t == steps)
      backend.clear_adjoints(false);
    else
      backend.chain_adjoints({{tg.u_prev, tg.u}, {tg.v_prev, tg.v}});
    if (seeds[0].count(t)) {
      std::vector<double> ub(B * n3), bb(B * b3, 0.0);
      backend.get_adjoint(tg.u, ub);
      for (int b = 0; b < B; ++b) {
        const FrameSeed& s = seeds[b].at(t);
        for (size_t i = 0; i < n3; ++i) ub[b * n3 + i] += s.u_bar[i];
        std::copy(s.band_bar.begin(), s.band_bar.end(), bb.begin() + b * b3);
      }
      backend.set_adjoint(tg.u, ub);
      backend.set_adjoint(tg.band_u, bb);
    }
    if (extends(t))
      backend.run_adjoint();
    else
      backend.run_adjoint_prefix(tg.extension_op);
  }
  std::vector<std::vector<double>> v_bar(B, std::vector<double>(n3, 0.0));
  if (steps > 0) {  // the parameters' cotangents, accumulated where the steps ran
    for (size_t t = 0; t < tg.graph.tensors().size(); ++t)
      if (tg.graph.tensor(int(t)).role == TensorInfo::Role::Input) backend.get_adjoint(int(t), adj.all(int(t)));
    backend.get_adjoint(tg.v_prev, adj.all(tg.v_prev));  // the initial state's
    for (int b = 0; b < B; ++b) std::copy_n(adj.data(tg.v_prev, b), n3, v_bar[b].begin());
  }

  sim.sync_host();  // the initial state, the last one the backward pass loaded
  for (int b = 0; b < B; ++b) {
    ParameterGradient& pg = results[b].gradient;
    for (size_t t = 0; t < tg.graph.tensors().size(); ++t) {
      const TensorInfo& info = tg.graph.tensor(int(t));
      if (info.role != TensorInfo::Role::Input || info.domain != Domain::Scalar) continue;
      const double* q = adj.data(int(t), b);
      pg.input[info.name].assign(q, q + info.components);
    }
    pg.youngs_modulus = adj.data(tg.youngs_modulus, b)[0];
    pg.poisson_ratio = adj.data(tg.poisson_ratio, b)[0];
    pg.density = adj.data(tg.density, b)[0];
    pg.mass_damping = adj.data(tg.mass_damping, b)[0];
    pg.stiffness_damping = adj.data(tg.stiffness_damping, b)[0];
    for (int k = 0; k < 3; ++k) pg.gravity[k] = adj.data(tg.gravity, b)[k];
    if (tg.ground_planes >= 0) {
      const double* q = adj.data(tg.ground_planes, b);
      for (size_t p = 0; p < sim.parameters(b).planes.size(); ++p) {
        pg.plane_normal.emplace_back(q[6 * p], q[6 * p + 1], q[6 * p + 2]);
        pg.plane_height.push_back(q[6 * p + 3]);
      }
    }
    // v_0,i = v_lin + w x (x_i - c) on free nodes.
    const std::vector<char>& fixed = sim.fixed_nodes();
    for (int i = 0; i < g.node_count; ++i) {
      if (fixed[i]) continue;
      const Eigen::Vector3d vb(v_bar[b][3 * i], v_bar[b][3 * i + 1], v_bar[b][3 * i + 2]);
      const Eigen::Vector3d r =
          g.pose.rotation * (Eigen::Vector3d(g.node_rest[3 * i], g.node_rest[3 * i + 1], g.node_rest[3 * i + 2]) - sim.spin_center());
      pg.linear_velocity += vb;
      pg.angular_velocity += r.cross(vb);
    }
  }
  return results;
}

}  // namespace ssc
