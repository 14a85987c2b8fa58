// Reconstruction of physical parameters from observations: N perturbed starts, each an
// optimiser in the parameter space of the fitted parameters, advanced in lockstep with
// all active starts' simulations evaluated as one batch. A start whose simulation fails
// is reported and dropped; the start with the lowest final cost is the result.
//
// Starts: positive parameters are drawn log-uniformly in [low, high] x nominal (default
// [0.1, 10]), bounded ones uniformly in their bounds, free ones uniformly in
// nominal +- spread x max(|nominal|, 1) (default spread 0.5). Seeded, so a run repeats.
#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "models/optim/optimizer.h"
#include "models/optim/parameter_space.h"
#include "models/sim/problem.h"

namespace ssc {

struct ReconstructionOptions {
  std::vector<std::string> fit;  // parameter names (vectors expand)
  int starts = 20;
  std::string optimizer = "rprop";
  OptimizerOptions optimizer_options;
  std::uint64_t seed = 1;
  double low = 0.1, high = 10.0;  // multiplicative range of positive parameters
  double spread = 0.5;            // relative range of free parameters
  // Ranges [low, high] the starts of these parameters are drawn from uniformly instead (a
  // plane's height_range in the scene, models/sim/scene.h).
  std::map<std::string, std::pair<double, double>> start_ranges;
  // Typical magnitudes of free parameters (the optimiser's coordinate is x / max(|nominal|,
  // magnitude); default 1 in the parameter's unit), by name.
  std::map<std::string, double> typical_magnitudes;
  // Bounds [lower, upper] that fits of these parameters stay strictly within (plausible
  // ranges, models/sim/extensions.h): their axis becomes the sigmoid onto the bounds, for
  // every optimiser. An infinite end keeps the parameter's own transform.
  std::map<std::string, std::pair<double, double>> bounds;
  std::vector<Eigen::VectorXd> initial_values;  // overrides the sampling when non-empty (one per start)
  // With initial_values: per start, the indices of the parameters it moves; the others keep
  // their initial values (which then need not be valid on their axis: friction 0, say).
  // Starts that fit different subsets of one model's parameters so run as one batch (`ssc
  // diagnose`: the base model, its placebos and several extensions at once). Empty: all.
  std::vector<std::vector<int>> start_free;
  bool finite_differences = false;  // central differences instead of the adjoint (for comparison)
  double fd_step = 1e-4;            // in the optimiser's internal coordinates (log space: 0.01 %)
  std::string device = "cpu";       // "cuda": simulations and adjoints on the GPU (Simulation::use_gpu)
};

struct StartRecord {
  Eigen::VectorXd initial, final;   // physical values
  double final_cost = 0;
  std::vector<double> cost_history;                // per iteration (cost at the point evaluated)
  std::vector<Eigen::VectorXd> parameter_history;  // physical values per iteration
  int iterations = 0;
  std::string stop_reason;
  // At the best point told (the final values): each frame's matched and observed points and
  // their totals, the norm of the gradient in the optimiser's coordinates; and the norm at
  // the start.
  std::vector<FrameCost> frames;
  int matched_points = 0, observed_points = 0;
  double final_gradient_norm = 0, initial_gradient_norm = -1;
  bool failed = false;
  std::string failure;
};

struct ReconstructionResult {
  std::vector<std::string> names;
  std::vector<std::string> units;
  Eigen::VectorXd nominal;
  std::vector<StartRecord> starts;
  int best = -1;  // index into starts, -1 if every start failed
  int evaluations = 0;
  double wall_seconds = 0;
};

using ReconstructionProgress = std::function<void(int iteration, int active, double best_cost, const Eigen::VectorXd& best)>;

ReconstructionResult reconstruct(const Problem& problem, const ReconstructionOptions& options,
                                 const ReconstructionProgress& progress = {});

// The sampled start values (physical), exposed for tests.
// The start ranges a scene gives (its planes' height_range), by parameter name.
std::map<std::string, std::pair<double, double>> scene_start_ranges(const Scene& scene);
std::vector<Eigen::VectorXd> sample_starts(const ParameterSpace& space, const Eigen::VectorXd& nominal,
                                           const ReconstructionOptions& options);

}  // namespace ssc
