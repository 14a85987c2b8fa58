// grid.frame "object" (models/grid/sim_grid.h, RestPose): a rotated object's grid is laid along
// its own axes and its rotation becomes a rigid initial displacement. Corotated elasticity does
// not care which way the rest body faces, so the body must move as its twin in a world turned
// so that the object needs no rotation; the scene's world inputs (regions, gradient, probes)
// must land where the world frame puts them; and the cube turned onto an incline, whose faces
// the world grid cuts (FrictionSlope.CubeTurnedOffTheGridSlidesDownTheInclineRockingNotTumbling),
// slides as a rigid block does.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>

#include "models/sim/body.h"
#include "models/sim/scene.h"
#include "models/sim/simulation.h"
#include "runtime/errors.h"
#include "tests/turned_cube_slide.h"

namespace ssc {
namespace {

using json = nlohmann::json;
constexpr double kPi = 3.14159265358979323846;

// The CalculiX friction slide: a 0.2 m cube turned by -20 degrees about z onto a 20 degree
// incline, mu 0.5, launched down it at 1.2 m/s; 25 mm cells.
json friction_slide() {
  std::ifstream in(std::string(SSC_TEST_DATA_DIR) + "/calculix_drops/friction/scene.json");
  json j = json::parse(in);
  j.erase("observation");
  return j;
}

Eigen::Vector3d turn_z(const Eigen::Vector3d& v, double deg) {
  const double c = std::cos(deg * kPi / 180), s = std::sin(deg * kPi / 180);
  return {c * v.x() - s * v.y(), s * v.x() + c * v.y(), v.z()};
}

Eigen::Vector3d vec(const json& a) { return {a[0].get<double>(), a[1].get<double>(), a[2].get<double>()}; }
json arr(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

// The same scene with the world turned by +20 degrees about z: the cube unrotated on a level
// plane, gravity and the launch turned.
json turned_twin(json j) {
  const double by = 20;
  j["object"]["position"] = arr(turn_z(vec(j["object"]["position"]), by));
  j["object"]["rotation_deg"] = {0, 0, 0};
  j["gravity"] = arr(turn_z(vec(j["gravity"]), by));
  j["initial"]["linear_velocity"] = arr(turn_z(vec(j["initial"]["linear_velocity"]), by));
  j["ground"]["planes"][0]["angles_deg"] = {0.0, 0.0};
  j["grid"]["frame"] = "world";
  return j;
}

TEST(GridFrame, ATurnedCubeMovesAsItsTwinInATurnedWorld) {
  json object = friction_slide();
  object["grid"]["frame"] = "object";
  const Scene a = parse_scene(object, "object_frame.json"), b = parse_scene(turned_twin(object), "turned_world.json");
  const SimGrid ga = build_body_grid(a), gb = build_body_grid(b);
  EXPECT_EQ(ga.cell_count, gb.cell_count) << "the same cells: the cube's faces on grid planes in both";
  EXPECT_NEAR(ga.total_volume, 0.008, 1e-9);
  Simulation sa(a, ga), sb(b, gb);
  const Eigen::Vector3d top = vec(object["object"]["position"]) + turn_z(Eigen::Vector3d(0.05, 0.09, 0.02), -20);
  double worst = 0, worst_probe = 0;
  for (int n = 0; n <= a.time.steps; ++n) {
    if (n > 0) sa.step(), sb.step();
    const Eigen::Vector3d ca = sa.center_of_mass(0), cb = turn_z(sb.center_of_mass(0), -20);
    worst = std::max(worst, (ca - cb).norm());
    const Eigen::Vector3d pa = sa.probe(0, top), pb = turn_z(sb.probe(0, turn_z(top, 20)), -20);
    worst_probe = std::max(worst_probe, (pa - pb).norm());
    if (n == 0) {
      // The twin's cube stands 1e-5 m off its grid plane (the scene's rounded position), which
      // the zero cutoff snaps onto it.
      EXPECT_LT((ca - cb).norm(), 2e-5) << "the pose places the rest body where the world frame does";
      EXPECT_LT(pa.norm(), 1e-12) << "a probe moves from where it starts";
    }
  }
  std::printf("over %d steps: centres of mass at most %.3g mm apart, a point near the top %.3g mm\n", a.time.steps,
              1e3 * worst, 1e3 * worst_probe);
  // What remains is the CG's tolerance: its Jacobi preconditioner is diagonal in the world's axes.
  EXPECT_LT(worst, 5e-4);
  EXPECT_LT(worst_probe, 5e-4);
}

TEST(GridFrame, TheCubeTurnedOntoTheInclineSlidesAsARigidBlock) {
  // Also with the corner weights floored at 1e-3 h^3/8, where the world grid tumbles.
  for (const double floor : {1e-3, -1.0}) {
    const TurnedCubeSlide s = turned_cube_slide("object", floor);
    EXPECT_NEAR(s.slid, s.rigid, 0.02 * s.rigid);
    // The soft body rocks (6.0 degrees measured at both floors, where the world grid's floor of
    // 1e-3 tumbles past 45) and comes back.
    EXPECT_LT(s.largest, 8.0);
    EXPECT_LT(s.least_late, 2.0) << "it does not rock back";
  }
}

TEST(GridFrame, RegionsAndTheStiffnessGradientAreGivenInTheWorld) {
  std::ifstream in(std::string(SSC_TEST_DATA_DIR) + "/calculix_drops/two_materials/scene.json");
  json j = json::parse(in);
  j.erase("observation");
  j["material"]["stiffness_gradient"] = {3.0, -2.0, 0.0};
  double region_volume[2], region_x[2], gradient_x[2];
  for (int f = 0; f < 2; ++f) {
    j["grid"]["frame"] = f == 0 ? "object" : "world";
    const Scene scene = parse_scene(j, "two_materials.json");
    const SimGrid g = build_body_grid(scene);
    Simulation sim(scene, g);
    const std::vector<double> E = sim.cell_youngs(0);
    double v = 0, x = 0, ex = 0, e = 0;
    for (int c = 0; c < g.cell_count; ++c) {
      v += g.cell_region_share[size_t(c)] * g.cell_volume[size_t(c)];
      x += g.cell_region_share[size_t(c)] * g.cell_volume[size_t(c)] * g.cell_start(c).x();
      ex += E[size_t(c)] * g.cell_volume[size_t(c)] * g.cell_start(c).x();
      e += E[size_t(c)] * g.cell_volume[size_t(c)];
    }
    region_volume[f] = v, region_x[f] = x / v, gradient_x[f] = ex / e;
    std::printf("%s frame: the stiff region holds %.5f m^3, centred at x = %.4f m; the modulus-weighted x %.4f m\n",
                f == 0 ? "object" : "world", v, region_x[f], gradient_x[f]);
  }
  // The two grids cut the body differently: within a few percent, and a fraction of a cell.
  EXPECT_NEAR(region_volume[0], region_volume[1], 0.05 * region_volume[1]);
  EXPECT_NEAR(region_x[0], region_x[1], 0.005);
  EXPECT_NEAR(gradient_x[0], gradient_x[1], 0.005);
}

// The band around the body takes the Laplacian extension of its displacement, which carries a
// translation but not a rotation: a large initial turn would bend the band cells (and the cost
// read through them) from the first extended step on. Extended relative to the pose, the band
// of a body in free fall moves rigidly with it: the pose's displacement plus g t^2 / 2.
TEST(GridFrame, ABodyTurnedFarFallsWithItsBandRigid) {
  json j;
  j["object"] = {{"primitive", "box"}, {"half_extents", {0.1, 0.06, 0.08}}, {"position", {0.3, 1.0, -0.2}},
                 {"rotation_deg", {30, -100, 45}}};
  j["grid"] = {{"cell_size", 0.04}, {"band_width", 3}, {"frame", "object"}};
  j["material"] = {{"youngs_modulus", 5e4}, {"poisson_ratio", 0.3}, {"density", 500}, {"mass_damping", 0.0}, {"stiffness_damping", 0.0}};
  j["gravity"] = {0, -9.81, 0};
  j["time"] = {{"dt", 0.01}, {"steps", 10}, {"theta", 0.5}};
  j["solver"] = {{"tolerance", 1e-12}, {"extension_tolerance", 1e-13}};
  const Scene scene = parse_scene(j, "turned_far.json");
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid, 1, true);  // with the band extension
  ASSERT_GT(grid.band_count, 0);
  double worst = 0;
  for (int n = 0; n <= scene.time.steps; ++n) {
    if (n > 0) sim.step();
    const double t = n * scene.time.dt;
    const double* band = sim.band_displacement(0);
    ASSERT_NE(band, nullptr);
    for (int b = 0; b < grid.band_count; ++b) {
      const Eigen::Vector3d x = grid.sdf.node_position(grid.band_grid[size_t(b)]);
      const Eigen::Vector3d rigid = grid.start(x) - x + Eigen::Vector3d(0, -0.5 * 9.81 * t * t, 0);
      worst = std::max(worst, (Eigen::Vector3d(band[3 * b], band[3 * b + 1], band[3 * b + 2]) - rigid).norm());
    }
  }
  std::printf("band of %d nodes over %d steps of free fall: at most %.3g m from the rigid motion\n", grid.band_count,
              scene.time.steps, worst);
  // The theta-scheme with theta 0.5 falls exactly as g t^2 / 2; what is left is the solves'.
  EXPECT_LT(worst, 1e-9);
}

TEST(GridFrame, AnUnknownFrameIsAnInputErrorNamingTheKey) {
  json j = friction_slide();
  j["grid"]["frame"] = "body";
  try {
    parse_scene(j, "frame.json");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("grid.frame"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("\"object\""), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ssc
