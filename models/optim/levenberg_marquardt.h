// Levenberg-Marquardt on a residual vector r(z), cost J = 1/2 ||r||^2, with an ask/tell
// interface like optimizer.h's, so that many starts advance in lockstep with their
// evaluations run as one batch. Each round a start asks for n + 1 points: the trial point z_t
// and its forward-difference probes z_t + h e_j (h = fd_step in the internal coordinates).
// Told their residual vectors, it accepts z_t if the cost fell (the probes then give the
// Jacobian there, and the next step is ready at once: one batch per iteration) or raises the
// damping and proposes a shorter step from the same point (the probes are then unused).
//
// Step: (J'J + lambda D) dz = -J'r with D the diagonal of J'J, each entry the largest seen so far
// (Marquardt's scaling kept monotone, as MINPACK does), shortened to |dz_i| <= lm_max_step
// (internal units: a factor e for a positive parameter), lambda from 1e-3 by Nielsen's rule
// (rho = actual / predicted decrease; rho > 0: accept, lambda *= max(1/3, 1 - (2 rho - 1)^3),
// nu = 2; else lambda *= nu, nu *= 2). A point whose `matched` flag differs between the trial
// and a probe gives that Jacobian entry 0: its residual switched between the robust form and a
// constant, which has no derivative (surface_residuals.h).
//
// Large residuals (a structured secant term, after Dennis, Gay and Welsch's NL2SOL, 1981): the
// cost's Hessian is J'J + sum_i r_i H_i, and Gauss-Newton keeps J'J alone. Where the model misses
// the data the second part is large, and where it is negative J'J is too curved: every step
// falls short, the cost falls by twice what the model predicted (rho about 2, which the damping
// cannot fix as it can only shorten steps), and a one-parameter fit of ssc's (a homogeneous body
// fitted to CalculiX's body of two materials) crept by 5 % a step until the iteration limit. So
// S, an estimate of the second part, is kept by the structured secant update after each
// accepted step s (y = (J_new - J_old)' r_new, sized by min(1, |s'y| / |s'Ss|), then the
// symmetric rank-two update that makes S s = y). Only S's negative part is used: a step that is
// too long is the damping's to shorten. The next step's model is J'J + S- (its curvature floored
// at 1e-6 of the largest diagonal of J'J) where the last trial's cost fell by more than 1.5
// times Gauss-Newton's prediction and that model predicted the fall better (NL2SOL's rule, gated:
// on a rough cost the actual decrease scatters about the prediction, and the secant term taken on
// that scatter made a slow start slower), else J'J alone; OptimizerOptions::lm_secant = false
// keeps J'J alone.
//
// Stop reasons (stop_reason(); converged() for the first three):
//   "converged: gradient"                      ||J'r|| <= gradient_tolerance (also at the start)
//   "converged: relative cost change < tol"    an accepted step's actual and predicted decrease
//                                              both <= tol x J, tol the larger of
//                                              relative_tolerance and s^2 / (m - n) (below)
//   "converged: step < tol"                    a proposed step ||dz|| <= step_tolerance (||z|| + step_tolerance)
//   "iteration limit"                          max_iterations accepted steps
//   "failed: simulation"                       the start point's evaluation failed (failure())
//   "failed: non-finite residuals"             at the start point
//   "failed: non-finite step"                  the damped system had no finite solution
//   "failed: no decrease after 30 damping increases"
// A failed trial or probe (a simulation that exploded at a long step) counts as a rejected step.
//
// The statistical tolerance: with m residual entries, n parameters and the residuals' variance
// estimated as 2 J / (m - n), moving the parameters by s standard errors changes J by about
// s^2 J / (m - n). A step that is predicted to lower J by less than that (s = lm_standard_errors,
// 0.1) moves them by less than a tenth of their uncertainty, so further iterations change
// nothing the data can tell. Residuals that are correlated (model error) make the true
// uncertainty larger, so this errs on the strict side. It is Bates and Watts's relative offset
// criterion in the form of a cost change; on ssc's fits it stops the iterations that went on
// lowering J by 1e-6 of itself until the iteration limit.
//
// Lookahead: a rejected trial is followed by a shorter step from the same point, and after a
// rejection the next step does not depend on the rejected cost (the model falls back to
// Gauss-Newton, the damping rises by nu). So the trials after 1, 2, ... rejections in a row are
// known in advance (lookahead()), and a driver whose batches have room can evaluate them in the
// same round and tell them in order until one is accepted: the same steps in fewer rounds
// (tell_in_order()).
//
// Bounds (a projected step): an axis marked bounded runs its parameter through a sigmoid, so the
// bound itself lies at z = +-infinity and a fit that wants a value beyond it would creep there
// until the iteration limit. Such an axis is held once it is saturated (|z| >= kSaturated: the
// parameter within 1e-3 of its range's end) and the gradient pushes it further out; the step
// and the convergence tests then run over the other axes (the gradient test on the projected
// gradient). It is released when the gradient turns inward.
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

