// Gradient-based optimisers with an ask/tell interface, so that many of them (the
// perturbed starts of one reconstruction) advance in lockstep while their cost
// evaluations run as one batch: ask() gives the point to evaluate next, tell() takes its
// cost and gradient. An iteration ends when a step is accepted; done() says whether the
// run has stopped (iteration budget, small gradient, or stalled cost). Stop reasons:
// "converged: gradient", "converged: relative cost change < tol", "iteration limit",
// "failed: non-finite cost", "failed: line search" (lbfgs), "failed: Barzilai-Borwein step
// undefined (no change in the gradient)" (gd).
//   rprop        iRprop- (Igel and Huesken 2000): sign-based steps, no step after a sign change
//   rprop-paper  the paper's R-Prop: like iRprop- but it still steps after a sign change
//   gd           gradient descent with alternating Barzilai-Borwein step sizes
//   lbfgs        L-BFGS (m = 6) with a backtracking line search on the Armijo and curvature conditions
#pragma once
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

namespace ssc {

struct OptimizerOptions {
  int max_iterations = 50;
  double gradient_tolerance = 1e-10;   // on ||dJ/dz||
  double relative_tolerance = 1e-7;    // on |J_k - J_k-1| / |J_k|, over 3 consecutive iterations (lm: one)
  double step_tolerance = 1e-8;        // lm: on ||dz|| / (||z|| + step_tolerance)
  double lm_max_step = 1.0;            // lm: largest |dz_i| of one step, in internal units
  // lm: the cost change test also passes once the step left would move the parameters by less
  // than this many standard errors (see levenberg_marquardt.h); 0 turns that off.
  double lm_standard_errors = 0.1;
  // lm: lengthen the steps of a large-residual fit with the structured secant term (see
  // levenberg_marquardt.h); false: Gauss-Newton's model alone.
  bool lm_secant = true;
  double rprop_initial_step = 0.05;    // in internal units (log space: 5 %)
  double rprop_min_step = 1e-8, rprop_max_step = 1.0;
  double gd_initial_step = 0.05;       // length of the first step in internal units
  int lbfgs_memory = 6;
};

class Optimizer {
 public:
  virtual ~Optimizer() = default;
  virtual const Eigen::VectorXd& ask() const = 0;
  virtual void tell(double cost, const Eigen::VectorXd& gradient) = 0;
  virtual bool done() const = 0;
  virtual int iterations() const = 0;
  virtual std::string stop_reason() const = 0;
  bool converged() const { return stop_reason().rfind("converged", 0) == 0; }
  // Best point told so far.
  const Eigen::VectorXd& best_point() const { return best_x_; }
  double best_cost() const { return best_cost_; }

 protected:
  void record(const Eigen::VectorXd& x, double cost) {
    if (cost < best_cost_) best_cost_ = cost, best_x_ = x;
  }
  Eigen::VectorXd best_x_;
  double best_cost_ = 1e300;
};

// InputError for an unknown name (listing the valid ones).
std::unique_ptr<Optimizer> make_optimizer(const std::string& name, const Eigen::VectorXd& start, const OptimizerOptions& options);
std::vector<std::string> optimizer_names();

}  // namespace ssc
