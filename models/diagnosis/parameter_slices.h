// One-sided identification: the held-in cost along each of a fit's parameters, the others
// held at the fit, out to the ends of the parameter's plausible range. Where the cost stays
// within a tolerance of the fit's all the way to an end, the data fix the parameter on that
// side only: a cube that comes to rest on a slope fixes a lower bound on its friction, not a
// value, and its fitted friction is wherever the optimiser stopped on the plateau.
#pragma once
#include <string>
#include <utility>
#include <vector>

#include "models/sim/problem.h"

namespace ssc {

struct ParameterSlice {
  std::string name;
  double fitted = 0;
  std::vector<double> values, costs;  // ascending, the fitted value among them
  // The span of probed values, contiguous with the fitted one, whose cost exceeds the fit's by
  // at most `relative` of it; open_low / open_high: it reaches that end of the plausible range.
  double low = 0, high = 0;
  bool open_low = false, open_high = false;
};

// Probes per_side values on each side of every parameter's fitted value, at 1/2^(per_side-1),
// ..., 1/2, 1 of the way to its range's end (in log space where log_scale), all as one batch of
// forward simulations over problem's frames. A side whose end is not finite is not probed; a
// probe whose simulation fails is left out of its slice (so an end it failed at is not open).
std::vector<ParameterSlice> slice_parameters(const Problem& problem, const PhysicalParameters& at,
                                             const std::vector<std::string>& names,
                                             const std::vector<std::pair<double, double>>& ranges,
                                             const std::vector<bool>& log_scale, double relative, int per_side,
                                             const std::string& device);

// The span and its open ends from values, costs and the fitted value's index (in slice).
void supported_span(ParameterSlice& slice, size_t fitted_index, double range_low, double range_high,
                    double relative);

}  // namespace ssc
