// A smooth frame cost for trajectory-gradient tests that need no observations: linear in the
// node displacements (weights sin(0.37 i + frame)) and quadratic in the band displacements.
#pragma once
#include <cmath>

#include "models/grid/sim_grid.h"
#include "models/sim/gradient.h"

namespace ssc {

inline FrameCostFunction synthetic_frame_cost(const SimGrid& grid) {
  return [&grid](size_t f, int, const double* u, const double* band, double* ub, double* bb) {
    FrameCost c;
    for (int i = 0; i < 3 * grid.node_count; ++i) {
      const double w = std::sin(0.37 * i + double(f));
      c.cost += w * u[i];
      if (ub) ub[i] += w;
    }
    for (int i = 0; i < 3 * grid.band_count; ++i) {
      c.cost += 0.5 * band[i] * band[i];
      if (bb) bb[i] += band[i];
    }
    return c;
  };
}

}  // namespace ssc
