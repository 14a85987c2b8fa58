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
  int region_youngs = -1, stiffness_gradient = -1;  // with the heterogeneous_stiffness extension
  int air_drag = -1;                                // with the air_drag extension
  bool neo_hookean = false;                         // the elastic energy is the Neo-Hookean one
  // State read by the step and its successors written by it.
  int u_prev, v_prev, band_guess = -1;
  int v_before = -1;  // v_prev a step earlier, for the solve's start (a step of one solve only)
  int u, v, band_u = -1, rotation, mass, lambda, mu, cg_iterations;
  // The band extension's op, the graph's last (-1 without): a step no cost observes runs the
  // ops before it alone (StepBackend::run_prefix).
  int extension_op = -1;
};

struct Scene;

// The model extensions a graph holds (docs/scene-format.md names them).
struct TimestepModel {
  bool friction = false;        // Coulomb friction at the contact points (ops/friction.h), with planes
  int region_count = 0;         // material regions, each with its Young's modulus (ops/stiffness_field.h)
  bool stiffness_gradient = false;  // E(x) = E exp(g . (x - c)) (ops/stiffness_field.h)
  bool air_drag = false;        // quadratic drag on the surface (ops/air_drag.h)
  // The step's nonlinear iterations (ops/contact_implicit.h): implicit contact (Newton on the
  // penalty force), the rotation updated within the step, and how many solves a step takes.
  bool implicit_contact = false, updated_corotation = false;
  bool line_search = true;  // on the implicit contact's iterations (ops/line_search.h)
  bool neo_hookean = false;  // material.model "neo_hookean" (ops/neo_hookean.h), through the iterations
  int nonlinear_iterations = 4;

  bool heterogeneous() const { return region_count > 0 || stiffness_gradient; }
  // Whether the step repeats its solve nonlinear_iterations times (implicit contact needs a plane).
  bool iterates(int plane_count) const {
    return (implicit_contact && plane_count > 0) || updated_corotation || neo_hookean;
  }
};
// The extensions a scene models.
TimestepModel timestep_model(const Scene& scene);

// plane_count > 0 adds the contact force; extension adds the band solve; model the
// extensions.
TimestepGraph build_timestep_graph(int plane_count, bool extension, const TimestepModel& model = {});

}  // namespace ssc
