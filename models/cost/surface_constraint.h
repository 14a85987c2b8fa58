// The sparse surface constraint cost J_SSC of the paper for one observed frame.
//
// The rest grid's displacement is known on active nodes (the FE solution) and band nodes
// (its extension). Every cell whose 8 corners all carry a displacement is a candidate:
// its deformed corners X_c = x_c + u_c. An observed world point p is matched to the
// candidate cell whose inverse trilinear map gives local coordinates in [0,1]^3; the
// rest SDF interpolated there, phi, is the point's distance to the surface. Several
// matching cells: the one with the smallest |phi| (ties: lowest cell index). No match:
// the constant cost 1/2 phi_max^2. Candidates come from a uniform bin grid over the
// deformed cells' bounding boxes, rebuilt per frame (no search over all cells).
//
// J_frame = weight / N * sum_i cost(phi_i), cost = 1/2 phi_max^2 (1 - exp(-phi^2/phi_max^2))
// (ops/trilinear.h), N = number of observed points of the frame.
#pragma once
#include <Eigen/Core>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "models/grid/sim_grid.h"

namespace ssc {

struct FrameCost {
  double cost = 0;
  int points = 0, matched = 0;
};

class SurfaceConstraintCost {
 public:
  SurfaceConstraintCost(const SimGrid& grid, double phi_max);

  double phi_max() const { return phi_max_; }
  int candidate_cells() const { return int(cells_.size()); }

  // Cost of one frame for active-node displacements u and band displacements band_u.
  // With u_bar/band_bar non-null, adds d(cost)/du and d(cost)/d(band_u) into them.
  FrameCost evaluate(const std::vector<Eigen::Vector3d>& points, double weight, const double* u, const double* band_u,
                     double* u_bar, double* band_bar) const;

  // The J_SDF baseline: per point 1/2 (phi - target)^2, points unmatched (or with a NaN
  // target) left out; normalised by the number of points like evaluate().
  FrameCost evaluate_targets(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& targets, double weight,
                             const double* u, const double* band_u, double* u_bar, double* band_bar) const;

  // Rest-pose SDF value at the matched location of each point (NaN if unmatched);
  // for pictures and residual maps.
  std::vector<double> point_phi(const std::vector<Eigen::Vector3d>& points, const double* u, const double* band_u) const;

  // Per point: phi (the signed distance to the simulated surface, metres; NaN unmatched), the
  // rest-shape position of its match, and the simulated surface's outward unit normal there
  // (the rest SDF's gradient mapped by the cell's deformation): the point lies phi * normal
  // off the surface.
  struct PointResidual {
    double phi = std::numeric_limits<double>::quiet_NaN();
    Eigen::Vector3d rest = Eigen::Vector3d::Zero(), normal = Eigen::Vector3d::Zero();
    bool matched() const { return !std::isnan(phi); }
  };
  std::vector<PointResidual> point_residuals(const std::vector<Eigen::Vector3d>& points, const double* u,
                                             const double* band_u) const;

 private:
  struct Match {
    int cell = -1;
    double a = 0, b = 0, c = 0, phi = 0;
  };
  FrameCost evaluate_impl(const std::vector<Eigen::Vector3d>& points, const std::vector<double>* targets, double weight,
                          const double* u, const double* band_u, double* u_bar, double* band_bar) const;
  std::vector<Match> match_points(const std::vector<Eigen::Vector3d>& points, const double* u, const double* band_u) const;

  const SimGrid& grid_;
  double phi_max_;
  std::vector<long> cells_;                 // candidate cells by the flat index of corner 0
  std::vector<std::array<int, 8>> corners_;  // per candidate: grid_kind of each corner
};

}  // namespace ssc
