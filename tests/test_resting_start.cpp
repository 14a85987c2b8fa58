// A body placed on a plane (or a millimetre into it) is thrown up by the soft-min contact,
// which pushes before touching: the start warns, naming the plane, the distance and the
// position of a resting start, and the body put there stays still. The warning's distance is
// checked against the simulated motion, not against itself.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "models/io/run_record.h"
#include "models/sim/body.h"
#include "models/sim/resting_start.h"
#include "models/sim/scene.h"
#include "models/sim/simulation.h"

namespace ssc {
namespace {
using json = nlohmann::json;

// A 0.2 m cube of 500 kg/m^3 (39 N) whose bottom face is at height `bottom` over a stiff
// ground at height `ground` (k = 1e6 Pa/m, alpha = 100 /m: touching, the bottom face alone is pushed with
// k A ln 2 / alpha = 277 N). Stiff material and no damping, so the motion is nearly rigid.
Scene cube(double bottom, double ground = 0) {
  const json j = {
      {"object", {{"primitive", "box"}, {"half_extents", {0.1, 0.1, 0.1}}, {"position", {0, bottom + 0.1, 0}}}},
      {"grid", {{"cell_size", 0.05}}},
      {"material", {{"youngs_modulus", 1e6}, {"poisson_ratio", 0.3}, {"density", 500}, {"mass_damping", 0},
                    {"stiffness_damping", 0}}},
      {"ground", {{"height", ground}, {"stiffness", 1e6}, {"softmin_alpha", 100}}},
      {"time", {{"dt", 0.002}, {"steps", 200}, {"theta", 0.5}}}};
  return parse_scene(j, "cube.json");
}

// The largest and smallest vertical displacement of the centre of mass over `steps` steps.
std::pair<double, double> vertical_range(Simulation& sim, const SimGrid& grid, int steps) {
  double lo = 0, hi = 0, mass = 0;
  for (double v : grid.node_volume) mass += v;
  for (int s = 0; s < steps; ++s) {
    sim.step();
    double y = 0;
    for (int i = 0; i < grid.node_count; ++i) y += grid.node_volume[i] * sim.displacement(0)[3 * i + 1];
    lo = std::min(lo, y / mass);
    hi = std::max(hi, y / mass);
  }
  return {lo, hi};
}

const Warning* resting_warning() {
  for (const Warning& w : warnings())
    if (w.code == "resting_start") return &w;
  return nullptr;
}

TEST(RestingStart, ACubeOnTheGroundIsThrownUpAndTheWarningSaysHowFar) {
  for (double bottom : {0.0, -0.001}) {
    SCOPED_TRACE(bottom);
    clear_warnings();
    const Scene scene = cube(bottom);
    const SimGrid grid = build_body_grid(scene);
    Simulation sim(scene, grid);
    const Warning* w = resting_warning();
    ASSERT_NE(w, nullptr);
    for (const char* part : {"cube.json", "ground plane 0", bottom == 0 ? "0 m above" : "0.001 m inside",
                             "thrown off the plane", "ground.planes[0].height"})
      EXPECT_NE(w->message.find(part), std::string::npos) << part << " not in: " << w->message;
    const std::vector<RestingStart> jumps = resting_start_jumps(grid, sim.parameters(0), sim.fixed_nodes());
    ASSERT_EQ(jumps.size(), 1u);
    EXPECT_NEAR(jumps[0].lowest, bottom, 1e-9);
    // The apex of the simulated flight (0.25 s covers it) against the rigid, undamped estimate:
    // the theta scheme and the elastic body lose a little.
    const auto [lo, hi] = vertical_range(sim, grid, 125);
    EXPECT_GT(hi, 0.02) << "the cube did not jump";
    EXPECT_NEAR(hi, jumps[0].excursion, 0.15 * jumps[0].excursion);
  }
  clear_warnings();
}

TEST(RestingStart, AtTheEquilibriumTheCubeStaysStillAndNothingIsSaid) {
  const Scene on = cube(0.0);
  const SimGrid on_grid = build_body_grid(on);
  clear_warnings();
  const Simulation probe(on, on_grid);
  const std::vector<RestingStart> jumps = resting_start_jumps(on_grid, probe.parameters(0), probe.fixed_nodes());
  ASSERT_EQ(jumps.size(), 1u);
  const double lift = jumps[0].equilibrium;
  EXPECT_GT(lift, 0.01);  // a stiff contact holds the cube above the plane
  // The warning's fix: the plane lowered by that much (the cube, and so its grid, stay).
  EXPECT_NE(resting_warning()->message.find(fmt::format("ground.planes[0].height to {:.6g}", -lift)), std::string::npos);
  clear_warnings();
  const Scene rest = cube(0.0, -lift);
  const SimGrid grid = build_body_grid(rest);
  Simulation sim(rest, grid);
  EXPECT_EQ(resting_warning(), nullptr);
  const auto [lo, hi] = vertical_range(sim, grid, 50);  // 0.1 s
  EXPECT_LT(std::max(-lo, hi), 1e-3);
  // A drop from 10 cm is out of the contact's reach: no warning.
  clear_warnings();
  const Scene drop = cube(0.1);
  const SimGrid drop_grid = build_body_grid(drop);
  Simulation dropped(drop, drop_grid);
  EXPECT_EQ(resting_warning(), nullptr);
  clear_warnings();
}

}  // namespace
}  // namespace ssc
