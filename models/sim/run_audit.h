// Checks that keep a wrong simulation from passing as a result (docs/errors.md):
//  - energy audit: the total energy (kinetic + elastic + gravitational + contact potential)
//    may not rise above its value at the start (the rest shape: no elastic energy) by more
//    than solver.energy_tolerance times the run's energy scale (initial kinetic and contact
//    energy + m |g| L, L the rest body's diagonal); gravity is the only external force that does work
//    (fixed nodes do not move), and Rayleigh damping, theta > 1/2 and the contact's damping
//    term only remove energy, so a rise is the time integration going wrong (a contact too
//    stiff for time.dt, or time.dt too large). SimulationError naming the step.
//  - bounding region: every node stays within 10 L plus twice the ballistic reach
//    (v_max t + |g| t^2 / 2) of the rest body; SimulationError otherwise.
//  - a body that starts inside a ground plane (a surface point deeper than h/4 + 1/alpha):
//    InputError for the scene as given, SimulationError for a start of a fit.
//  - inverted cells (det F <= 0 at the cell centre): counted, with the first step, and
//    reported as a warning by the commands (SimulationAudit::inverted_cells).
#pragma once
#include <Eigen/Geometry>
#include <string>

namespace ssc {

class Simulation;
struct PhysicalParameters;
struct SimGrid;

struct SimulationAudit {
  double tolerance = 0.05;  // fraction of energy_scale
  double energy_start = 0, energy_scale = 0;
  double body_diagonal = 0, max_speed = 0;
  Eigen::AlignedBox3d rest_box;
  int inverted_cells = 0, first_inverted_step = -1;  // the most cells inverted at once, and when first

  // Takes the start state's energy and extent; the state must be the rest shape (u = 0).
  void start(const Simulation& sim, int b);
  // Throws SimulationError ("<when> <step>: ...") for energy gained or a node outside the region.
  void check(const Simulation& sim, int b, int step, const char* when);
};

// Empty when no contact point starts deeper than h/4 + 1/alpha inside a ground plane; else
// a message naming the plane, the depth and the fix.
std::string initial_penetration(const SimGrid& grid, const PhysicalParameters& p);

}  // namespace ssc
