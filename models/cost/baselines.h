// The two baseline costs of the paper's figure 4, for comparison with J_SSC in sweeps:
//   J_disp: known correspondences, 1/2 |u - u_true|^2 over the active nodes per frame
//           (normalised by the node count);
//   J_SDF:  the full SDF difference: at every grid node y that carries a displacement,
//           the deformed SDF phi_t(y) (found by the same inverse trilinear map as J_SSC)
//           against the true one, 1/2 (phi_t(y) - phi_true_t(y))^2 (normalised).
// Both need the true trajectory, simulated here from the true parameters.
#pragma once
#include <Eigen/Core>
#include <vector>

#include "models/cost/surface_constraint.h"
#include "models/sim/gradient.h"
#include "models/sim/simulation.h"

namespace ssc {

struct TrueTrajectory {
  std::vector<int> steps;
  std::vector<std::vector<double>> u;    // per frame, active nodes
  std::vector<std::vector<double>> phi;  // per frame, at sample_points
  std::vector<Eigen::Vector3d> sample_points;
};

TrueTrajectory simulate_truth(const Scene& scene, const SimGrid& grid, const PhysicalParameters& truth,
                              const std::vector<int>& steps, const SurfaceConstraintCost& cost);

FrameCostFunction displacement_cost(const TrueTrajectory& truth);
FrameCostFunction sdf_difference_cost(const TrueTrajectory& truth, const SurfaceConstraintCost& cost);

}  // namespace ssc
