// Coulomb friction at ground contact (ops/friction.h) against mechanics with a closed form:
//  - a box on a slope with mu < tan(a) slides with acceleration g (sin a - mu cos a);
//  - with mu > tan(a) a box released at rest stays (it may creep below the smoothing
//    velocity eps: at most eps r / sqrt(1 - r^2), r = tan(a) / mu);
//  - a box launched at v0 on a level plane stops after v0^2 / (2 mu g).
// The slope is the level plane with gravity tilted by a (the same mechanics; the box then
// starts axis-aligned on the plane). Figures are printed for docs/validation.md.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "models/sim/body.h"
#include "models/sim/scene.h"
#include "models/sim/simulation.h"
#include "tests/mean_velocity.h"

namespace ssc {
namespace {

using json = nlohmann::json;
constexpr double kG = 9.81, kPi = 3.14159265358979323846;

// A flat elastic box, 10 x 2.5 x 10 cm (E 100 kPa, 500 kg/m^3), on the plane y = 0 (k 1e6 Pa/m,
// soft-min 1000 /m), gravity tilted by `slope_deg` about z. It starts at the height where the
// soft-min pressure carries its weight (2.04 mm above the plane). Flat, because on a penalty
// ground a box's rear edge lifts once the friction moment puts the resultant outside the middle
// third of its base (mu h > w / 6, a Winkler foundation's kern): then it rocks, as a real box on
// a soft floor would; this one stays flat up to mu = 1.33.
json box_scene(double slope_deg, double mu, double vx, double dt, int steps) {
  const double a = slope_deg * kPi / 180;
  json j;
  j["object"] = {{"primitive", "box"}, {"half_extents", {0.05, 0.0125, 0.05}}, {"position", {0, 0.0125 + 0.00204, 0}}};
  j["grid"] = {{"cell_size", 0.0125}};
  j["material"] = {{"youngs_modulus", 1e5}, {"poisson_ratio", 0.3}, {"density", 500}, {"mass_damping", 0.0},
                   {"stiffness_damping", 0.002}};
  j["gravity"] = {kG * std::sin(a), -kG * std::cos(a), 0};
  j["initial"] = {{"linear_velocity", {vx, 0, 0}}};
  j["ground"] = {{"height", 0.0}, {"stiffness", 1e6}, {"softmin_alpha", 1000}, {"friction", mu}};
  j["time"] = {{"dt", dt}, {"steps", steps}, {"theta", 0.6}};
  j["solver"] = {{"tolerance", 1e-10}, {"max_iterations", 5000}, {"energy_tolerance", 0.05}};
  return j;
}

struct Trajectory {
  std::vector<double> x, vx;  // centre of mass along the slope, and its velocity, per step (0: start)
};

Trajectory run(const json& j) {
  const Scene scene = parse_scene(j, "friction_test.json");
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid);
  Trajectory r;
  const double x0 = sim.center_of_mass(0).x();
  auto mean_vx = [&] { return mean_velocity_x(sim, grid); };
  r.x.push_back(0);
  r.vx.push_back(mean_vx());
  for (int n = 0; n < scene.time.steps; ++n) {
    sim.step();
    r.x.push_back(sim.center_of_mass(0).x() - x0);
    r.vx.push_back(mean_vx());
  }
  return r;
}

TEST(Friction, BoxSlidesDownASlopeWithTheCoulombAcceleration) {
  const double dt = 1.0 / 600;
  struct Case {
    double slope_deg, mu;
  };
  for (const Case c : {Case{30, 0.2}, Case{20, 0.1}, Case{40, 0.5}, Case{25, 0.3}}) {
    const double a = c.slope_deg * kPi / 180;
    const double expected = kG * (std::sin(a) - c.mu * std::cos(a));
    // Launched down the slope at 0.3 m/s (sliding from the start, |w| >> eps); the
    // acceleration from the velocity between 0.1 s and 0.4 s (the landing transient over).
    const Trajectory r = run(box_scene(c.slope_deg, c.mu, 0.3, dt, 240));
    const int n1 = 60, n2 = 240;
    const double measured = (r.vx[n2] - r.vx[n1]) / ((n2 - n1) * dt);
    std::printf("slope %2.0f deg, mu %.2f: acceleration %.4f m/s^2, g (sin a - mu cos a) = %.4f (%+.2f %%)\n",
                c.slope_deg, c.mu, measured, expected, 100 * (measured / expected - 1));
    EXPECT_NEAR(measured, expected, 0.015 * expected) << "slope " << c.slope_deg << ", mu " << c.mu;
  }
}

TEST(Friction, BoxAtRestOnASlopeSteeperThanItsFrictionStays) {
  const double dt = 1.0 / 600, eps = 1e-3, T = 1.0;
  struct Case {
    double slope_deg, mu;
  };
  for (const Case c : {Case{20, 0.6}, Case{10, 0.3}, Case{30, 0.9}}) {
    const double r_ = std::tan(c.slope_deg * kPi / 180) / c.mu;
    const Trajectory r = run(box_scene(c.slope_deg, c.mu, 0.0, dt, int(T / dt)));
    const double creep = eps * r_ / std::sqrt(1 - r_ * r_);
    // The release excites the body's rocking on the penalty ground (undamped there; the same
    // without friction): the centre of mass wobbles about a fixed point. The mean speed over
    // the second half is the drift.
    const size_t half = r.vx.size() / 2;
    double max_speed = 0;
    for (size_t n = half; n < r.vx.size(); ++n) max_speed = std::max(max_speed, std::abs(r.vx[n]));
    const double drift = (r.x.back() - r.x[half]) / (T / 2);
    std::printf("slope %2.0f deg, mu %.2f (tan a / mu = %.2f): moved %.3f mm in %.1f s; drift in the second half "
                "%.3f mm/s (creep bound %.3f mm/s), wobble up to %.1f mm/s\n",
                c.slope_deg, c.mu, r_, 1e3 * r.x.back(), T, 1e3 * drift, 1e3 * creep, 1e3 * max_speed);
    // The normal force varies with the wobble, so the creep runs a little above the bound
    // computed for the static normal force.
    EXPECT_LT(std::abs(r.x.back()), 1.5e-3) << "slope " << c.slope_deg << ", mu " << c.mu;
    EXPECT_LT(std::abs(drift), 1.5 * creep) << "slope " << c.slope_deg << ", mu " << c.mu;
    EXPECT_LT(max_speed, 0.02) << "a wobble, not a slide";
  }
}

TEST(Friction, BoxLaunchedOnALevelPlaneStopsAfterTheCoulombDistance) {
  const double dt = 1.0 / 600;
  struct Case {
    double v0, mu;
  };
  for (const Case c : {Case{1.0, 0.5}, Case{0.6, 0.3}, Case{1.5, 0.8}}) {
    const double expected = c.v0 * c.v0 / (2 * c.mu * kG);
    const int steps = int(1.5 * c.v0 / (c.mu * kG) / dt) + 60;
    const Trajectory r = run(box_scene(0, c.mu, c.v0, dt, steps));
    // At rest it wobbles on the penalty ground (as in the test above); the mean speed over
    // the last 0.1 s is the drift.
    const size_t last = r.x.size() - 1, back = size_t(0.1 / dt);
    const double drift = (r.x[last] - r.x[last - back]) / 0.1;
    std::printf("v0 %.1f m/s, mu %.2f: stopped after %.4f m, v0^2 / (2 mu g) = %.4f m (%+.2f %%), drift at the end "
                "%.2f mm/s\n",
                c.v0, c.mu, r.x.back(), expected, 100 * (r.x.back() / expected - 1), 1e3 * drift);
    EXPECT_NEAR(r.x.back(), expected, 0.02 * expected) << "v0 " << c.v0 << ", mu " << c.mu;
    EXPECT_LT(std::abs(drift), 2.5e-3);
  }
}

TEST(Friction, FrictionlessSceneHasNoFrictionOp) {
  json j = box_scene(0, 0, 0, 0.01, 1);
  j["ground"].erase("friction");
  const Scene scene = parse_scene(j, "friction_test.json");
  EXPECT_FALSE(models_friction(scene));
  const Scene with = parse_scene(box_scene(0, 0, 0, 0.01, 1), "friction_test.json");
  EXPECT_TRUE(models_friction(with)) << "a friction key (even 0) puts the op in the model, so that mu can be fitted";
}

}  // namespace
}  // namespace ssc
