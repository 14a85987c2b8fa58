// One-sided identification (see parameter_slices.h).
#include "models/diagnosis/parameter_slices.h"

#include <algorithm>
#include <cmath>

#include "models/cost/surface_constraint.h"
#include "models/sim/compute_device.h"
#include "models/sim/gradient.h"
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
  std::vector<ParameterSlice> slices(names.size());
  std::vector<PhysicalParameters> items = {at};
  std::vector<std::vector<int>> item_of(names.size());  // per slice, its values' batch items
  std::vector<size_t> fitted_index(names.size());
  for (size_t j = 0; j < names.size(); ++j) {
    ParameterSlice& s = slices[j];
    s.name = names[j];
    s.fitted = get_parameter(at, names[j]);
    const auto [lo, hi] = ranges[j];
    auto toward = [&](double end, double fraction) {
      if (log_scale[j] && end > 0 && s.fitted > 0) return s.fitted * std::pow(end / s.fitted, fraction);
      return s.fitted + fraction * (end - s.fitted);
    };
    std::vector<std::pair<double, int>> probes = {{s.fitted, 0}};
    for (double end : {lo, hi}) {
      if (!std::isfinite(end) || end == s.fitted) continue;
      for (int k = per_side - 1; k >= 0; --k) {
        const double v = k == 0 ? end : toward(end, std::ldexp(1.0, -k));
        PhysicalParameters p = at;
        set_parameter(p, names[j], v);
        items.push_back(p);
        probes.emplace_back(v, int(items.size()) - 1);
      }
    }
    std::sort(probes.begin(), probes.end());
    for (size_t k = 0; k < probes.size(); ++k) {
      s.values.push_back(probes[k].first);
      item_of[j].push_back(probes[k].second);
      if (probes[k].second == 0) fitted_index[j] = k;
    }
  }
  Simulation sim(problem.scene, problem.grid, int(items.size()), true);
  place_on(sim, device);
  for (size_t i = 0; i < items.size(); ++i) sim.set_parameters(int(i), items[i]);
  const SurfaceConstraintCost cost(problem.grid, problem.phi_max);
  GradientOptions o;
  o.gradient = false;
  const std::vector<CostGradient> r = evaluate_cost_gradient(sim, cost, problem.frames, o);
  for (size_t j = 0; j < names.size(); ++j) {
    ParameterSlice& s = slices[j];
    for (int item : item_of[j]) s.costs.push_back(r[size_t(item)].cost);
    supported_span(s, fitted_index[j], ranges[j].first, ranges[j].second, relative);
  }
  return slices;
}

}  // namespace ssc
