// One-sided identification (see parameter_slices.h).
#include "models/diagnosis/parameter_slices.h"

#include <algorithm>
#include <cmath>

#include "models/cost/surface_constraint.h"
#include "models/optim/batch_evaluation.h"
#include "models/sim/parameters.h"
#include "runtime/errors.h"

namespace ssc {

void supported_span(ParameterSlice& s, size_t fitted_index, double range_low, double range_high, double relative) {
  const double reference = s.costs[fitted_index], tolerance = relative * reference;
  size_t lo = fitted_index, hi = fitted_index;
  while (lo > 0 && s.costs[lo - 1] - reference <= tolerance) --lo;
  while (hi + 1 < s.values.size() && s.costs[hi + 1] - reference <= tolerance) ++hi;
  s.low = s.values[lo], s.high = s.values[hi];
  s.open_low = lo != fitted_index && s.low == range_low;
  s.open_high = hi != fitted_index && s.high == range_high;
}

std::vector<ParameterSlice> slice_parameters(const Problem& problem, const PhysicalParameters& at,
                                             const std::vector<std::string>& names,
                                             const std::vector<std::pair<double, double>>& ranges,
                                             const std::vector<bool>& log_scale, double relative, int per_side,
                                             const std::string& device) {
  if (ranges.size() != names.size() || log_scale.size() != names.size() || per_side < 1)
    throw InputError("slice_parameters: one range and one scale per parameter, at least one probe a side");
  Eigen::VectorXd fitted(Eigen::Index(names.size()));
  for (size_t j = 0; j < names.size(); ++j) fitted[Eigen::Index(j)] = get_parameter(at, names[j]);
  std::vector<ParameterSlice> slices(names.size());
  std::vector<Eigen::VectorXd> points = {fitted};
  std::vector<std::vector<int>> point_of(names.size());  // per slice, its values' points
  std::vector<size_t> fitted_index(names.size());
  for (size_t j = 0; j < names.size(); ++j) {
    ParameterSlice& s = slices[j];
    s.name = names[j];
    s.fitted = fitted[Eigen::Index(j)];
    const auto [lo, hi] = ranges[j];
    auto toward = [&](double end, double fraction) {
      if (log_scale[j] && end > 0 && s.fitted > 0) return s.fitted * std::pow(end / s.fitted, fraction);
      return s.fitted + fraction * (end - s.fitted);
    };
    std::vector<std::pair<double, int>> probes = {{s.fitted, 0}};
    for (double end : {lo, hi}) {
      if (!std::isfinite(end) || end == s.fitted) continue;
      for (int k = per_side - 1; k >= 0; --k) {
        points.push_back(fitted);
        points.back()[Eigen::Index(j)] = k == 0 ? end : toward(end, std::ldexp(1.0, -k));
        probes.emplace_back(points.back()[Eigen::Index(j)], int(points.size()) - 1);
      }
    }
    std::sort(probes.begin(), probes.end());
    for (size_t k = 0; k < probes.size(); ++k) {
      s.values.push_back(probes[k].first);
      point_of[j].push_back(probes[k].second);
      if (probes[k].second == 0) fitted_index[j] = k;
    }
  }
  // A probe whose simulation fails (the energy audit, say) is left out of its slice.
  BatchSimulations sims(problem, device);
  const SurfaceConstraintCost cost(problem.grid, problem.phi_max);
  const std::vector<PointEvaluation> r = evaluate_batch(sims, cost, at, names, points, false);
  if (!r[0].ok) throw SimulationError("the fit's own parameters failed to simulate: " + r[0].failure);
  for (size_t j = 0; j < names.size(); ++j) {
    ParameterSlice& s = slices[j];
    std::vector<double> values;
    size_t fit = 0;
    for (size_t k = 0; k < point_of[j].size(); ++k) {
      const PointEvaluation& e = r[size_t(point_of[j][k])];
      if (!e.ok) continue;
      if (k == fitted_index[j]) fit = values.size();
      values.push_back(s.values[k]);
      s.costs.push_back(e.value.cost);
    }
    s.values = std::move(values);
    supported_span(s, fit, ranges[j].first, ranges[j].second, relative);
  }
  return slices;
}

}  // namespace ssc
