// R-Prop, Barzilai-Borwein gradient descent and L-BFGS (see optimizer.h).
#include "models/optim/optimizer.h"

#include <fmt/format.h>

#include <cmath>
#include <deque>

#include "runtime/errors.h"

namespace ssc {
namespace {

// Shared bookkeeping: iteration count and the stopping rules.
class StoppingRules {
 public:
  explicit StoppingRules(const OptimizerOptions& o) : o_(o) {}
  void accepted(double cost, double gradient_norm) {
    ++iterations_;
    if (!std::isfinite(cost)) {
      reason_ = "failed: non-finite cost";
      return;
    }
    if (gradient_norm <= o_.gradient_tolerance) reason_ = "converged: gradient";
    if (has_last_ && std::abs(cost - last_) <= o_.relative_tolerance * std::abs(cost)) {
      if (++stalled_ >= 3) reason_ = "converged: relative cost change < tol";
    } else {
      stalled_ = 0;
    }
    if (reason_.empty() && iterations_ >= o_.max_iterations) reason_ = "iteration limit";
    last_ = cost;
    has_last_ = true;
  }
  void stop(const std::string& why) { reason_ = why; }
  bool done() const { return !reason_.empty(); }
  int iterations() const { return iterations_; }
  const std::string& reason() const { return reason_; }

 private:
  const OptimizerOptions& o_;
  int iterations_ = 0, stalled_ = 0;
  double last_ = 0;
  bool has_last_ = false;
  std::string reason_;
};

double sign(double v) { return v > 0 ? 1.0 : (v < 0 ? -1.0 : 0.0); }

// The part every optimiser here shares: its options and stopping rules.
class RuledOptimizer : public Optimizer {
 public:
  explicit RuledOptimizer(const OptimizerOptions& o) : o_(o), rules_(o_) {}
  bool done() const override { return rules_.done(); }
  int iterations() const override { return rules_.iterations(); }
  std::string stop_reason() const override { return rules_.reason(); }

 protected:
  OptimizerOptions o_;
  StoppingRules rules_;
};

class Rprop : public RuledOptimizer {
 public:
  Rprop(const Eigen::VectorXd& x, const OptimizerOptions& o, bool paper_variant)
      : RuledOptimizer(o), paper_(paper_variant), x_(x), step_(Eigen::VectorXd::Constant(x.size(), o.rprop_initial_step)),
        last_g_(Eigen::VectorXd::Zero(x.size())) {}
  const Eigen::VectorXd& ask() const override { return x_; }
  void tell(double cost, const Eigen::VectorXd& g) override {
    record(x_, cost);
    rules_.accepted(cost, g.norm());
    if (rules_.done()) return;
    Eigen::VectorXd next_g = g;
    for (int i = 0; i < x_.size(); ++i) {
      const double s = g[i] * last_g_[i];
      if (s > 0) {
        step_[i] = std::min(step_[i] * 1.2, o_.rprop_max_step);
      } else if (s < 0) {
        step_[i] = std::max(step_[i] * 0.5, o_.rprop_min_step);
        next_g[i] = 0;
        if (!paper_) continue;
      }
      x_[i] -= sign(g[i]) * step_[i];
    }
    last_g_ = next_g;
  }

 private:
  bool paper_;
  Eigen::VectorXd x_, step_, last_g_;
};

class BarzilaiBorwein : public RuledOptimizer {
 public:
  BarzilaiBorwein(const Eigen::VectorXd& x, const OptimizerOptions& o) : RuledOptimizer(o), x_(x) {}
  const Eigen::VectorXd& ask() const override { return x_; }
  void tell(double cost, const Eigen::VectorXd& g) override {
    record(x_, cost);
    rules_.accepted(cost, g.norm());
    if (rules_.done()) return;
    double step;
    if (rules_.iterations() == 1) {
      step = o_.gd_initial_step / std::max(g.norm(), 1e-300);
    } else {
      const Eigen::VectorXd s = x_ - last_x_, y = g - last_g_;
      const double sy = s.dot(y);
      step = rules_.iterations() % 2 == 0 ? s.dot(s) / sy : sy / y.dot(y);
      step = std::abs(step);
      if (!std::isfinite(step) || step == 0) {
        rules_.stop("failed: Barzilai-Borwein step undefined (no change in the gradient)");
        return;
      }
      // Never move more than the first step's length times 10 in one go.
      step = std::min(step, 10 * o_.gd_initial_step / std::max(g.norm(), 1e-300));
    }
    last_x_ = x_;
    last_g_ = g;
    x_ -= step * g;
  }

