// Cost and exact gradient of the sparse surface constraint over a whole simulation.
//
// Forward: every batch item is simulated from its initial state; every step is kept whole
// (states and intermediates) where memory allows, else the states (u, v, band) every
// checkpoint_every steps, all where the steps run (device memory on the GPU); the cost's
// cotangents are taken at each observed frame. Backward: for t = T..1 the step is loaded
// or recomputed from state t-1 (recomputed from the last checkpoint when not stored), its
// ops' adjoints are run in reverse, and the state cotangents flow to step t-1. Parameter gradients accumulate over all steps;
// the initial velocity's gradient comes from the cotangent of v_0.
#pragma once
#include <Eigen/Core>
#include <functional>
#include <map>
#include <vector>

#include "models/cost/surface_constraint.h"
#include "models/sim/simulation.h"

namespace ssc {

struct ObservedFrame {
  int step = 0;         // simulation step the frame shows
  double weight = 1.0;
  std::vector<Eigen::Vector3d> points;  // world, metres
};

struct ParameterGradient {
  double youngs_modulus = 0, poisson_ratio = 0, density = 0, mass_damping = 0, stiffness_damping = 0;
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> plane_normal;  // d cost / d (unit normal), per plane
  std::vector<double> plane_height;
  // d cost / d (graph input) for every input of the timestep graph, by its name: what the
  // parameter rows with a graph_component read (models/sim/parameter_table.h).
  std::map<std::string, std::vector<double>> input;
  // d cost / d (the input entry a parameter row names); 0 if the graph lacks the input.
  double input_entry(const std::string& name, int component) const {
    const auto it = input.find(name);
    return it == input.end() ? 0.0 : it->second.at(size_t(component));
  }
};

struct CostGradient {
  double cost = 0;
  std::vector<FrameCost> frames;
  ParameterGradient gradient;
};

struct GradientOptions {
  bool gradient = true;
  // 0: every step kept whole (states and intermediates: nothing recomputed) if that fits in
  // the memory budget, else every step's state if that fits, else every ceil(sqrt(T))-th
  // state; k > 0: every k-th state. The memory is the device's on the GPU, else the host's;
  // the budget is at most half of what is free there now, and memory_budget_bytes if > 0
  // (default: 2 GB of host memory on the CPU; on the GPU no more than the half).
  int checkpoint_every = 0;
  double memory_budget_bytes = 0;
  // Called at every step of the forward pass and of the backward pass with the steps done
  // and the total (the forward's steps, twice that with the gradient): a long run's progress.
  std::function<void(int done, int total)> on_step;
};

// One result per batch item. The simulation must have been built with extension = true.
std::vector<CostGradient> evaluate_cost_gradient(Simulation& sim, const SurfaceConstraintCost& cost,
                                                 const std::vector<ObservedFrame>& frames,
                                                 const GradientOptions& options = {});

// Any cost that is a sum of per-frame terms of the state: frame f at frame_steps[f]
// returns its cost and, with non-null bars, adds its cotangents (active and band nodes).
using FrameCostFunction = std::function<FrameCost(size_t frame, int batch_item, const double* u, const double* band_u,
                                                  double* u_bar, double* band_bar)>;
std::vector<CostGradient> evaluate_trajectory_gradient(Simulation& sim, const std::vector<int>& frame_steps,
                                                       const FrameCostFunction& cost, const GradientOptions& options = {});

}  // namespace ssc