#include "models/optim/optimizer.h"

namespace ssc {

// One evaluation: the residuals (a fixed layout for every point of one problem) and, per entry,
// whether it is in its smooth form (a matched point) or a constant (unmatched).
struct ResidualVector {
  Eigen::VectorXd r;
  std::vector<char> matched;
};

class LevenbergMarquardt {
 public:
  // bounded: per axis, whether it is a sigmoid (bounded) axis; empty: none.
  LevenbergMarquardt(const Eigen::VectorXd& start, const OptimizerOptions& options, double fd_step,
                     std::vector<char> bounded = {});
  static constexpr double kSaturated = 6.9;  // sigmoid(6.9) = 1 - 1.0e-3
  // The points to evaluate next: the trial point, then trial + fd_step e_j, j = 0..n-1.
  std::vector<Eigen::VectorXd> ask() const { return points_for(trial_); }
  // The trial point alone (ask()'s first).
  const Eigen::VectorXd& trial() const { return trial_; }
  // A trial point and its forward-difference probes, as ask() gives them.
  std::vector<Eigen::VectorXd> points_for(const Eigen::VectorXd& trial) const;
  // Their residual vectors, in that order; `failure` non-empty when any of them failed (the
  // residuals are then not read).
  void tell(const std::vector<ResidualVector>& values, const std::string& failure = "");

  // The trial points (internal coordinates) this start would ask for after 1..extra rejections
  // in a row from now; fewer where it would stop first.
  std::vector<Eigen::VectorXd> lookahead(int extra) const;
  // Tells each group of values (each the residual vectors of a trial and its probes, in ask()'s
  // order; `trials[k]` the trial point they were asked for) in order while the trials are
  // rejected and each next one is the point this start then asks for. Returns the index of the
  // group whose trial was accepted, or -1; the groups after a stop or a mismatch are not told.
  int tell_in_order(const std::vector<std::vector<ResidualVector>>& groups, const std::vector<std::string>& failures,
                    const std::vector<Eigen::VectorXd>& trials);

  bool done() const { return !reason_.empty(); }
  bool converged() const { return reason_.rfind("converged", 0) == 0; }
  int iterations() const { return iterations_; }
  const std::string& stop_reason() const { return reason_; }
  const std::string& failure() const { return failure_; }
  // The accepted point (the best told: a step is accepted only if it lowers the cost), its cost
  // and ||J'r|| there; whether the last tell() accepted its trial (the start counts).
  const Eigen::VectorXd& best_point() const { return z_; }
  double best_cost() const { return cost_; }
  double gradient_norm() const { return g_.norm(); }
  // How many axes are held at their bound at the current point (see the header comment).
  int held_at_bound() const;
  bool accepted() const { return accepted_; }
  const Eigen::MatrixXd& jacobian() const { return J_; }
  double damping() const { return lambda_; }

 private:
  void take(const std::vector<ResidualVector>& values);
  void propose();
  // Which model the next step takes: the one whose predicted decrease was nearer the actual one.
  void choose_model(double actual);
  // The structured secant update of S after the accepted step s (J_before: the Jacobian there).
  void update_secant(const Eigen::VectorXd& s, const Eigen::MatrixXd& J_before);
  // Whether axis j is held at its bound at the current point (see the header comment).
  bool held(Eigen::Index j) const;
  double projected_gradient_norm() const;
  // The relative cost change under which an accepted step counts as converged.
  double cost_tolerance() const;

  OptimizerOptions o_;
  double h_;
  Eigen::VectorXd z_, trial_, g_, r_, scale_;
  std::vector<char> matched_, bounded_;
  Eigen::MatrixXd J_, S_;
  double cost_ = 0, predicted_ = 0, lambda_ = 1e-3, nu_ = 2;
  double predicted_gauss_newton_ = 0, predicted_augmented_ = 0;
  bool augmented_ = false;
  int iterations_ = 0, rejections_ = 0;
  bool started_ = false, accepted_ = false;
  std::string reason_, failure_;
};

}  // namespace ssc
