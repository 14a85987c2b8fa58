// One optimiser round's points evaluated as a batch: each point's cost and gradient (or, for
// Levenberg-Marquardt, its residual vector), a failed simulation dropping only its own points.
// The points are shared among the run's workers (models/sim/batch_workers.h: the GPUs of the
// device, the ranks of an MPI run), each keeping its batched simulation from round to round.
#pragma once
#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "models/optim/levenberg_marquardt.h"
#include "models/optim/surface_residuals.h"
#include "models/sim/gradient.h"
#include "models/sim/parameters.h"
#include "models/sim/problem.h"

namespace ssc {

// Each worker's batched simulation of the last round, kept while its number of points stays
// the same, so that a GPU's modules, buffers and captured graphs are set up once. On a GPU,
// where a step of a small batch costs what it costs for one, a batch whose starts finish is
// kept and its free places run copies of an active start; a share larger than the GPU holds
// resident runs in turns (batch_limit).
class BatchSimulations {
 public:
  BatchSimulations(const Problem& problem, std::string device);
  ~BatchSimulations();
  // Room for this many workers; called before the workers' threads start (they then touch only their own).
  void reserve_workers(int count);
  // Worker `worker`'s simulation (on `device`, "cpu" or "cuda:K") with at least n items (exactly n on the CPU).
  Simulation& batch(int worker, const std::string& device, int n);
  void forget(int worker);  // after a failure: no half-run state carries over
  // The most points a worker runs as one batch: on a GPU its resident batch
  // (GpuTimestep::resident_items), so that a point's values do not depend on how the points
  // are shared among GPUs; larger shares run in turns. No limit on the CPU.
  int batch_limit(int worker, const std::string& device);
  std::unique_ptr<Simulation> make(const std::string& device, int n) const;
  const std::string& device() const { return device_; }
  const Problem& problem() const { return problem_; }

 private:
  const Problem& problem_;
  std::string device_;
  std::vector<std::unique_ptr<Simulation>> batches_;  // per worker
  std::vector<int> limits_;                           // per worker, 0: not known yet
};

struct PointEvaluation {
  bool ok = true;
  std::string failure;  // a failed simulation's message
  CostGradient value;
  ResidualVector residuals;  // with a SurfaceResiduals only
};

// Evaluates base with names set to each point. A simulation failure that names its batch items
// (SimulationError::items) drops those points and runs the others again as one batch; one that
// does not, one point at a time, so that only the failing points are dropped. With
// `residuals`, each point's residual vector (forward simulations only: `gradient` is then
// ignored). on_step: the progress of the first worker's simulation (steps done, total).
std::vector<PointEvaluation> evaluate_batch(BatchSimulations& sims, const SurfaceConstraintCost& cost,
                                            const PhysicalParameters& base, const std::vector<std::string>& names,
                                            const std::vector<Eigen::VectorXd>& points, bool gradient,
                                            const SurfaceResiduals* residuals = nullptr,
                                            const std::function<void(int, int)>& on_step = {});

// A point's evaluation as bytes and back (the ranks of an MPI run send each other these).
std::string encode_point(const PointEvaluation& e);
PointEvaluation decode_point(const std::string& bytes);

}  // namespace ssc
