// Levenberg-Marquardt with forward-difference Jacobians (see levenberg_marquardt.h).
#include "models/optim/levenberg_marquardt.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace ssc {
namespace {

constexpr int kMaxRejections = 30;
constexpr double kMinDamping = 1e-12;

}  // namespace

LevenbergMarquardt::LevenbergMarquardt(const Eigen::VectorXd& start, const OptimizerOptions& options, double fd_step,
                                       std::vector<char> bounded)
    : o_(options), h_(fd_step), z_(start), trial_(start), scale_(Eigen::VectorXd::Zero(start.size())),
      bounded_(std::move(bounded)) {
  if (!bounded_.empty() && bounded_.size() != size_t(start.size()))
    throw std::logic_error("LevenbergMarquardt: one bounded flag per axis");
}

bool LevenbergMarquardt::held(Eigen::Index j) const {
  return !bounded_.empty() && bounded_[size_t(j)] && std::abs(z_[j]) >= kSaturated && g_[j] * z_[j] < 0;
}

int LevenbergMarquardt::held_at_bound() const {
  int n = 0;
  for (Eigen::Index j = 0; j < z_.size(); ++j) n += g_.size() == z_.size() && held(j);
  return n;
}

double LevenbergMarquardt::cost_tolerance() const {
  const double dof = double(r_.size() - z_.size());
  const double s = o_.lm_standard_errors;
  return dof > 0 ? std::max(o_.relative_tolerance, s * s / dof) : o_.relative_tolerance;
}

double LevenbergMarquardt::projected_gradient_norm() const {
  double sum = 0;
  for (Eigen::Index j = 0; j < g_.size(); ++j)
    if (!held(j)) sum += g_[j] * g_[j];
  return std::sqrt(sum);
}

std::vector<Eigen::VectorXd> LevenbergMarquardt::ask() const {
  std::vector<Eigen::VectorXd> points(size_t(z_.size()) + 1, trial_);
  for (Eigen::Index j = 0; j < z_.size(); ++j) points[size_t(j) + 1][j] += h_;
  return points;
}

void LevenbergMarquardt::tell(const std::vector<ResidualVector>& values, const std::string& failure) {
  if (failure.empty() && values.size() != size_t(z_.size()) + 1)
    throw std::logic_error("LevenbergMarquardt::tell: one residual vector per point asked");
  accepted_ = false;
  const double infinity = std::numeric_limits<double>::infinity();
  const double cost = failure.empty() && values[0].r.allFinite() ? 0.5 * values[0].r.squaredNorm() : infinity;
  if (!started_) {
    if (!failure.empty()) {
      reason_ = "failed: simulation";
      failure_ = failure;
      return;
    }
    if (cost == infinity) {
      reason_ = "failed: non-finite residuals";
      return;
    }
    started_ = accepted_ = true;
    take(values);
    if (projected_gradient_norm() <= o_.gradient_tolerance) reason_ = "converged: gradient";
  } else if (cost < cost_) {  // rho > 0
    const double before = cost_, predicted = predicted_, rho = (cost_ - cost) / predicted_;
    z_ = trial_;
    take(values);
    ++iterations_;
    rejections_ = 0;
    accepted_ = true;
    lambda_ = std::max(kMinDamping, lambda_ * std::max(1.0 / 3.0, 1 - std::pow(2 * rho - 1, 3)));
    nu_ = 2;
    if (projected_gradient_norm() <= o_.gradient_tolerance)
      reason_ = "converged: gradient";
    else if (before - cost <= cost_tolerance() * before && predicted <= cost_tolerance() * before)
      reason_ = "converged: relative cost change < tol";
    else if (iterations_ >= o_.max_iterations)
      reason_ = "iteration limit";
  } else {
    if (++rejections_ >= kMaxRejections) {
      reason_ = "failed: no decrease after 30 damping increases";
      return;
    }
    lambda_ *= nu_;
    nu_ *= 2;
  }
  if (!done()) propose();
}

void LevenbergMarquardt::take(const std::vector<ResidualVector>& values) {
  const ResidualVector& base = values[0];
  r_ = base.r;
  cost_ = 0.5 * r_.squaredNorm();
  J_.resize(r_.size(), z_.size());
  for (Eigen::Index j = 0; j < z_.size(); ++j) {
    const ResidualVector& probe = values[size_t(j) + 1];
    if (probe.r.size() != r_.size()) throw std::logic_error("LevenbergMarquardt::tell: residual vectors differ in length");
    J_.col(j) = (probe.r - r_) / h_;
    if (!base.matched.empty())
      for (Eigen::Index i = 0; i < r_.size(); ++i)
        if (probe.matched[size_t(i)] != base.matched[size_t(i)]) J_(i, j) = 0;
  }
  g_ = J_.transpose() * r_;
  scale_ = scale_.cwiseMax(J_.colwise().squaredNorm().transpose());
}

void LevenbergMarquardt::propose() {
  const Eigen::MatrixXd JtJ = J_.transpose() * J_;
  const double largest = scale_.maxCoeff();
  std::vector<Eigen::Index> free;
  for (Eigen::Index j = 0; j < z_.size(); ++j)
    if (!held(j)) free.push_back(j);
  if (free.empty()) {
    reason_ = "converged: gradient";  // every axis at a bound it is pushed against
    return;
  }
  const Eigen::Index m = Eigen::Index(free.size());
  Eigen::MatrixXd A(m, m);
  Eigen::VectorXd b(m);
  for (Eigen::Index a = 0; a < m; ++a) {
    b[a] = -g_[free[size_t(a)]];
    for (Eigen::Index c = 0; c < m; ++c) A(a, c) = JtJ(free[size_t(a)], free[size_t(c)]);
    A(a, a) += lambda_ * std::max(scale_[free[size_t(a)]], 1e-12 * largest);
  }
  const Eigen::VectorXd step = A.ldlt().solve(b);
  Eigen::VectorXd dz = Eigen::VectorXd::Zero(z_.size());
  for (Eigen::Index a = 0; a < m; ++a) dz[free[size_t(a)]] = step[a];
  // A nearly flat axis (a parameter near its bound, where the sigmoid saturates) would get a
  // long step that lands deep in the flat part; the step keeps its direction but is shortened.
  const double longest = dz.cwiseAbs().maxCoeff();
  if (longest > o_.lm_max_step) dz *= o_.lm_max_step / longest;
  predicted_ = -(g_.dot(dz) + 0.5 * dz.dot(JtJ * dz));
  if (!dz.allFinite()) {
    reason_ = "failed: non-finite step";
    return;
  }
  if (dz.norm() <= o_.step_tolerance * (z_.norm() + o_.step_tolerance)) {
    reason_ = "converged: step < tol";
    return;
  }
  if (!(predicted_ > 0)) {  // rounding: the model sees no decrease left
    reason_ = "converged: relative cost change < tol";
    return;
  }
  trial_ = z_ + dz;
}

}  // namespace ssc
