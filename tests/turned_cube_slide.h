// The CalculiX friction slide of tests/data/calculix_drops/friction (a 0.2 m cube turned by 20
// degrees onto a 20 degree incline, mu 0.5, launched down it at 1.2 m/s) simulated by ssc for
// 0.4 s on a given grid frame and corner-weight floor, against a rigid block's slide; shared by
// FrictionSlope (the world's grid) and GridFrame (the cube's own).
#pragma once
#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "models/sim/body.h"
#include "models/sim/scene.h"
#include "models/sim/simulation.h"

namespace ssc {

struct TurnedCubeSlide {
  double slid = 0, rigid = 0;        // m down the incline in 0.4 s: ssc's, a rigid block's
  double largest = 0, least_late = 0;  // forward tilt (degrees): largest, smallest in the second half
  double floor = 0;                  // grid.min_node_volume used
};

// floor <= 0: the scene's default corner-weight floor.
inline TurnedCubeSlide turned_cube_slide(const std::string& frame, double floor) {
  constexpr double kPiHere = 3.14159265358979323846, kGHere = 9.81;
  std::ifstream in(std::string(SSC_SOURCE_DIR) + "/tests/data/calculix_drops/friction/scene.json");
  nlohmann::json j = nlohmann::json::parse(in);
  j.erase("observation");
  j["grid"]["frame"] = frame;
  j["time"]["steps"] = 240;  // 0.4 s
  if (floor > 0) j["grid"]["min_node_volume"] = floor;
  const double a = -20 * kPiHere / 180, v0 = 1.2, t_end = 0.4;
  const Eigen::Vector3d along(std::cos(a), std::sin(a), 0), up(-std::sin(a), std::cos(a), 0);
  const double deceleration = kGHere * (0.5 * std::cos(a) - std::sin(-a));
  const Scene scene = parse_scene(j, "calculix_friction.json");
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid);
  const Eigen::Vector3d c0 = sim.center_of_mass(0), top = c0 + 0.09 * up, bottom = c0 - 0.09 * up;
  TurnedCubeSlide r;
  r.floor = scene.grid.min_node_volume;
  r.least_late = 1e9;
  for (int n = 0; n < scene.time.steps; ++n) {
    sim.step();
    const Eigen::Vector3d axis = (top + sim.probe(0, top)) - (bottom + sim.probe(0, bottom));
    const double tilt = std::atan2(axis.dot(along), axis.dot(up)) * 180 / kPiHere;
    r.largest = std::max(r.largest, tilt);
    if (2 * n >= scene.time.steps) r.least_late = std::min(r.least_late, tilt);
  }
  r.slid = (sim.center_of_mass(0) - c0).dot(along);
  r.rigid = v0 * t_end - 0.5 * deceleration * t_end * t_end;
  std::printf("%s grid, corner weights floored at %g h^3/8: slid %.4f m in %.1f s (rigid block %.4f m), largest tilt "
              "%.2f deg, back to %.2f deg in the second half\n",
              frame.c_str(), r.floor, r.slid, t_end, r.rigid, r.largest, r.least_late);
  return r;
}

}  // namespace ssc
