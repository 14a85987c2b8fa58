// A 0.2 m cube on a 25 degree slope with Coulomb friction (ops/friction.h), against rigid-body
// statics: with mu > tan(a) it stays (up to the elastic settling and the smoothed law's creep,
// at most eps r / sqrt(1 - r^2), r = tan(a) / mu), with mu < tan(a) it slides with
// g (sin a - mu cos a), and it does not tip (a rigid block tips only past tan(a) = w / h); a
// block three times as tall as wide does tip there. The slope is the level plane y = 0 with
// gravity tilted by a about z, so that the block's faces lie on grid planes.
//
// The ground is stiff (k = 1e7 Pa/m, soft-min 1e4 /m): on a soft penalty ground a standing
// block can tip for real (a rigid block on the default 1e5 Pa/m ground has no equilibrium on
// this slope, whatever mu: docs/validation.md); its base's contact points reach its edges (its
// rims are surface nodes, models/grid/sim_grid.h). The linearized contact takes
// dt = 1/600 s on that ground (at 1/300 s its points bounce off it), the implicit 1/300 s.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>

#include "models/sim/body.h"
#include "models/sim/scene.h"
#include "models/sim/simulation.h"
#include "tests/mean_velocity.h"
#include "tests/turned_cube_slide.h"

namespace ssc {
namespace {

using json = nlohmann::json;
constexpr double kG = 9.81, kPi = 3.14159265358979323846, kSlopeDeg = 25;

struct BlockOnSlope {
  double mu = 0.6;
  bool implicit = true;
  double half_width = 0.1, half_height = 0.1;
  double duration = 1.0;
  double slope_deg = kSlopeDeg;
  double youngs_modulus = 2e5, density = 400;
  double ground_stiffness = 1e7, softmin_alpha = 1e4;
  double speed = 0;  // initial, down the slope
  double dt = 0;     // 0: 1/300 s with implicit contact, 1/600 s with linearized
  double theta = 0.6;
  double lift = 0;   // of the block's base above the plane at the start, m
  double ground_height = 0;
  double stiffness_damping = -1;  // < 0: the scene's default
  int contact_subdivisions = 0;   // 0: the scene's default
};

// The height at which a level plane's soft-min pressure, (k / alpha) ln(1 + exp(-alpha d)),
// carries the block's weight.
double resting_lift(const BlockOnSlope& s) {
  const double pressure = s.density * kG * 2 * s.half_height;
  return -std::log(std::expm1(pressure * s.softmin_alpha / s.ground_stiffness)) / s.softmin_alpha;
}

json block_scene(const BlockOnSlope& s) {
  const double a = s.slope_deg * kPi / 180;
  json j;
  j["object"] = {{"primitive", "box"},
                 {"half_extents", {s.half_width, s.half_height, s.half_width}},
                 {"position", {0, s.half_height + s.lift, 0}}};
  j["grid"] = {{"cell_size", 0.025}};
  if (s.contact_subdivisions > 0) j["grid"]["contact_subdivisions"] = s.contact_subdivisions;
  j["material"] = {{"youngs_modulus", s.youngs_modulus}, {"poisson_ratio", 0.3}, {"density", s.density},
                   {"mass_damping", 0.0}};
  j["gravity"] = {kG * std::sin(a), -kG * std::cos(a), 0};
  j["initial"] = {{"linear_velocity", {s.speed, 0, 0}}};
  if (s.stiffness_damping >= 0) j["material"]["stiffness_damping"] = s.stiffness_damping;
  j["ground"] = {{"height", s.ground_height}, {"stiffness", s.ground_stiffness}, {"softmin_alpha", s.softmin_alpha},
                 {"friction", s.mu}};
  const double dt = s.dt > 0 ? s.dt : s.implicit ? 1.0 / 300 : 1.0 / 600;
  j["time"] = {{"dt", dt}, {"steps", int(std::lround(s.duration / dt))}, {"theta", s.theta}};
  j["solver"] = {{"tolerance", 1e-10}, {"max_iterations", 5000}, {"contact", s.implicit ? "implicit" : "linearized"}};
  return j;
}

struct Motion {
  double dt = 0;
  std::vector<double> x, vx;  // centre of mass down the slope and its velocity, per step (0: start)
  double max_tilt_deg = 0;    // largest forward rotation of the block's axis
};

Motion run(const BlockOnSlope& s) {
  const Scene scene = parse_scene(block_scene(s), "friction_slope_test.json");
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid);
  Motion m;
  m.dt = scene.time.dt;
  const Eigen::Vector3d c0 = sim.center_of_mass(0);
  const Eigen::Vector3d top = c0 + Eigen::Vector3d(0, 0.9 * s.half_height, 0);
  const Eigen::Vector3d bottom = c0 - Eigen::Vector3d(0, 0.9 * s.half_height, 0);
  auto mean_vx = [&] { return mean_velocity_x(sim, grid); };
  m.x.push_back(0);
  m.vx.push_back(0);
  for (int n = 0; n < scene.time.steps; ++n) {
    sim.step();
    m.x.push_back(sim.center_of_mass(0).x() - c0.x());
    m.vx.push_back(mean_vx());
    const Eigen::Vector3d axis = (top + sim.probe(0, top)) - (bottom + sim.probe(0, bottom));
    m.max_tilt_deg = std::max(m.max_tilt_deg, std::atan2(axis.x(), axis.y()) * 180 / kPi);
  }
  return m;
}

const char* contact_name(bool implicit) { return implicit ? "implicit" : "linearized"; }

// Bound on the centre of mass's travel over T: 4.5 mm for the release (the cube's elastic
// shear under the friction traction, 0.4 mm, its tilt on the penalty ground, 0.6 degrees or
// 1 mm, and the slip before the friction has built up: 1.6 to 4 mm measured) plus 1.5 times
// the creep bound for T (the normal force on each point varies as the cube rocks, so a point's
// tan(a) / mu runs above the mean). Before the op's fix the cube slid 1 m.
TEST(FrictionSlope, CubeStaysWhenMuExceedsTanSlope) {
  const double eps = 1e-3, settle = 4.5e-3;
  for (const bool implicit : {false, true})
    for (const double mu : {0.6, 0.5}) {
      BlockOnSlope s;
      s.mu = mu;
      s.implicit = implicit;
      const Motion m = run(s);
      const double r = std::tan(kSlopeDeg * kPi / 180) / mu, creep = eps * r / std::sqrt(1 - r * r);
      const size_t half = m.x.size() / 2;
      const double drift = (m.x.back() - m.x[half]) / (s.duration / 2);
      std::printf("%-10s mu %.1f (tan a / mu = %.2f): moved %.2f mm in %.0f s (bound %.2f mm); drift in the second "
                  "half %.2f mm/s (creep bound %.2f mm/s); largest tilt %.2f deg\n",
                  contact_name(implicit), mu, r, 1e3 * m.x.back(), s.duration,
                  1e3 * (settle + 1.5 * creep * s.duration), 1e3 * drift, 1e3 * creep, m.max_tilt_deg);
      EXPECT_LT(std::abs(m.x.back()), settle + 1.5 * creep * s.duration) << contact_name(implicit) << ", mu " << mu;
      EXPECT_LT(std::abs(drift), 1.5 * creep) << contact_name(implicit) << ", mu " << mu;
      EXPECT_LT(m.max_tilt_deg, 2.0) << "a cube (w / h = 1) on tan a = 0.47 must not tip";
    }
}

TEST(FrictionSlope, CubeSlidesWithTheCoulombAcceleration) {
  const double a = kSlopeDeg * kPi / 180;
  for (const bool implicit : {false, true}) {
    BlockOnSlope s;
    s.mu = 0.3;
    s.implicit = implicit;
    s.duration = 0.8;
    const Motion m = run(s);
    const double expected = kG * (std::sin(a) - s.mu * std::cos(a));
    // From rest; the acceleration from the velocity between 0.2 s and the end (the release over).
    const size_t n1 = size_t(std::lround(0.2 / m.dt)), n2 = m.vx.size() - 1;
    const double measured = (m.vx[n2] - m.vx[n1]) / ((n2 - n1) * m.dt);
    std::printf("%-10s mu 0.3: acceleration %.4f m/s^2, g (sin a - mu cos a) = %.4f (%+.2f %%); largest tilt %.2f deg\n",
                contact_name(implicit), measured, expected, 100 * (measured / expected - 1), m.max_tilt_deg);
    EXPECT_NEAR(measured, expected, 0.02 * expected) << contact_name(implicit);
    EXPECT_LT(m.max_tilt_deg, 2.0);
  }
}

// A block 0.1 x 0.3 x 0.1 m (w / h = 1/3 < tan a) held by mu = 1 tips over its front edge.
TEST(FrictionSlope, TallBlockTipsPastItsEdge) {
  BlockOnSlope s;
  s.mu = 1.0;
  s.half_width = 0.05;
  s.half_height = 0.15;
  const Motion m = run(s);
  std::printf("tall block (h / w = 3), mu 1.0: largest tilt %.1f deg in %.0f s, moved %.1f mm\n", m.max_tilt_deg,
              s.duration, 1e3 * m.x.back());
  EXPECT_GT(m.max_tilt_deg, 30.0);
}

// The CalculiX friction cases' cube (0.2 m, 500 kg/m^3), ground (k 1e8 Pa/m, soft-min 5000 /m),
// step (1/600 s, theta 0.55), cells (25 mm) and damping (none), launched at 1.2 m/s along a level
// plane with mu = 0.5. The plane is lowered to where the soft-min ground carries the cube, so
// that its faces stay on grid planes (`lifted`: the cube is raised instead).
BlockOnSlope launched_cube(double youngs_modulus, bool lifted) {
  BlockOnSlope s;
  s.slope_deg = 0;
  s.mu = 0.5;
  s.youngs_modulus = youngs_modulus, s.density = 500;
  s.stiffness_damping = 0;
  s.ground_stiffness = 1e8, s.softmin_alpha = 5e3;
  if (lifted)
    s.lift = resting_lift(s);
  else
    s.ground_height = -resting_lift(s);
  s.speed = 1.2;
  s.dt = 1.0 / 600, s.theta = 0.55;
  s.duration = 0.4;
  return s;
}

// A rigid block stops after v0^2 / (2 mu g) = 0.147 m and does not tip (mu < w / h). The soft
// cube (50 kPa) shears and rocks on the penalty ground; before its rims carried contact points
// its base's points stopped 25 mm short of its front edge, and it tipped over the row before it
// (49 degrees) and tumbled on.
TEST(FrictionSlope, CubeLaunchedOnALevelPlaneStopsAfterTheCoulombDistanceUntipped) {
  for (const double E : {5e4, 2e5, 1e6}) {
    const BlockOnSlope s = launched_cube(E, false);
    const Motion m = run(s);
    const double expected = s.speed * s.speed / (2 * s.mu * kG);
    std::printf("cube, E %.0f kPa, v0 %.1f m/s, mu %.1f: stopped after %.4f m (v0^2 / (2 mu g) = %.4f m, %+.1f %%), "
                "largest tilt %.1f deg\n",
                E / 1e3, s.speed, s.mu, m.x.back(), expected, 100 * (m.x.back() / expected - 1), m.max_tilt_deg);
    EXPECT_NEAR(m.x.back(), expected, 0.02 * expected) << "E " << E;
    EXPECT_LT(m.max_tilt_deg, 8.0) << "E " << E;
  }
}

// The same soft cube raised by the same height instead, so that its faces lie 0.6 mm off the
// grid planes: the sampled SDF's zero level then bevels each convex edge across a cell. With
// contact points on the cells' own edges (contact_subdivisions 1) its base's points reach
// +-75 mm of the 100, and it tips by 50 degrees and tumbles; on the box's exact surface with a
// finer lattice (the default 2, and 4) they reach its rims to within h / s.
TEST(FrictionSlope, CubeOffTheGridPlanesLaunchedOnALevelPlaneStopsAfterTheCoulombDistanceUntipped) {
  for (const int subdivisions : {1, 2, 4}) {
    BlockOnSlope s = launched_cube(5e4, true);
    s.contact_subdivisions = subdivisions;
    const Motion m = run(s);
    const double expected = s.speed * s.speed / (2 * s.mu * kG);
    std::printf("soft cube off the grid planes, contact_subdivisions %d: stopped after %.4f m (%+.1f %%), largest tilt "
                "%.1f deg\n",
                subdivisions, m.x.back(), 100 * (m.x.back() / expected - 1), m.max_tilt_deg);
    if (subdivisions == 1) {
      EXPECT_GT(m.max_tilt_deg, 30.0) << "the bevelled base no longer tips: update this test and docs/diagnosis.md";
      continue;
    }
    EXPECT_NEAR(m.x.back(), expected, 0.03 * expected) << "contact_subdivisions " << subdivisions;
    EXPECT_LT(m.max_tilt_deg, 10.0) << "contact_subdivisions " << subdivisions;
  }
}

// The CalculiX friction slide in ssc (tests/data/calculix_drops/friction: a 0.2 m cube at 50 kPa
// turned by 20 degrees onto a 20 degree incline, mu 0.5, launched down it at 1.2 m/s): a rigid
// block decelerates at g (sin a - mu cos a) = -1.25 m/s^2 and does not tip (mu < w / h). Its
// faces are oblique to the grid, so its surface cells are cut and their outer corners carry
// almost no volume: with the corner weights floored at 1e-3 h^3/8 those corners are a soft
// hinge under the base, and on 25 mm cells the cube tips forward and tumbles (64 degrees by
// 0.4 s); at the default floor it rocks and comes back, as on 12.5 mm cells.
// On the world's grid (grid.frame "world"); in the cube's own frame its faces lie on grid planes
// (GridFrame.TheCubeTurnedOntoTheInclineSlidesAsARigidBlock).
TEST(FrictionSlope, CubeTurnedOffTheGridSlidesDownTheInclineRockingNotTumbling) {
  const TurnedCubeSlide tumbles = turned_cube_slide("world", 1e-3);
  EXPECT_GT(tumbles.largest, 45.0) << "the floor of 1e-3 no longer tumbles: update this test and docs/diagnosis.md";
  const TurnedCubeSlide s = turned_cube_slide("world", -1.0);
  EXPECT_LT(s.largest, 12.0);
  EXPECT_LT(s.least_late, 2.0) << "it does not rock back";
  EXPECT_NEAR(s.slid, s.rigid, 0.02 * s.rigid);
}

}  // namespace
}  // namespace ssc
