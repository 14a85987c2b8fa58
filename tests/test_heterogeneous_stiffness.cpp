// The heterogeneous_stiffness extension (ops/stiffness_field.h) against mechanics with a
// closed form and against CalculiX, an independent FEM code (tests/data/calculix/, made by
// tools/calculix/make-references.sh with 20-node hexahedra):
//  - a bar of two materials hanging under its own weight stretches like two springs in series,
//    delta = rho g int_0^L y / E(y) dy (y the height above its free end);
//  - a graded bar, E(y) = E0 exp(g (y - c)), hanging: the same integral, in closed form;
//  - a cantilever of two materials bending under its weight, against CalculiX: the ratio of
//    its deflections to the homogeneous cantilever's (the trilinear cells' bending lock, which
//    makes both too stiff by about the same factor, cancels), and the absolute deflections.
// Each is a linear static solve: one implicit Euler step (theta = 1) with dt = 1000 s from
// the rest shape, whose system is K + M / dt^2 (the mass term 1e-6 of the stiffness's scale)
// with the rest rotation, the small-deformation equilibrium K u = f.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include "models/sim/body.h"
#include "models/sim/scene.h"
#include "models/sim/simulation.h"
#include "models/sim/timestep_graph.h"
#include "runtime/errors.h"
#include "tests/calculix_reference.h"

