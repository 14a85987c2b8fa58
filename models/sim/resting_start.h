// A body that starts within reach of a ground plane is not at rest: the soft-min contact
// (ops/contact.h) pushes before touching, with k A ln(1 + exp(-alpha d)) / alpha on a contact
// point at distance d (k A ln 2 / alpha when touching), so a body placed on a plane is thrown
// up, or sinks in, at the first step. Checked once, for the scene's values, when a
// simulation starts; the body is left where the scene puts it (docs/decisions.md, decision 12),
// and a warning says how far it will move and where the plane would hold it at rest.
//
// For each plane (stiffness > 0, gravity pressing the body onto it, no fixed nodes), with
// the rest body moved rigidly by s along the plane's normal:
//  - push F(s): the contact force of all contact points; the reach is the lowest distance
//    of the body above the plane at which F falls to kRestingReachFraction of the weight;
//  - equilibrium s_eq: F(s_eq) = m g_n (g_n the gravity towards the plane);
//  - excursion: the other turning point of the undamped rigid motion, where the contact
//    potential plus m g_n s equals its start value plus the kinetic energy along n.
// A body starting within the reach whose excursion exceeds kRestingStartTolerance is
// reported.
#pragma once
#include <string>
#include <vector>

namespace ssc {

struct PhysicalParameters;
struct SimGrid;

constexpr double kRestingReachFraction = 0.1;
constexpr double kRestingStartTolerance = 1e-3;  // metres

struct RestingStart {
  int plane = -1;
  double lowest = 0;       // m, the rest body's lowest signed distance to the plane
  double reach = 0;        // m, the lowest distance at which the push is kRestingReachFraction of the weight
  double push = 0;         // N, the contact force at the start
  double weight = 0;       // N, m g_n
  double equilibrium = 0;  // m along the normal, from the start
  double excursion = 0;    // m along the normal, from the start: the far turning point
};

// Every plane whose contact moves the body by more than kRestingStartTolerance at the start.
std::vector<RestingStart> resting_start_jumps(const SimGrid& grid, const PhysicalParameters& p,
                                              const std::vector<char>& fixed_nodes);

// The warning for one plane: what happens, and the plane height of a resting start (moving
// the plane keeps the grid; moving the body resamples it on the grid's fixed lattice).
std::string resting_start_message(const RestingStart& r, const PhysicalParameters& p);

}  // namespace ssc
