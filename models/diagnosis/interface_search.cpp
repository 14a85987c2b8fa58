// The two_materials interface's pattern search (see interface_search.h).
#include "models/diagnosis/interface_search.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "models/cost/surface_constraint.h"
#include "models/sim/body.h"
#include "models/sim/compute_device.h"
#include "models/sim/gradient.h"
#include "models/sim/parameters.h"

namespace ssc {
namespace {

constexpr double kPi = 3.14159265358979323846;
const std::string kRegionModulus = "material.regions[0].youngs_modulus";

// The held-in problem with a two-material body, loaded once (the observations are read once);
// each geometry only reassigns the region's cells (models/sim/body.h).
Problem two_material_problem(const InterfaceGuess& start, const DiagnosisContext& c) {
  const ModelSpec spec = two_materials_spec(start.normal, start.offset, start.modulus, "");
  std::vector<std::string> overrides = c.overrides, fit = c.options.fit;
  overrides.insert(overrides.end(), spec.overrides.begin(), spec.overrides.end());
  fit.push_back(kRegionModulus);
  return held_in(load_problem(c.scene_path, overrides, c.observations, c.phi_max, fit), c.heldin);
}

// Whether the interface leaves cells of the body on both sides.
bool splits_body(const SimGrid& grid, const InterfaceGuess& g) {
  MaterialRegion region;
  region.normal = g.normal;
  region.offset = g.offset;
  int inside = 0;
  for (int e = 0; e < grid.cell_count; ++e)
    inside += region.contains(grid.cell_start(e));
  return inside > 0 && inside < grid.cell_count;
}

// The held-in cost of one geometry at the best of o.moduli scales of its moduli (one batch):
// both sides' where the body's is given, else the second's alone with the body at the base
// fit's; the best go to g. +infinity for a geometry that is no interface (one side empty) or
// whose simulation fails.
double score(Problem& p, const FittedModel& base, InterfaceGuess& g, const DiagnosisContext& c,
             const InterfaceSearchOptions& o, const std::string& device) {
  if (!splits_body(p.grid, g)) return std::numeric_limits<double>::infinity();
  MaterialRegion& region = p.scene.material.regions[0];
  region.normal = g.normal;
  region.offset = g.offset;
  assign_material_regions(p.scene, p.grid);
  try {
    const int n = std::max(1, o.moduli);
    Simulation sim(p.scene, p.grid, n, true);
    place_on(sim, device);
    std::vector<double> moduli, bodies;
    for (int i = 0; i < n; ++i) {
      const double f = std::pow(3.0, n == 1 ? 0.0 : -1 + 2.0 * i / (n - 1));
      moduli.push_back(g.modulus * f);
      bodies.push_back(g.body_modulus * f);
      PhysicalParameters q = with_values(p.scene, base.names, base.values);
      if (g.body_modulus > 0) set_parameter(q, "youngs_modulus", bodies.back());
      set_parameter(q, kRegionModulus, moduli.back());
      sim.set_parameters(i, q);
    }
    GradientOptions go;
    go.gradient = false;
    const std::vector<CostGradient> r = evaluate_cost_gradient(sim, SurfaceConstraintCost(p.grid, p.phi_max), p.frames, go);
    double best = std::numeric_limits<double>::infinity();
    size_t at = size_t(-1);
    for (size_t i = 0; i < size_t(n); ++i)
      if (std::isfinite(r[i].cost) && r[i].cost < best) best = r[i].cost, at = i;
    if (at != size_t(-1)) g.modulus = moduli[at], g.body_modulus = bodies[at];
    return best;
  } catch (const std::exception&) {
    return std::numeric_limits<double>::infinity();
  }
}

}  // namespace

InterfaceSearch search_interface(const FittedModel& base, const InterfaceGuess& start, const DiagnosisContext& c,
                                 const InterfaceSearchOptions& o) {
  InterfaceSearch s;
  s.best = start;
  Problem p = two_material_problem(start, c);
  s.heldin_cost = s.start_cost = score(p, base, s.best, c, o, c.options.device);
  s.geometries = 1;
  // The interface turns about its point nearest to the body's centre of mass at the start.
  const Eigen::Vector3d centre = base.problem.grid.start_center_of_mass();
  for (int round = 0; round < o.rounds; ++round) {
    const double tilt = o.tilt_deg * kPi / 180 / std::pow(2.0, round);
    const double shift = o.shift_fraction * c.extent / std::pow(2.0, round);
    for (int moves = 0; moves < o.moves_per_round; ++moves) {
      const Eigen::Vector3d n = s.best.normal;
      const Eigen::Vector3d pivot = centre + (s.best.offset - n.dot(centre)) * n;
      const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
      std::vector<InterfaceGuess> around;
      for (const Eigen::Vector3d& w : {u, Eigen::Vector3d(-u), v, Eigen::Vector3d(-v)}) {
        InterfaceGuess g = s.best;
        g.normal = (std::cos(tilt) * n + std::sin(tilt) * w).normalized();
        g.offset = g.normal.dot(pivot);
        around.push_back(g);
      }
      for (double sign : {-1.0, 1.0}) {
        InterfaceGuess g = s.best;
        g.offset += sign * shift;
        around.push_back(g);
      }
      // With the body's modulus given, score() scales both sides together; the ratio of the
      // two sides moves here, as geometry does: at CalculiX's interface the held-in cost at the
      // gradient's ratio is 4 times that at the true one.
      if (s.best.body_modulus > 0)
        for (double sign : {-1.0, 1.0}) {
          InterfaceGuess g = s.best;
          g.modulus *= std::pow(o.ratio_step, sign / std::pow(2.0, round));
          around.push_back(g);
        }
      InterfaceGuess next = s.best;
      double next_cost = s.heldin_cost;
      std::vector<double> costs(around.size());  // side by side on GPUs, each on its copy of the problem
      side_by_side(around.size(), c.options.device, [&](size_t k, const std::string& device) {
        Problem own = p;
        costs[k] = score(own, base, around[k], c, o, device);
      });
      for (size_t k = 0; k < around.size(); ++k) {
        ++s.geometries;
        if (costs[k] < next_cost) next = around[k], next_cost = costs[k];
      }
      if (!(next_cost < s.heldin_cost)) break;
      s.best = next, s.heldin_cost = next_cost;
    }
  }
  return s;
}

}  // namespace ssc
