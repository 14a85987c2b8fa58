// Identifiability: how well the data determine parameters at a point, and which of them trade
// one for the other ("air drag or mass damping").
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

#include "models/sim/problem.h"

namespace ssc {

// The Gauss-Newton matrix J^T J of the cost's residuals (each observed point's robust residual
// r, its cost term r^2 / 2), J from forward differences (step steps[j]) of n + 1 simulations run
// as one batch; its inverse (the parameters' covariance up to a factor) scaled to a unit
// diagonal is their correlation. A correlation near +-1: the data fix a combination of the
// two, not each. Parameters the residuals do not depend on there are left out (`flat`);
// `failure` says why there is no correlation (fewer than two parameters left).
struct ParameterCorrelation {
  std::vector<std::string> names, flat;  // names: the parameters of gauss_newton and correlation
  Eigen::MatrixXd gauss_newton, correlation;
  std::string failure;
};
ParameterCorrelation parameter_correlation(const Problem& problem, const PhysicalParameters& at,
                                           const std::vector<std::string>& names, const std::vector<double>& steps,
                                           const std::string& device);

}  // namespace ssc
