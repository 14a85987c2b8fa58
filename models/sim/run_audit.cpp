// Physical sanity checks of a running simulation (see run_audit.h).
#include "models/sim/run_audit.h"

#include <fmt/format.h>

#include <cmath>

#include "runtime/errors.h"
#include "models/sim/simulation.h"

namespace ssc {

void SimulationAudit::start(const Simulation& sim, int b) {
  const SimGrid& g = sim.grid();
  rest_box.setEmpty();
  for (int i = 0; i < g.node_count; ++i) rest_box.extend(Eigen::Vector3d(g.node_rest[3 * i], g.node_rest[3 * i + 1], g.node_rest[3 * i + 2]));
  body_diagonal = rest_box.diagonal().norm();
  const PhysicalParameters& p = sim.parameters(b);
  const double radius = (rest_box.max() - sim.spin_center()).cwiseMax(sim.spin_center() - rest_box.min()).norm();
  max_speed = p.linear_velocity.norm() + p.angular_velocity.norm() * radius;
  // The start is the rest shape (no elastic energy): only the motion and the ground count.
  const double kinetic = sim.kinetic_energy(b), contact = sim.contact_energy(b);
  energy_start = kinetic + contact + sim.gravitational_energy(b);
  double volume = 0;
  for (double v : g.node_volume) volume += v;
  energy_scale = kinetic + contact + p.density * volume * p.gravity.norm() * body_diagonal + 1e-12;
  inverted_cells = 0;
  first_inverted_step = -1;
}

void SimulationAudit::check(const Simulation& sim, int b, int step, const char* when) {
  const PhysicalParameters& p = sim.parameters(b);
  const double t = step * sim.dt();
  const double reach = 10 * body_diagonal + 2 * (max_speed * t + 0.5 * p.gravity.norm() * t * t);
  const double* u = sim.displacement(b);
  const SimGrid& g = sim.grid();
  for (int i = 0; i < g.node_count; ++i) {
    const Eigen::Vector3d x(g.node_rest[3 * i] + u[3 * i], g.node_rest[3 * i + 1] + u[3 * i + 1], g.node_rest[3 * i + 2] + u[3 * i + 2]);
    if (rest_box.exteriorDistance(x) > reach)
      throw SimulationError(fmt::format(
          "{} {}: the simulation exploded (batch item {}): a node is {:.3g} m from the body's rest box, beyond any "
          "motion the initial velocity and gravity allow ({:.3g} m by t = {:.3g} s); lower time.dt or the ground stiffness",
          when, step, b, rest_box.exteriorDistance(x), reach, t), {b});
  }
  const Simulation::CellScan cells = sim.scan_cells(b);
  if (tolerance > 0) {
    const double kinetic = sim.kinetic_energy(b), elastic = cells.elastic, contact = sim.contact_energy(b);
    const double gravity = sim.gravitational_energy(b);
    const double total = kinetic + elastic + contact + gravity;
    if (!(total <= energy_start + tolerance * energy_scale))
      throw SimulationError(fmt::format(
          "{} {}: the simulation gained energy (batch item {}): the total energy rose from {:.4g} J to {:.4g} J "
          "(kinetic {:.4g}, elastic {:.4g}, contact {:.4g}, gravitational {:.4g} J), more than solver.energy_tolerance "
          "= {:g} of the run's energy scale {:.4g} J. Nothing in the model adds energy: time.dt is too large for the "
          "ground contact (set solver.contact to \"implicit\", which holds stiff grounds; with it, raise "
          "solver.nonlinear_iterations or lower time.dt; or lower ground.stiffness or ground.softmin_alpha) or for a "
          "fast spin (the cells' rotation stores spurious elastic energy growing with (omega dt)^2: lower time.dt, or "
          "set solver.corotation to \"updated\")",
          when, step, b, energy_start, total, kinetic, elastic, contact, gravity, tolerance, energy_scale), {b});
  }
  if (cells.inverted > 0 && first_inverted_step < 0) first_inverted_step = step;
  inverted_cells = std::max(inverted_cells, cells.inverted);
}

std::string initial_penetration(const SimGrid& grid, const PhysicalParameters& p) {
  for (size_t k = 0; k < p.planes.size(); ++k) {
    const PlaneSpec& plane = p.planes[k];
    if (plane.stiffness <= 0) continue;
    const Eigen::Vector3d n = plane.normal.normalized();
    const double allowed = 0.25 * grid.h + 1.0 / plane.softmin_alpha;
    double deepest = 0;
    for (const ContactPoint& c : grid.contact_points) {
      const Eigen::Vector3d x = grid.point_start(c);
      deepest = std::max(deepest, plane.height - n.dot(x));
    }
    if (deepest > allowed)
      return fmt::format("the body starts {:.3g} m inside ground plane {} (height {:g} m, normal [{:.3g}, {:.3g}, {:.3g}]); "
                         "the contact would throw it out. Move the object (object.position) or the plane (ground.height) "
                         "so that the body starts above it (tolerance {:.3g} m: h/4 + 1/softmin_alpha)",
                         deepest, k, plane.height, n.x(), n.y(), n.z(), allowed);
  }
  return "";
}

}  // namespace ssc
