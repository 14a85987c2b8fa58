// Identifiability (see identifiability.h).
#include "models/diagnosis/identifiability.h"

#include <Eigen/Eigenvalues>

#include <cmath>

#include "models/cost/surface_constraint.h"
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
  if (device == "cuda") sim.use_gpu();
  sim.set_parameters(0, at);
  for (int j = 0; j < n; ++j) {
    PhysicalParameters p = at;
    set_parameter(p, names[size_t(j)], get_parameter(at, names[size_t(j)]) + steps[size_t(j)]);
    sim.set_parameters(j + 1, p);
  }
  // Each point's residual r, its cost term r^2 / 2 (surface_constraint.h): r = sign(phi) phi_max
  // sqrt(1 - exp(-phi^2 / phi_max^2)) sqrt(weight / N), phi_max sqrt(weight / N) unmatched.
  const SurfaceConstraintCost cost(problem.grid, problem.phi_max);
  const double phi_max = problem.phi_max;
  std::vector<std::vector<double>> r(size_t(n + 1));
  int step = 0;
  for (const ObservedFrame& frame : problem.frames) {
    while (step < frame.step) sim.step(), ++step;
    if (frame.points.empty()) continue;
    const double scale = std::sqrt(frame.weight / double(frame.points.size()));
    for (int item = 0; item <= n; ++item)
      for (const SurfaceConstraintCost::PointResidual& p :
           cost.point_residuals(frame.points, sim.displacement(item), sim.band_displacement(item)))
        r[size_t(item)].push_back(
            scale * (p.matched() ? std::copysign(phi_max * std::sqrt(-std::expm1(-p.phi * p.phi / (phi_max * phi_max))), p.phi)
                                 : phi_max));
  }
  Eigen::MatrixXd J(Eigen::Index(r[0].size()), n);
  const Eigen::Map<const Eigen::VectorXd> r0(r[0].data(), Eigen::Index(r[0].size()));
  for (int j = 0; j < n; ++j)
    J.col(j) = (Eigen::Map<const Eigen::VectorXd>(r[size_t(j + 1)].data(), Eigen::Index(r[0].size())) - r0) /
               steps[size_t(j)];
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
