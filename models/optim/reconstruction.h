// Reconstruction of physical parameters from observations: N perturbed starts, each an
// optimiser in the parameter space of the fitted parameters, advanced in lockstep with
// all active starts' simulations evaluated as one batch. A start whose simulation fails
// is reported and dropped; the start with the lowest final cost is the result.
//
// Starts: positive parameters are drawn log-uniformly in [low, high] x nominal (default
// [0.1, 10]), bounded ones uniformly in their bounds, free ones uniformly in
// nominal +- spread x max(|nominal|, 1) (default spread 0.5). Seeded, so a run repeats.
// Explicit bounds (a plausible range) make a parameter's axis bounded for every optimiser
// (parameter_space.h); its starts are drawn from the part of the usual range inside them.
//
// optimizer "lm" (levenberg_marquardt.h) fits the per-point residuals (surface_residuals.h)
// instead of the cost and its adjoint gradient: each round a start's trial point and its n
// forward-difference probes, all starts' in one batch of forward simulations.
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
  std::string optimizer = "rprop";  // optimizer_names() or "lm"
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
  // ranges, models/sim/extensions.h), by expanded name; names not fitted are ignored. The axis
  // becomes bounded on them for every optimiser (with_bounds in parameter_space.h; an infinite
  // upper end keeps the parameter's own transform), the starts are drawn inside them, and a
  // start on or beyond a bound starts 2 % of the range (of the log range for a positive
  // parameter) inside it instead.
  std::map<std::string, std::pair<double, double>> bounds;
  std::vector<Eigen::VectorXd> initial_values;  // overrides the sampling when non-empty (one per start)
  // With initial_values: per start, the indices of the parameters it moves; the others keep
  // their initial values (which then need not be valid on their axis: friction 0, say).
  // Starts that fit different subsets of one model's parameters so run as one batch (`ssc
  // diagnose`: the base model, its placebos and several extensions at once). Empty: all.
  std::vector<std::vector<int>> start_free;
  // With initial_values: per start, the model it fits, where the models compete and only the
  // best is kept (`ssc diagnose`'s proposed planes, fitted as one batch). lm: a stalled start of
  // a model whose best cost is more than kCompetingMargin above the best model's does not go
  // on (in_contention; reconstruction.cpp, fit_least_squares). Empty: one model.
  std::vector<int> competing_models;
  bool finite_differences = false;  // central differences instead of the adjoint (for comparison; not with lm)
  double fd_step = 1e-4;            // in the optimiser's internal coordinates (log space: 0.01 %); also lm's
  std::string device = "cpu";       // "cuda" or "cuda:K": on the GPUs (models/sim/compute_device.h)
  // lm: the trials of up to this many more rejections evaluated with each trial where a round
  // has room (reconstruction.cpp, run_rounds); -1: SSC_LM_LOOKAHEAD=N where set, else 0. Meant
  // for the GPU, where a round costs about what its longest simulation does; off by default: the
  // diagnosis timing case, four fits to a GPU, was no faster with it (docs/reconstruction.md).
  int lm_lookahead = -1;
  // Within a round: the steps done of the batch evaluation running and their total (forward,
  // and backward with the gradient), for progress on long rounds; may be empty.
  std::function<void(int done, int total)> evaluation_progress;
};

struct StartRecord {
  Eigen::VectorXd initial, final;   // physical values
  double final_cost = 0;
  std::vector<double> cost_history;                // per iteration (cost at the point evaluated)
  std::vector<Eigen::VectorXd> parameter_history;  // physical values per iteration
  int iterations = 0;
  int restarts = 0;  // lm: how often it went on from a stall (reconstruction.cpp, check_convergence_claims)
  // The batches of the starts' rounds it took part in (lm: its first evaluation, its iterations
  // and its rejected trials, several of those a round with lm_lookahead; a GPU round costs about
  // the same however few starts take part).
  int rounds = 0;
  // "converged: ...", "iteration limit" or "failed: ..." (docs/reconstruction.md#stopping);
  // converged: the reason starts with "converged".
  std::string stop_reason;
  bool converged = false;
  // At the best point told (the final values): each frame's matched and observed points and
  // their totals, the norm of the gradient in the optimiser's coordinates; and the norm at
  // the start.
  std::vector<FrameCost> frames;
  int matched_points = 0, observed_points = 0;
  double final_gradient_norm = 0, initial_gradient_norm = -1;
  bool failed = false;  // no result: its start point's simulation failed (failure says why)
  std::string failure;
};

struct ReconstructionResult {
  std::vector<std::string> names;
  std::vector<std::string> units;
  Eigen::VectorXd nominal;
  std::vector<StartRecord> starts;
  int best = -1;  // index into starts, -1 if every start failed
  int evaluations = 0;  // simulations: forward and adjoint each, forward only for lm
  // Batches of them run (one per round of the starts, and the checks): a GPU batch costs about
  // the same however few starts are still going on, so these count its time.
  int batches = 0;
  double wall_seconds = 0;
};

using ReconstructionProgress = std::function<void(int iteration, int active, double best_cost, const Eigen::VectorXd& best)>;

// InputError unless `name` is one of optimizer_names() or "lm" (listing them).
void check_optimizer_name(const std::string& name);

ReconstructionResult reconstruct(const Problem& problem, const ReconstructionOptions& options,
                                 const ReconstructionProgress& progress = {});

// For competing models (ReconstructionOptions::competing_models: start -> model) and each
// start's cost: whether the start's model is still in contention, its best cost within
// kCompetingMargin of the lowest model's (a start with no cost, NaN or infinite, counts for
// none). Exposed for tests.
constexpr double kCompetingMargin = 0.1;
std::vector<char> in_contention(const std::vector<int>& model, const std::vector<double>& cost);

// The sampled start values (physical), exposed for tests.
// The start ranges a scene gives (its planes' height_range), by parameter name.
std::map<std::string, std::pair<double, double>> scene_start_ranges(const Scene& scene);
std::vector<Eigen::VectorXd> sample_starts(const ParameterSpace& space, const Eigen::VectorXd& nominal,
                                           const ReconstructionOptions& options);

}  // namespace ssc
