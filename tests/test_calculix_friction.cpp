// Friction against CalculiX and rigid-body mechanics: a 0.2 m cube (50 kPa, 500 kg/m^3)
// launched at 1.2 m/s down a frictionless-but-for-Coulomb 20 degree incline, resting on it,
// with mu 0.25 (it speeds up) and 0.5 (it slows down). CalculiX simulated it
// (tools/calculix/drops.py, cases friction_low and friction; its surface at 60 Hz kept in
// tests/data/calculix_drops/), ssc simulates the case's scene.json at the same parameters (the
// plane lowered to ssc's contact equilibrium, so that both bodies start at rest where ccx's
// does). A rigid block slides s(t) = v0 t + g (sin a - mu cos a) t^2 / 2 down the slope.
// Compared: the distance slid at 0.1 and 0.2 s (ccx: its surface nodes' centroid; ssc: the
// centre of mass).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "models/geometry/mesh.h"
#include "models/sim/body.h"
#include "models/sim/scene.h"
#include "models/sim/simulation.h"

namespace ssc {
namespace {

constexpr double kPi = 3.14159265358979323846, kG = 9.81, kSlope = 20 * kPi / 180, kV0 = 1.2;
const Eigen::Vector3d kDownhill(std::cos(kSlope), -std::sin(kSlope), 0);

std::string case_dir(const std::string& name) { return std::string(SSC_TEST_DATA_DIR) + "/calculix_drops/" + name; }

Eigen::Vector3d ccx_centroid(const std::string& name, int frame) {
  char file[32];
  std::snprintf(file, sizeof file, "/frames/frame_%04d.ply", frame);
  const TriangleMesh mesh = load_mesh(case_dir(name) + file);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& v : mesh.vertices) sum += v;
  return sum / double(mesh.vertices.size());
}

struct Slid {
  double ccx[2], ssc[2], rigid[2];  // at 0.1 and 0.2 s
};

Slid slide(const std::string& name, double mu, const std::string& frame = "world") {
  Slid out{};
  const Scene scene = load_scene(case_dir(name) + "/scene.json", {"grid.frame=\"" + frame + "\""});
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid);
  const Eigen::Vector3d c0 = sim.center_of_mass(0), x0 = ccx_centroid(name, 0);
  const int per_frame = int(std::lround(1.0 / (60 * scene.time.dt)));
  for (int k = 0; k < 2; ++k) {
    const int frame = 6 * (k + 1);
    const double t = frame / 60.0;
    for (int n = 0; n < 6 * per_frame; ++n) sim.step();
    out.ssc[k] = (sim.center_of_mass(0) - c0).dot(kDownhill);
    out.ccx[k] = (ccx_centroid(name, frame) - x0).dot(kDownhill);
    out.rigid[k] = kV0 * t + 0.5 * kG * (std::sin(kSlope) - mu * std::cos(kSlope)) * t * t;
    std::printf("%s, t = %.1f s: slid %.4f m (CalculiX), %.4f m (ssc), %.4f m (rigid block)\n", name.c_str(), t,
                out.ccx[k], out.ssc[k], out.rigid[k]);
  }
  return out;
}

TEST(CalculixFriction, ACubeSpeedingUpOnTheInclineSlidesAsCalculixAndTheRigidBlock) {
  const Slid s = slide("friction_low", 0.25);
  for (int k = 0; k < 2; ++k) {
    EXPECT_NEAR(s.ccx[k], s.rigid[k], 1e-3) << "CalculiX against the closed form";
    EXPECT_NEAR(s.ssc[k], s.ccx[k], 1.5e-3);
    EXPECT_NEAR(s.ssc[k], s.rigid[k], 1.5e-3);
  }
}

// CalculiX's cube is itself 2.2 mm behind the rigid block at 0.1 s and 0.9 mm ahead at 0.2 s
// (it rocks). ssc's, on a grid along its own axes (grid.frame "object"), agrees with CalculiX
// within 0.4 mm at both; on the world's grid, whose cut cells under its base let it rock
// forward, it brakes 3 % harder (6 mm short at 0.2 s: docs/validation.md).
TEST(CalculixFriction, ACubeSlowingDownOnTheInclineSlidesAsCalculixAndTheRigidBlock) {
  const Slid s = slide("friction", 0.5, "object");
  for (int k = 0; k < 2; ++k) {
    EXPECT_NEAR(s.ccx[k], s.rigid[k], 2.5e-3) << "CalculiX against the closed form";
    EXPECT_NEAR(s.ssc[k], s.ccx[k], 1e-3);
  }
}

}  // namespace
}  // namespace ssc
