// The second plane's proposals (models/diagnosis/candidates.h, plane_proposals) on a cube that
// slides at 2 m/s into a wall at x = 0.5 m, bounces off and comes back, while the fitted scene
// has the ground alone: the wall is proposed where the observed cube reached farthest (with the
// part of the grid beyond the seen surface), not where it was when the fit had run furthest
// past it (behind its start by then, so no plane was proposed), and its fitted range holds the
// true wall.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "models/diagnosis/candidates.h"
#include "models/sim/body.h"
#include "models/sim/deformed_surface.h"
#include "models/sim/simulation.h"

namespace ssc {
namespace {

nlohmann::json sliding_cube(bool wall) {
  nlohmann::json planes = nlohmann::json::array({{{"height", 0.0}}});
  if (wall) planes.push_back({{"angles_deg", {90, 180}}, {"height", -0.5}});
  return {{"object", {{"primitive", "box"}, {"half_extents", {0.1, 0.1, 0.1}}, {"position", {0.013, 0.1022, 0.007}}}},
          {"grid", {{"cell_size", 0.05}}},
          {"material", {{"youngs_modulus", 5e4}, {"poisson_ratio", 0.3}, {"density", 200}}},
          {"initial", {{"linear_velocity", {2.0, 0.0, 0.0}}}},
          {"ground", {{"stiffness", 1e5}, {"softmin_alpha", 300}, {"planes", planes}}},
          {"time", {{"dt", 0.01}, {"steps", 56}, {"theta", 0.6}}},
          {"solver", {{"contact", "implicit"}}}};
}

TEST(PlaneProposals, AWallTheBodyBouncedOffStandsWhereItReachedFarthest) {
  const Scene data = parse_scene(sliding_cube(true), "wall.json");
  const SimGrid data_grid = build_body_grid(data);
  Simulation sim(data, data_grid, 1, false);
  const DeformedSurface surface(data_grid);
  FittedModel base;
  base.problem.scene = parse_scene(sliding_cube(false), "fit.json");
  base.problem.grid = build_body_grid(base.problem.scene);
  double farthest = -1e9, last = 0;
  for (int step = 1; step <= 56; ++step) {
    sim.step();
    if (step % 4) continue;
    ObservedFrame frame;
    frame.step = step;
    for (const Eigen::Vector3d& x : surface.positions(sim.displacement(0)))
      if (x.z() > 0.05) frame.points.push_back(x);  // the side a camera in front sees
    last = -1e9;
    for (const Eigen::Vector3d& x : frame.points) last = std::max(last, x.x());
    farthest = std::max(farthest, last);
    base.problem.frames.push_back(frame);
  }
  ASSERT_GT(farthest, 0.45);
  ASSERT_LT(last, 0.2) << "the cube came back";
  const std::vector<ModelSpec> specs = plane_proposals(base, int(base.problem.frames.size()), 3);
  ASSERT_FALSE(specs.empty()) << "no wall proposed";
  // n . x >= height with n = -x: the wall at x = -height, fitted within the range.
  const auto range = specs[0].ranges.at("ground.planes[1].height");
  std::printf("proposal: %s; its height fitted in [%g, %g]\n", specs[0].note.c_str(), range.first, range.second);
  EXPECT_EQ(specs[0].note.find("a plane facing (-1.00, "), 0u) << specs[0].note;
  EXPECT_LT(range.first, -0.5);
  EXPECT_GT(range.second, -0.5);
}

}  // namespace
}  // namespace ssc
