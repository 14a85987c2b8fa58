// The score test (see score_test.h).
#include "models/diagnosis/score_test.h"

#include <algorithm>
#include <cmath>

#include "models/cost/surface_constraint.h"
#include "models/sim/compute_device.h"
#include "models/sim/extensions.h"
#include "models/sim/parameters.h"

namespace ssc {

std::map<std::string, double> score_test(const FittedModel& base, const DiagnosisContext& c) {
  std::vector<std::string> overrides = c.overrides, fit = c.options.fit;
  std::vector<const ExtensionRow*> rows;
  for (const ExtensionRow& row : extension_table())
    if (row.fit == ExtensionRow::Fit::OffValue) {
      rows.push_back(&row);
      overrides.insert(overrides.end(), row.overrides.begin(), row.overrides.end());
      for (const std::string& p : row.parameters(base.problem.scene)) fit.push_back(p);
    }
  Problem p = load_problem(c.scene_path, overrides, c.observations, c.phi_max, fit);
  p.frames.resize(size_t(c.heldin));
  PhysicalParameters params = PhysicalParameters::from_scene(p.scene);
  for (const auto& [name, value] : values_by_name(base)) set_parameter(params, name, value);
  std::map<const ExtensionRow*, std::vector<std::string>> own;
  for (const ExtensionRow* row : rows) {
    own[row] = expand_parameter_names(row->parameters(p.scene), params);
    for (const std::string& name : own[row]) set_parameter(params, name, row->off_value);
  }
  Simulation sim(p.scene, p.grid, 1, true);
  place_on(sim, c.options.device);
  sim.set_parameters(0, params);
  const SurfaceConstraintCost cost(p.grid, p.phi_max);
  const CostGradient r = evaluate_cost_gradient(sim, cost, p.frames, {})[0];
  std::map<std::string, double> score;
  if (!(r.cost > 0)) return score;
  for (const ExtensionRow* row : rows) {
    double sum = 0, squares = 0;
    for (const std::string& name : own[row]) {
      const double g = parameter_gradient(r.gradient, params, name);
      sum += g, squares += g * g;
    }
    const double typical = row->typical(c.extent);
    score[row->name] = (row->one_sided ? std::max(0.0, -typical * sum) : typical * std::sqrt(squares)) / r.cost;
  }
  return score;
}

}  // namespace ssc
