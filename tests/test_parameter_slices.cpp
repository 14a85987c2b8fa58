// One-sided identification (models/diagnosis/parameter_slices.h):
//  - the span of values that fit as well as the fitted one, on made-up costs;
//  - a cube at rest on a 25 degree slope with mu = 0.8 fixes only a lower bound on its friction:
//    every mu above tan 25 = 0.466 holds it (rigid-body statics), so the held-in cost is flat
//    from there to the plausible range's end, 1.5 (within the diagnosis's 5 % of the fitted
//    cost), and rises where the cube would slide.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "models/diagnosis/parameter_slices.h"
#include "models/sim/parameters.h"
#include "models/sim/problem.h"
#include "tests/cli_test_folder.h"

namespace ssc {
namespace {

using json = nlohmann::json;

ParameterSlice made_up(std::vector<double> values, std::vector<double> costs) {
  ParameterSlice s;
  s.values = std::move(values);
  s.costs = std::move(costs);
  return s;
}

TEST(SupportedSpan, APlateauToTheRangesEndIsALowerBound) {
  ParameterSlice s = made_up({0, 0.4, 0.6, 0.8, 1.0, 1.5}, {9, 3, 1.01, 1, 1.0, 1.005});
  supported_span(s, 3, 0, 1.5, 0.02);  // within 2 % of the fitted cost
  EXPECT_EQ(s.low, 0.6);
  EXPECT_EQ(s.high, 1.5);
  EXPECT_FALSE(s.open_low);
  EXPECT_TRUE(s.open_high);
}

TEST(SupportedSpan, AMinimumInsideTheRangeIsClosedOnBothSides) {
  ParameterSlice s = made_up({0, 0.4, 0.6, 0.8, 1.0, 1.5}, {9, 3, 1.5, 1, 1.3, 4});
  supported_span(s, 3, 0, 1.5, 0.02);
  EXPECT_EQ(s.low, 0.8);
  EXPECT_EQ(s.high, 0.8);
  EXPECT_FALSE(s.open_low || s.open_high);
  // A plateau broken by a rise is not open: the span stops at the rise.
  ParameterSlice t = made_up({0, 0.4, 0.6, 0.8, 1.0, 1.5}, {1, 1, 5, 1, 1, 1});
  supported_span(t, 3, 0, 1.5, 0.02);
  EXPECT_EQ(t.low, 0.8);
  EXPECT_FALSE(t.open_low);
  EXPECT_TRUE(t.open_high);
}

TEST(SupportedSpan, AFlatCostFixesNothing) {
  ParameterSlice s = made_up({0.1, 0.5, 2}, {1, 1, 1});
  supported_span(s, 1, 0.1, 2, 0.0);
  EXPECT_TRUE(s.open_low && s.open_high);
}

// The slope as level ground with gravity tilted by 25 degrees about z (the cube's faces on
// grid planes), stiff implicit contact as in tests/test_friction_slope.cpp.
json resting_cube(double mu) {
  const double a = 25 * 3.14159265358979323846 / 180, g = 9.81;
  json j;
  j["object"] = {{"primitive", "box"}, {"half_extents", {0.1, 0.1, 0.1}}, {"position", {0, 0.1, 0}}};
  j["grid"] = {{"cell_size", 0.05}};
  j["material"] = {{"youngs_modulus", 2e5}, {"poisson_ratio", 0.3}, {"density", 400}, {"mass_damping", 0.0}};
  j["gravity"] = {g * std::sin(a), -g * std::cos(a), 0};
  j["ground"] = {{"height", 0.0}, {"stiffness", 1e7}, {"softmin_alpha", 1e4}, {"friction", mu}};
  j["time"] = {{"dt", 1.0 / 300}, {"steps", 120}, {"theta", 0.6}};
  j["solver"] = {{"contact", "implicit"}};
  j["observation"] = {{"every", 12},
                      {"noise", 0.0005},
                      {"seed", 3},
                      {"cameras",
                       {{{"name", "cam"}, {"width", 64}, {"height", 48}, {"eye", {0.4, 0.5, 1.2}},
                         {"target", {0.1, 0.1, 0}}, {"fov_deg", 50}}}}};
  return j;
}

class ParameterSlices : public CliTestFolder {
 protected:
  ParameterSlices() : CliTestFolder("ssc-slices-") {}
};

TEST_F(ParameterSlices, ACubeAtRestOnASlopeFixesOnlyALowerBoundOnItsFriction) {
  const std::string scene = write("cube.json", resting_cube(0.8));
  std::string out, err;
  ASSERT_EQ(run("observe '" + scene + "' --out '" + (dir_ / "obs").string() + "' --device cpu --quiet", &out, &err), 0)
      << err;
  const Problem problem = load_problem(scene, {}, (dir_ / "obs").string(), 0, {"ground.friction"});
  const PhysicalParameters at = PhysicalParameters::from_scene(problem.scene);
  std::vector<ParameterSlice> s =
      slice_parameters(problem, at, {"ground.friction"}, {{0.0, 1.5}}, {false}, 0.05, 4, "cpu");
  ASSERT_EQ(s.size(), 1u);
  ParameterSlice& f = s[0];
  ASSERT_EQ(f.values.size(), 9u);
  EXPECT_EQ(f.values.front(), 0.0);
  EXPECT_EQ(f.values.back(), 1.5);
  for (size_t k = 0; k < f.values.size(); ++k) std::printf("mu %.4f: held-in cost %.6e\n", f.values[k], f.costs[k]);
  ASSERT_EQ(f.values[4], 0.8);
  std::printf("supported: %.4f .. %.4f (open low %d, high %d)\n", f.low, f.high, f.open_low, f.open_high);
  EXPECT_TRUE(f.open_high) << "every mu above tan 25 holds the cube: the cost cannot rise towards 1.5";
  EXPECT_FALSE(f.open_low) << "without friction the cube slides down";
  EXPECT_GT(f.low, std::tan(25 * 3.14159265358979323846 / 180)) << "below tan 25 the cube slides";
}

}  // namespace
}  // namespace ssc
