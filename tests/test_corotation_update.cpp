// solver.corotation = "updated" (the rotation of each solve's iterate, models/sim/
// timestep_graph.cpp) against "lagged" (the previous step's) on a rigid spin: a torus spinning
// freely, no damping, theta = 1/2, dt 0.005 s, at E = 5e5, 5e6 and 5e7 Pa. A rigid spin stores
// no elastic energy; what the discrete body stores is spurious. The updated rotation must
// store at most half of the lagged one's and gain at most 30 % of its energy. It does not
// remove all: the theta-scheme moves nodes along chords, which stretches the end of a step by
// about (omega dt)^2 / 4 with any rotation (docs/validation.md, rotation within the step).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdio>

#include "models/sim/body.h"
#include "models/sim/scene.h"
#include "models/sim/simulation.h"

namespace ssc {
namespace {

using json = nlohmann::json;

struct Spin {
  double elastic_over_kinetic = 0;  // the largest after a step
  double energy_rise = 0;           // the largest total energy over the start, relative
};

Spin spin(double youngs_modulus, const std::string& corotation) {
  json j;
  j["object"] = {{"primitive", "torus"}, {"major_radius", 0.2}, {"minor_radius", 0.07}, {"rotation_deg", {30, 0, 10}}};
  j["grid"] = {{"cell_size", 0.04}};
  j["material"] = {{"youngs_modulus", youngs_modulus}, {"poisson_ratio", 0.35}, {"density", 100},
                   {"mass_damping", 0.0},             {"stiffness_damping", 0.0}};
  j["gravity"] = {0, 0, 0};
  j["initial"] = {{"angular_velocity", {0, 6, 2}}};
  j["time"] = {{"dt", 0.005}, {"steps", 30}, {"theta", 0.5}};
  j["solver"] = {{"corotation", corotation}, {"energy_tolerance", 0.0}};
  const Scene scene = parse_scene(j, "spin.json");
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid);
  const double start = sim.kinetic_energy(0);
  Spin s;
  for (int n = 0; n < scene.time.steps; ++n) {
    sim.step();
    const double kinetic = sim.kinetic_energy(0), elastic = sim.elastic_energy(0);
    s.elastic_over_kinetic = std::max(s.elastic_over_kinetic, elastic / kinetic);
    s.energy_rise = std::max(s.energy_rise, (kinetic + elastic) / start - 1);
  }
  return s;
}

TEST(CorotationUpdate, SpinningBodyStoresLessSpuriousStrain) {
  std::printf("%8s %22s %22s %18s %18s\n", "E Pa", "elastic/kinetic lagged", "elastic/kinetic updated",
              "energy rise lagged", "energy rise updated");
  for (const double E : {5e5, 5e6, 5e7}) {
    const Spin lagged = spin(E, "lagged"), updated = spin(E, "updated");
    std::printf("%8.0e %21.3f%% %22.3f%% %17.3f%% %18.3f%%\n", E, 100 * lagged.elastic_over_kinetic,
                100 * updated.elastic_over_kinetic, 100 * lagged.energy_rise, 100 * updated.energy_rise);
    EXPECT_LT(updated.elastic_over_kinetic, 0.5 * lagged.elastic_over_kinetic) << "E " << E;
    EXPECT_LT(updated.energy_rise, 0.3 * lagged.energy_rise) << "E " << E;
    if (E <= 5e5) EXPECT_LT(updated.elastic_over_kinetic, 5e-3);
  }
}

}  // namespace
}  // namespace ssc
