// Baseline costs J_disp and J_SDF (see baselines.h).
#include "models/cost/baselines.h"

namespace ssc {

TrueTrajectory simulate_truth(const Scene& scene, const SimGrid& grid, const PhysicalParameters& truth,
                              const std::vector<int>& steps, const SurfaceConstraintCost& cost) {
  TrueTrajectory t;
  t.steps = steps;
  const SdfGrid& s = grid.sdf;
  for (long n = 0; n < s.node_count(); ++n)
    if (grid.grid_kind[n] != -1) {
      const int i = int(n % s.size.x()), j = int((n / s.size.x()) % s.size.y()), k = int(n / (long(s.size.x()) * s.size.y()));
      t.sample_points.push_back(s.node_position(i, j, k));
    }
  Simulation sim(scene, grid, 1, true);
  sim.set_parameters(0, truth);
  const std::vector<double> zero_band(3 * size_t(grid.band_count), 0.0);
  for (int step : steps) {
    while (sim.steps_taken() < step) sim.step();
    const double* band = sim.band_displacement(0);
    if (!band) band = zero_band.data();
    t.u.emplace_back(sim.displacement(0), sim.displacement(0) + 3 * grid.node_count);
    t.phi.push_back(cost.point_phi(t.sample_points, sim.displacement(0), band));
  }
  return t;
}

FrameCostFunction displacement_cost(const TrueTrajectory& truth) {
  return [&truth](size_t f, int, const double* u, const double*, double* u_bar, double*) {
    FrameCost r;
    const std::vector<double>& target = truth.u[f];
    const double scale = 3.0 / double(target.size());
    double sum = 0;
    for (size_t i = 0; i < target.size(); ++i) {
      const double d = u[i] - target[i];
      sum += 0.5 * d * d;
      if (u_bar) u_bar[i] += scale * d;
    }
    r.cost = scale * sum;
    r.points = r.matched = int(target.size() / 3);
    return r;
  };
}

FrameCostFunction sdf_difference_cost(const TrueTrajectory& truth, const SurfaceConstraintCost& cost) {
  return [&truth, &cost](size_t f, int, const double* u, const double* band, double* u_bar, double* band_bar) {
    return cost.evaluate_targets(truth.sample_points, truth.phi[f], 1.0, u, band, u_bar, band_bar);
  };
}

}  // namespace ssc