namespace ssc {
namespace {

using json = nlohmann::json;
constexpr double kG = 9.81;

json static_scene(const json& object, double cell_size, double E, double nu, double rho, const json& dirichlet) {
  json j;
  j["object"] = object;
  j["grid"] = {{"cell_size", cell_size}};
  j["material"] = {{"youngs_modulus", E}, {"poisson_ratio", nu}, {"density", rho},
                   {"mass_damping", 0.0}, {"stiffness_damping", 0.0}};
  j["gravity"] = {0, -kG, 0};
  j["dirichlet"] = dirichlet;
  j["time"] = {{"dt", 1000.0}, {"steps", 1}, {"theta", 1.0}};
  j["solver"] = {{"tolerance", 1e-11}, {"max_iterations", 50000}, {"energy_tolerance", 0.0}};
  return j;
}

// The displacements at rest points after the static solve.
std::vector<Eigen::Vector3d> static_displacements(const json& config, const std::vector<Eigen::Vector3d>& points,
                                                  std::string* regions = nullptr) {
  const Scene scene = parse_scene(config, "heterogeneous.json");
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid);
  sim.step();
  if (regions) {
    // Cells wholly in no region, wholly in each region, and split between regions.
    const size_t R = scene.material.regions.size();
    std::vector<int> count(R + 2, 0);
    for (int e = 0; e < grid.cell_count; ++e) {
      double rest = 1;
      int whole = -1;
      for (size_t k = 0; k < R; ++k) {
        const double s = grid.cell_region_share[R * size_t(e) + k];
        rest -= s;
        if (s == 1) whole = int(k);
      }
      ++count[rest == 1 ? 0 : whole >= 0 ? size_t(whole) + 1 : R + 1];
    }
    *regions = std::to_string(grid.cell_count) + " cells:";
    for (size_t k = 0; k < count.size(); ++k) *regions += " " + std::to_string(count[k]);
  }
  std::vector<Eigen::Vector3d> u;
  for (const Eigen::Vector3d& x : points) u.push_back(sim.probe(0, x));
  return u;
}

// A 0.1 m square bar hanging from its top face at y = 1 m, its free end at y = 0.
struct HangingBar {
  double rho = 100, nu = 0.05, h = 0.025;
  json object() const { return {{"primitive", "box"}, {"half_extents", {0.05, 0.5, 0.05}}, {"position", {0, 0.5, 0}}}; }
  json clamp() const { return json::array({{{"min", {-1, 1 - 0.25 * h, -1}}, {"max", {1, 2, 1}}}}); }
  double end_drop(const json& material_extra, double E) const {
    json j = static_scene(object(), h, E, nu, rho, clamp());
    for (auto& [k, v] : material_extra.items()) j["material"][k] = v;
    std::string regions;
    const double drop = -static_displacements(j, {Eigen::Vector3d(0, 0, 0)}, &regions)[0].y();
    std::printf("  hanging bar (%s: wholly in no region, wholly in each, split): end drop %.6e m\n", regions.c_str(), drop);
    return drop;
  }
};

TEST(HeterogeneousStiffness, CellsSplitByARegionHoldItsVolume) {
  // A 0.1 m cube on 25 mm cells, region x >= d for planes that cut the cells at several
  // fractions: the cells' shares times their volumes add up to the region's volume, (0.05 - d)
  // x 0.01 m^3, to within a slab of an eighth of a cell (4 samples per cell and axis). Taking
  // each cell whole by its centroid is off by up to half a cell's slab.
  const double h = 0.025;
  for (double d : {0.3 * h, 0.55 * h, -0.8 * h, 0.0}) {
    json j = static_scene({{"primitive", "box"}, {"half_extents", {0.05, 0.05, 0.05}}, {"position", {0, 0, 0}}}, h,
                          1e5, 0.3, 100, json::array());
    j["material"]["regions"] = {{{"normal", {1, 0, 0}}, {"offset", d}, {"youngs_modulus", 2e5}}};
    const Scene scene = parse_scene(j, "split.json");
    const SimGrid grid = build_body_grid(scene);
    double in_region = 0, body = 0;
    int split = 0;
    for (int e = 0; e < grid.cell_count; ++e) {
      double volume = 0;
      for (int c = 0; c < 8; ++c) volume += grid.cell_volume_weights[8 * size_t(e) + c];
      const double share = grid.cell_region_share[size_t(e)];
      in_region += share * volume;
      body += volume;
      split += share > 0 && share < 1;
    }
    const double fraction = in_region / body, truth = (0.05 - d) / 0.1;
    std::printf("region x >= %+.4f m: %.4f of the body (truth %.4f), %d cells split\n", d, fraction, truth, split);
    EXPECT_NEAR(fraction, truth, h / 8 / 0.1 + 1e-9) << d;
    for (double s : grid.cell_region_share) {
      EXPECT_GE(s, 0.0);
      EXPECT_LE(s, 1.0);
    }
  }
}

TEST(HeterogeneousStiffness, TwoMaterialHangingBarStretchesLikeSpringsInSeries) {
  const HangingBar bar;
  const double E1 = 1e5, E2 = 4e5;  // upper half E1, lower half (y <= 0.5) E2
  const json lower = {{"regions", {{{"normal", {0, -1, 0}}, {"offset", -0.5}, {"youngs_modulus", E2}}}}};
  const double drop = bar.end_drop(lower, E1);
  // delta = rho g (int_0.5^1 y dy / E1 + int_0^0.5 y dy / E2) = rho g (0.375 / E1 + 0.125 / E2)
  const double series = bar.rho * kG * (0.375 / E1 + 0.125 / E2);
  const double homogeneous = bar.end_drop(json::object(), E1);
  std::printf("two-material hanging bar: %.6e m, springs in series %.6e m (%+.3f %%); homogeneous E1 %.6e m "
              "(closed form %.6e m, %+.3f %%)\n",
              drop, series, 100 * (drop / series - 1), homogeneous, bar.rho * kG * 0.5 / E1,
              100 * (homogeneous / (bar.rho * kG * 0.5 / E1) - 1));
  EXPECT_NEAR(drop / series, 1.0, 0.01);
  EXPECT_NEAR(homogeneous / (bar.rho * kG * 0.5 / E1), 1.0, 0.01);
}

TEST(HeterogeneousStiffness, GradedHangingBarMatchesTheClosedForm) {
  const HangingBar bar;
  const double E0 = 2e5;
  for (double g : {2.0, -1.5}) {
    // E(y) = E0 exp(g (y - 0.5)) (the rest centre of mass at y = 0.5):
    // delta = rho g0 e^(g/2) / E0 int_0^1 y e^(-g y) dy = rho g0 e^(g/2) (1 - e^(-g) (1 + g)) / (E0 g^2)
    const double closed = bar.rho * kG * std::exp(g / 2) * (1 - std::exp(-g) * (1 + g)) / (E0 * g * g);
    const double drop = bar.end_drop({{"stiffness_gradient", {0.0, g, 0.0}}}, E0);
    std::printf("graded hanging bar, g = %+.1f 1/m: %.6e m, closed form %.6e m (%+.3f %%)\n", g, drop, closed,
                100 * (drop / closed - 1));
    EXPECT_NEAR(drop / closed, 1.0, 0.01) << "g = " << g;
  }
}

double reference_number(const json& r, const std::string& key, const std::string& sub = "") {
  return sub.empty() ? r.at("reference").at(key).get<double>() : r.at("reference").at(key).at(sub).get<double>();
}

TEST(HeterogeneousStiffness, TwoMaterialCantileverAgainstCalculix) {
  // CalculiX's bar: x in [0, 1], 0.1 m square, E = 1e6 Pa (and 4e6 Pa for x >= 0.5 in the
  // two-material case), nu = 0.3, 100 kg/m^3, clamped at x = 0, linear, under its weight.
  const json homogeneous_ref = read_calculix_reference("cantilever_gravity"), two_ref = read_calculix_reference("two_material_cantilever_gravity");
  const double h = 0.025;
  const json object = {{"primitive", "box"}, {"half_extents", {0.5, 0.05, 0.05}}, {"position", {0.5, 0.5, 0}}};
  const json clamp = json::array({{{"min", {-1, -1, -1}}, {"max", {0.25 * h, 2, 1}}}});
  const std::vector<Eigen::Vector3d> points = {{0.25, 0.5, 0}, {0.5, 0.5, 0}, {0.75, 0.5, 0}, {1.0, 0.5, 0}};
  const char* keys[4] = {"x=0.25", "x=0.5", "x=0.75", "x=1"};
  json one = static_scene(object, h, 1e6, 0.3, 100, clamp), two = one;
  two["material"]["regions"] = {{{"normal", {1, 0, 0}}, {"offset", 0.5}, {"youngs_modulus", 4e6}}};
  const std::vector<Eigen::Vector3d> u1 = static_displacements(one, points), u2 = static_displacements(two, points);
  std::printf("cantilever u_y (m), ssc (h = %.3f m, 4 cells thick) against CalculiX (C3D20R 40x4x4):\n", h);
  std::printf("  %-7s %12s %12s %12s %12s %10s %10s\n", "point", "ssc E1", "ccx E1", "ssc E1|E2", "ccx E1|E2",
              "ssc ratio", "ccx ratio");
  for (size_t k = 0; k < points.size(); ++k) {
    const double c1 = reference_number(homogeneous_ref, "centre_line_uy", keys[k]);
    const double c2 = reference_number(two_ref, "centre_line_uy", keys[k]);
    const double r_ssc = u2[k].y() / u1[k].y(), r_ccx = c2 / c1;
    std::printf("  %-7s %12.6e %12.6e %12.6e %12.6e %10.5f %10.5f\n", keys[k], u1[k].y(), c1, u2[k].y(), c2, r_ssc, r_ccx);
    EXPECT_NEAR(r_ssc, r_ccx, 0.01) << keys[k];
    // The trilinear cells lock in bending (tests/test_physics.cpp, PhysicsCantilever): with 4
    // cells through the thickness ssc is stiffer, never softer, by a bounded amount.
    EXPECT_GT(u1[k].y() / c1, 0.80) << keys[k];
    EXPECT_LT(u1[k].y() / c1, 1.01) << keys[k];
  }
}

// Each switch of the scene's "extensions" section turns its extension off and keeps its keys
// valid (they are still read and checked); an unknown name is an input error.
TEST(ExtensionSwitches, EachTurnsItsExtensionOffKeepingItsKeys) {
  json j;
  j["object"] = {{"primitive", "sphere"}, {"radius", 0.1}, {"position", {0, 0.2, 0}}};
  j["grid"] = {{"cell_size", 0.05}};
  j["material"] = {{"regions", {{{"normal", {1, 0, 0}}, {"offset", 0.0}, {"youngs_modulus", 2e4}}}},
                   {"stiffness_gradient", {1, 0, 0}}, {"model", "neo_hookean"}};
  j["ground"] = {{"friction", 0.3}, {"planes", {{{"height", 0.0}}, {{"angles_deg", {90, 0}}, {"height", -1.0}}}}};
  j["air_drag"] = 1.2;
  const Scene on = parse_scene(j, "switches.json");
  const TimestepModel all = timestep_model(on);
  EXPECT_TRUE(all.friction && all.air_drag && all.stiffness_gradient && all.neo_hookean);
  EXPECT_EQ(all.region_count, 1);
  EXPECT_EQ(on.planes.size(), 2u);
  j["extensions"] = {{"friction", false}, {"heterogeneous_stiffness", false}, {"second_plane", false},
                     {"air_drag", false}, {"nonlinear_material", false}};
  const Scene off = parse_scene(j, "switches.json");
  const TimestepModel none = timestep_model(off);
  EXPECT_FALSE(none.friction || none.air_drag || none.stiffness_gradient || none.heterogeneous() || none.neo_hookean);
  EXPECT_EQ(off.planes.size(), 1u);
  EXPECT_EQ(off.extensions_off.size(), 5u);
  j["extensions"] = {{"frition", false}};
  EXPECT_THROW(parse_scene(j, "switches.json"), InputError);
  j["extensions"] = json::object();
  j["material"]["regions"][0]["youngs_modulus"] = -1;  // a switched-off extension's keys are still checked
  j["extensions"]["heterogeneous_stiffness"] = false;
  EXPECT_THROW(parse_scene(j, "switches.json"), InputError);
}

}  // namespace
}  // namespace ssc
