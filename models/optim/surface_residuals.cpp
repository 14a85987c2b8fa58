// Residual vector of the sparse surface constraint (see surface_residuals.h).
#include "models/optim/surface_residuals.h"

#include <cmath>

#include "ops/trilinear.h"

namespace ssc {

SurfaceResiduals::SurfaceResiduals(const SurfaceConstraintCost& cost, const std::vector<ObservedFrame>& frames)
    : cost_(cost), frames_(frames), offsets_{0} {
  for (const ObservedFrame& f : frames) offsets_.push_back(offsets_.back() + int(f.points.size()));
}

FrameCost SurfaceResiduals::frame(size_t f, const double* u, const double* band_u, ResidualVector* out) const {
  const ObservedFrame& frame = frames_[f];
  FrameCost c;
  c.points = int(frame.points.size());
  if (frame.points.empty()) return c;
  const double phi_max = cost_.phi_max(), scale = frame.weight / double(frame.points.size());
  const std::vector<double> phi = cost_.point_phi(frame.points, u, band_u);
  double sum = 0;
  for (size_t i = 0; i < phi.size(); ++i) {
    const size_t k = size_t(offsets_[f]) + i;
    const bool matched = !std::isnan(phi[i]);
    const double term = matched ? ops::surface_point_cost(phi[i], phi_max) : 0.5 * phi_max * phi_max;
    sum += term;
    c.matched += matched;
    out->matched[k] = matched;
    out->r[Eigen::Index(k)] = std::copysign(std::sqrt(2 * scale * term), matched ? phi[i] : 1.0);
  }
  c.cost = scale * sum;
  return c;
}

}  // namespace ssc
