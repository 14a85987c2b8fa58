// The air_drag extension (ops/air_drag.h) against terminal velocity: a stiff body falling
// from rest under gravity and the drag -rho_a |v.n| (v.n) n per area reaches
//   V = sqrt(m g / (rho_a A_eff)),  A_eff = integral over the front of |n.e|^3 dA,
// a sphere's A_eff = pi r^2 / 2, a cube falling flat's the face area. The discrete body's
// own A_eff (its cells' surface weights and normals) gives the reference the discretisation
// of the surface does not enter; the analytic A_eff measures that discretisation.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>

#include "models/sim/body.h"
#include "models/sim/scene.h"
#include "models/sim/simulation.h"

namespace ssc {
namespace {

using json = nlohmann::json;
constexpr double kG = 9.81, kPi = 3.14159265358979323846;

struct Fall {
  double terminal_speed = 0;  // the centre of mass's, at the end
  double discrete_area = 0;   // the body's A_eff for a fall along -y
  double mass = 0;
};

Fall fall(const json& object, double cell_size, double rho_air, double seconds, double dt) {
  json j;
  j["object"] = object;
  j["grid"] = {{"cell_size", cell_size}};
  j["material"] = {{"youngs_modulus", 1e7}, {"poisson_ratio", 0.3}, {"density", 100},
                   {"mass_damping", 0.0},   {"stiffness_damping", 0.0}};
  j["gravity"] = {0, -kG, 0};
  j["air_drag"] = rho_air;
  j["time"] = {{"dt", dt}, {"steps", int(seconds / dt)}, {"theta", 0.6}};
  const Scene scene = parse_scene(j, "air_drag.json");
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid);
  for (int n = 0; n < scene.time.steps; ++n) sim.step();
  Fall f;
  f.mass = sim.total_mass();
  f.terminal_speed = -sim.linear_momentum(0).y() / f.mass;
  for (int e = 0; e < grid.cell_count; ++e) {
    const double ny = grid.cell_rest_normal[3 * size_t(e) + 1];
    if (ny >= 0) continue;
    for (int c = 0; c < 8; ++c) f.discrete_area += grid.cell_surface_weights[8 * size_t(e) + c] * std::pow(-ny, 3);
  }
  return f;
}

TEST(AirDrag, SphereReachesItsTerminalVelocity) {
  const double r = 0.1, rho_air = 30;
  // V = sqrt(m g / (rho_a pi r^2 / 2)) = 3.04 m/s, reached with the time constant V / g = 0.31 s.
  const Fall f = fall({{"primitive", "sphere"}, {"radius", r}, {"position", {0, 0, 0}}}, 0.025, rho_air, 3.0, 0.01);
  const double v_discrete = std::sqrt(f.mass * kG / (rho_air * f.discrete_area));
  const double analytic_area = kPi * r * r / 2;
  const double v_analytic = std::sqrt(f.mass * kG / (rho_air * analytic_area));
  std::printf("sphere r = %.2f m, rho_a = %.0f kg/m^3: speed after 3 s %.5f m/s; terminal %.5f m/s with the body's "
              "A_eff %.6f m^2 (%+.3f %%), %.5f m/s with pi r^2 / 2 = %.6f m^2 (%+.3f %%)\n",
              r, rho_air, f.terminal_speed, v_discrete, f.discrete_area, 100 * (f.terminal_speed / v_discrete - 1),
              v_analytic, analytic_area, 100 * (f.terminal_speed / v_analytic - 1));
  EXPECT_NEAR(f.terminal_speed / v_discrete, 1.0, 0.005);
  EXPECT_NEAR(f.terminal_speed / v_analytic, 1.0, 0.03);
}

// A cube's edge cells hold parts of two faces and take their mean normal: its A_eff falls
// short of the face area by the edge ring's share, a first-order discretisation error.
TEST(AirDrag, CubeFallingFlatConvergesToItsFaceArea) {
  const double half = 0.1, rho_air = 5, area = 4 * half * half;
  const json cube = {{"primitive", "box"}, {"half_extents", {half, half, half}}, {"position", {0, 0, 0}}};
  const Fall f = fall(cube, 0.025, rho_air, 3.0, 0.01);
  const double v_discrete = std::sqrt(f.mass * kG / (rho_air * f.discrete_area));
  const double v_face = std::sqrt(f.mass * kG / (rho_air * area));
  std::printf("cube 0.2 m (8 cells across), rho_a = %.0f kg/m^3: speed after 3 s %.5f m/s; terminal %.5f m/s with the "
              "body's A_eff %.6f m^2 (%+.3f %%), %.5f m/s with the face's %.6f m^2 (%+.3f %%)\n",
              rho_air, f.terminal_speed, v_discrete, f.discrete_area, 100 * (f.terminal_speed / v_discrete - 1), v_face,
              area, 100 * (f.terminal_speed / v_face - 1));
  EXPECT_NEAR(f.terminal_speed / v_discrete, 1.0, 0.005);
  double previous = 0;
  for (double h : {0.05, 0.025, 0.0125}) {
    const Fall g = fall(cube, h, rho_air, 0.0, 0.01);
    const double shortfall = 1 - g.discrete_area / area;
    std::printf("  cell %.4f m: A_eff %.6f m^2, %.2f %% below the face area\n", h, g.discrete_area, 100 * shortfall);
    EXPECT_GT(shortfall, 0);
    if (previous > 0) {
      EXPECT_NEAR(previous / shortfall, 2.0, 0.3) << "first order in the cell size";
    }
    previous = shortfall;
  }
}

TEST(AirDrag, SwitchedOffItIsFreeFall) {
  json j;
  j["object"] = {{"primitive", "sphere"}, {"radius", 0.1}, {"position", {0, 0, 0}}};
  j["grid"] = {{"cell_size", 0.05}};
  j["air_drag"] = 30.0;
  j["extensions"] = {{"air_drag", false}};
  const Scene scene = parse_scene(j, "air_drag_off.json");
  EXPECT_FALSE(scene.air_drag_key);
  EXPECT_EQ(build_timestep_graph(0, false, timestep_model(scene)).graph.find_tensor("air_drag"), -1);
}

}  // namespace
}  // namespace ssc
