// The body's mass-weighted mean velocity along x (node volumes stand for the lumped masses of a
// uniform density), for the friction tests' sliding and sticking checks.
#pragma once
#include "models/grid/sim_grid.h"
#include "models/sim/simulation.h"

namespace ssc {

inline double mean_velocity_x(const Simulation& sim, const SimGrid& grid) {
  const double* v = sim.velocity(0);
  double p = 0, mass = 0;
  for (int i = 0; i < grid.node_count; ++i) {
    p += grid.node_volume[i] * v[3 * i];
    mass += grid.node_volume[i];
  }
  return p / mass;
}

}  // namespace ssc
