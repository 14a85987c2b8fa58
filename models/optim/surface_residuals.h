// The sparse surface constraint cost written as a residual vector, J_SSC = 1/2 ||r||^2, for
// least-squares optimisers: one entry per observed point of every frame, in frame and point
// order, so the layout is the same for every parameter value. With w the frame's weight and N
// its number of points (models/cost/surface_constraint.h):
//   matched point:   r = sign(phi) phi_max sqrt(1 - exp(-phi^2 / phi_max^2)) sqrt(w / N)
//   unmatched point: r = phi_max sqrt(w / N), the cost's constant term, flagged unmatched
#pragma once
#include <vector>

#include "models/cost/surface_constraint.h"
#include "models/optim/levenberg_marquardt.h"
#include "models/sim/gradient.h"

namespace ssc {

class SurfaceResiduals {
 public:
  SurfaceResiduals(const SurfaceConstraintCost& cost, const std::vector<ObservedFrame>& frames);
  int size() const { return offsets_.back(); }
  // Writes frame f's entries into *out (sized size()) and returns the frame's cost, summed
  // as SurfaceConstraintCost::evaluate sums it.
  FrameCost frame(size_t f, const double* u, const double* band_u, ResidualVector* out) const;

 private:
  const SurfaceConstraintCost& cost_;
  const std::vector<ObservedFrame>& frames_;
  std::vector<int> offsets_;  // per frame, and the total at the end
};

}  // namespace ssc