 private:
  Eigen::VectorXd x_, last_x_, last_g_;
};

class Lbfgs : public RuledOptimizer {
 public:
  Lbfgs(const Eigen::VectorXd& x, const OptimizerOptions& o) : RuledOptimizer(o), x_(x), trial_(x) {}
  const Eigen::VectorXd& ask() const override { return trial_; }
  void tell(double cost, const Eigen::VectorXd& g) override {
    record(trial_, cost);
    if (!have_base_) {  // the first evaluation: the start point
      accept(cost, g);
      return;
    }
    const double slope = g.dot(direction_);
    const bool armijo = std::isfinite(cost) && cost <= f_ + 1e-4 * alpha_ * slope0_;
    const bool curvature = std::abs(slope) <= 0.9 * std::abs(slope0_);
    if (armijo && (curvature || trials_ >= 10)) {
      const Eigen::VectorXd s = trial_ - x_, y = g - g_;
      if (s.dot(y) > 1e-12 * s.norm() * y.norm()) {
        s_.push_back(s);
        y_.push_back(y);
        if (int(s_.size()) > o_.lbfgs_memory) s_.pop_front(), y_.pop_front();
      }
      x_ = trial_;
      accept(cost, g);
      return;
    }
    if (++trials_ > 20) {
      rules_.stop("failed: line search");
      return;
    }
    // Armijo failed: shrink; curvature failed with a descent slope: grow.
    alpha_ = armijo && slope < 0 ? alpha_ * 2.0 : alpha_ * 0.5;
    trial_ = x_ + alpha_ * direction_;
  }
  bool done() const override { return rules_.done(); }
  int iterations() const override { return rules_.iterations(); }
  std::string stop_reason() const override { return rules_.reason(); }

 private:
  void accept(double cost, const Eigen::VectorXd& g) {
    if (have_base_) rules_.accepted(cost, g.norm());
    have_base_ = true;
    f_ = cost;
    g_ = g;
    if (rules_.done()) return;
    if (g.norm() <= o_.gradient_tolerance) {
      rules_.stop("converged: gradient");
      return;
    }
    // Two-loop recursion.
    Eigen::VectorXd q = g;
    std::vector<double> a(s_.size());
    for (int i = int(s_.size()) - 1; i >= 0; --i) {
      a[i] = s_[i].dot(q) / y_[i].dot(s_[i]);
      q -= a[i] * y_[i];
    }
    const double gamma = s_.empty() ? o_.gd_initial_step / std::max(g.norm(), 1e-300)
                                    : s_.back().dot(y_.back()) / y_.back().dot(y_.back());
    q *= gamma;
    for (size_t i = 0; i < s_.size(); ++i) q += s_[i] * (a[i] - y_[i].dot(q) / y_[i].dot(s_[i]));
    direction_ = -q;
    slope0_ = g.dot(direction_);
    if (slope0_ >= 0) {  // not a descent direction: restart from steepest descent
      s_.clear();
      y_.clear();
      direction_ = -(o_.gd_initial_step / std::max(g.norm(), 1e-300)) * g;
      slope0_ = g.dot(direction_);
    }
    alpha_ = 1.0;
    trials_ = 0;
    trial_ = x_ + direction_;
  }

  Eigen::VectorXd x_, trial_, g_, direction_;
  std::deque<Eigen::VectorXd> s_, y_;
  double f_ = 0, alpha_ = 1, slope0_ = 0;
  int trials_ = 0;
  bool have_base_ = false;
};

}  // namespace

std::vector<std::string> optimizer_names() { return {"rprop", "rprop-paper", "gd", "lbfgs"}; }

std::unique_ptr<Optimizer> make_optimizer(const std::string& name, const Eigen::VectorXd& start, const OptimizerOptions& o) {
  if (name == "rprop") return std::make_unique<Rprop>(start, o, false);
  if (name == "rprop-paper") return std::make_unique<Rprop>(start, o, true);
  if (name == "gd") return std::make_unique<BarzilaiBorwein>(start, o);
  if (name == "lbfgs") return std::make_unique<Lbfgs>(start, o);
  throw InputError(fmt::format("unknown optimizer '{}'; choose one of rprop, rprop-paper, gd, lbfgs", name));
}

}  // namespace ssc
