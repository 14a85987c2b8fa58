// Levenberg-Marquardt with forward-difference Jacobians (see levenberg_marquardt.h).
#include "models/optim/levenberg_marquardt.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace ssc {
namespace {

constexpr int kMaxRejections = 30;
constexpr double kMinDamping = 1e-12;
constexpr double kCurvatureFloor = 1e-6;  // of the largest diagonal of J'J seen
// The secant term is taken only where the cost fell by more than this times Gauss-Newton's
// prediction: J'J clearly too curved, not a rough cost's scatter about it.
constexpr double kSecantEvidence = 1.5;

// A matrix over the free axes placed into an n x n one (zero on the held axes).
Eigen::MatrixXd on_axes(const Eigen::MatrixXd& H, const std::vector<Eigen::Index>& free, Eigen::Index n) {
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(n, n);
  for (size_t a = 0; a < free.size(); ++a)
    for (size_t c = 0; c < free.size(); ++c) out(free[a], free[c]) = H(Eigen::Index(a), Eigen::Index(c));
  return out;
}

}  // namespace

LevenbergMarquardt::LevenbergMarquardt(const Eigen::VectorXd& start, const OptimizerOptions& options, double fd_step,
                                       std::vector<char> bounded)
    : o_(options), h_(fd_step), z_(start), trial_(start), scale_(Eigen::VectorXd::Zero(start.size())),
      bounded_(std::move(bounded)), S_(Eigen::MatrixXd::Zero(start.size(), start.size())) {
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

std::vector<Eigen::VectorXd> LevenbergMarquardt::points_for(const Eigen::VectorXd& trial) const {
  std::vector<Eigen::VectorXd> points(size_t(z_.size()) + 1, trial);
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
    choose_model(cost_ - cost);
    const Eigen::MatrixXd J_before = J_;
    const Eigen::VectorXd z_before = z_;
    z_ = trial_;
    take(values);
    update_secant(z_ - z_before, J_before);
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
    if (cost < std::numeric_limits<double>::infinity())
      choose_model(cost_ - cost);
    else
      augmented_ = false;  // a failed simulation: back to the Gauss-Newton model
    if (++rejections_ >= kMaxRejections) {
      reason_ = "failed: no decrease after 30 damping increases";
      return;
    }
    lambda_ *= nu_;
    nu_ *= 2;
  }
  if (!done()) propose();
}

std::vector<Eigen::VectorXd> LevenbergMarquardt::lookahead(int extra) const {
  std::vector<Eigen::VectorXd> out;
  if (!started_ || done()) return out;
  LevenbergMarquardt next = *this;
  for (int k = 0; k < extra; ++k) {
    next.tell({}, "lookahead: a rejected trial");  // a rejection; its cost does not shape the next step
    if (next.done()) break;
    out.push_back(next.trial_);
  }
  return out;
}

int LevenbergMarquardt::tell_in_order(const std::vector<std::vector<ResidualVector>>& groups,
                                      const std::vector<std::string>& failures, const std::vector<Eigen::VectorXd>& trials) {
  for (size_t k = 0; k < groups.size(); ++k) {
    if (done() || (k > 0 && trial_ != trials[k])) break;
    tell(groups[k], failures[k]);
    if (accepted_) return int(k);
  }
  return -1;
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

void LevenbergMarquardt::choose_model(double actual) {
  augmented_ = o_.lm_secant && actual > kSecantEvidence * predicted_gauss_newton_ &&
               std::abs(actual - predicted_augmented_) < std::abs(actual - predicted_gauss_newton_);
}

void LevenbergMarquardt::update_secant(const Eigen::VectorXd& s, const Eigen::MatrixXd& J_before) {
  const double ss = s.squaredNorm();
  if (!(ss > 0)) return;
  const Eigen::VectorXd y = (J_ - J_before).transpose() * r_;  // the Hessian's second-order part along s
  const double sSs = s.dot(S_ * s);
  if (sSs != 0) S_ *= std::min(1.0, std::abs(s.dot(y)) / std::abs(sSs));  // sizing
  const Eigen::VectorXd w = y - S_ * s;
  S_ += (w * s.transpose() + s * w.transpose()) / ss - (w.dot(s) / (ss * ss)) * (s * s.transpose());
  if (!S_.allFinite()) S_.setZero();
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
  Eigen::MatrixXd gauss_newton(m, m), lowering(m, m);
  Eigen::VectorXd b(m);
  for (Eigen::Index a = 0; a < m; ++a) {
    b[a] = -g_[free[size_t(a)]];
    for (Eigen::Index c = 0; c < m; ++c) {
      gauss_newton(a, c) = JtJ(free[size_t(a)], free[size_t(c)]);
      lowering(a, c) = S_(free[size_t(a)], free[size_t(c)]);
    }
  }
  {  // the secant term's negative part only (see the header); the sum's curvature floored
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(lowering);
    lowering = eigen.eigenvectors() * eigen.eigenvalues().cwiseMin(0.0).asDiagonal() * eigen.eigenvectors().transpose();
    eigen.compute(gauss_newton + lowering);
    lowering = eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(kCurvatureFloor * largest).asDiagonal() *
                   eigen.eigenvectors().transpose() - gauss_newton;
  }
  Eigen::MatrixXd A = augmented_ ? Eigen::MatrixXd(gauss_newton + lowering) : gauss_newton;
  for (Eigen::Index a = 0; a < m; ++a) A(a, a) += lambda_ * std::max(scale_[free[size_t(a)]], 1e-12 * largest);
  const Eigen::VectorXd step = A.ldlt().solve(b);
  Eigen::VectorXd dz = Eigen::VectorXd::Zero(z_.size());
  for (Eigen::Index a = 0; a < m; ++a) dz[free[size_t(a)]] = step[a];
  // A nearly flat axis (a parameter near its bound, where the sigmoid saturates) would get a
  // long step that lands deep in the flat part; the step keeps its direction but is shortened.
  const double longest = dz.cwiseAbs().maxCoeff();
  if (longest > o_.lm_max_step) dz *= o_.lm_max_step / longest;
  predicted_gauss_newton_ = -(g_.dot(dz) + 0.5 * dz.dot(JtJ * dz));
  predicted_augmented_ = predicted_gauss_newton_ - 0.5 * dz.dot(on_axes(lowering, free, z_.size()) * dz);
  predicted_ = augmented_ ? predicted_augmented_ : predicted_gauss_newton_;
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
