// Identifiability (see identifiability.h).
#include "models/diagnosis/identifiability.h"

#include <Eigen/Eigenvalues>

#include <cmath>

#include "models/cost/surface_constraint.h"
#include "models/optim/surface_residuals.h"
#include "models/sim/compute_device.h"
#include "models/sim/parameters.h"
#include "runtime/errors.h"

namespace ssc {

ParameterCorrelation parameter_correlation(const Problem& problem, const PhysicalParameters& at,
                                           const std::vector<std::string>& names, const std::vector<double>& steps,
                                           const std::string& device) {
  ParameterCorrelation c;
  const int n = int(names.size());
  if (n == 0 || steps.size() != names.size()) throw InputError("parameter_correlation: one step per parameter");
  Simulation sim(problem.scene, problem.grid, n + 1, true);
  place_on(sim, device);
  sim.set_parameters(0, at);
  for (int j = 0; j < n; ++j) {
    PhysicalParameters p = at;
    set_parameter(p, names[size_t(j)], get_parameter(at, names[size_t(j)]) + steps[size_t(j)]);
    sim.set_parameters(j + 1, p);
  }
  // Each observed point's residual r, its cost term r^2 / 2 (models/optim/surface_residuals.h).
  const SurfaceConstraintCost cost(problem.grid, problem.phi_max);
  const SurfaceResiduals residuals(cost, problem.frames);
  std::vector<ResidualVector> r(size_t(n + 1));
  for (ResidualVector& v : r) {
    v.r.resize(residuals.size());
    v.matched.resize(size_t(residuals.size()));
  }
  int step = 0;
  for (size_t f = 0; f < problem.frames.size(); ++f) {
    while (step < problem.frames[f].step) sim.step(), ++step;
    for (int item = 0; item <= n; ++item)
      residuals.frame(f, sim.displacement(item), sim.band_displacement(item), &r[size_t(item)]);
  }
  const Eigen::VectorXd& r0 = r[0].r;
  Eigen::MatrixXd J(r0.size(), n);
  for (int j = 0; j < n; ++j) J.col(j) = (r[size_t(j + 1)].r - r0) / steps[size_t(j)];
  const Eigen::MatrixXd gn = J.transpose() * J;
  std::vector<int> kept;  // the parameters whose step moved the residuals beyond rounding
  for (int i = 0; i < n; ++i)
    (std::abs(steps[size_t(i)]) * J.col(i).norm() > 1e-9 * r0.norm() ? kept.push_back(i) : c.flat.push_back(names[size_t(i)]));
  for (int i : kept) c.names.push_back(names[size_t(i)]);
  const Eigen::Index k = Eigen::Index(kept.size());
  c.gauss_newton.resize(k, k);
  for (Eigen::Index i = 0; i < k; ++i)
    for (Eigen::Index m = 0; m < k; ++m) c.gauss_newton(i, m) = gn(kept[size_t(i)], kept[size_t(m)]);
  if (k < 2) {
    c.failure = "fewer than 2 parameters change the residuals";
    return c;
  }
  // The covariance (up to a factor), scaled to a unit diagonal; an exactly confounded pair
  // (a zero eigenvalue) comes out with correlation +-1.
  const Eigen::VectorXd s = c.gauss_newton.diagonal().cwiseSqrt().cwiseInverse();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(s.asDiagonal() * c.gauss_newton * s.asDiagonal());
  const Eigen::VectorXd inverse =
      eig.eigenvalues().cwiseMax(1e-9 * eig.eigenvalues().maxCoeff()).cwiseInverse();
  const Eigen::MatrixXd covariance = eig.eigenvectors() * inverse.asDiagonal() * eig.eigenvectors().transpose();
  const Eigen::VectorXd t = covariance.diagonal().cwiseSqrt().cwiseInverse();
  c.correlation = t.asDiagonal() * covariance * t.asDiagonal();
  return c;
}

}  // namespace ssc
