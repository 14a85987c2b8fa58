// The graph of one simulation timestep (the paper's forward model), built once per
// scene. docs/architecture.md shows it with the kernel plan.
#pragma once
#include "graph/graph.h"

namespace ssc {

struct TimestepGraph {
  Graph graph;
  // Inputs (per batch item): material, damping, gravity, time stepping, planes, fixed nodes.
  int youngs_modulus, poisson_ratio, density, mass_damping, stiffness_damping, gravity, dt, theta;
  int ground_planes = -1, fixed;
  // State read by the step and its successors written by it.
  int u_prev, v_prev, band_guess = -1;
  int u, v, band_u = -1, rotation, mass, lambda, mu, cg_iterations;
};

// plane_count > 0 adds the contact force, friction (with planes) Coulomb friction at the
// contact points (ops/friction.h); extension adds the band solve.
TimestepGraph build_timestep_graph(int plane_count, bool extension, bool friction = false);

}  // namespace ssc
