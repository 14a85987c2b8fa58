// The parameter table: one row per parameter, each row's accessors agree with each other.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "runtime/errors.h"
#include "models/sim/parameter_table.h"
#include "models/sim/parameters.h"

namespace ssc {
namespace {

PhysicalParameters two_planes() {
  PhysicalParameters p;
  p.youngs_modulus = 5000, p.poisson_ratio = 0.3, p.density = 100, p.mass_damping = 0.1, p.stiffness_damping = 0.01;
  p.gravity = {0, -9.81, 0};
  p.planes.resize(2);
  p.planes[1].normal = normal_from_angles(20, 40);
  p.region_youngs = {2e4};
  return p;
}

TEST(ParameterTable, EveryRowIsUniqueAndReadsBackWhatItWrites) {
  const PhysicalParameters p = two_planes();
  const std::vector<ParameterRow> table = parameter_table(p);
  // per plane: height, two angles, friction, friction velocity; per material region its
  // modulus; the stiffness gradient; air drag
  EXPECT_EQ(table.size(), 5u + 9u + 2u * 5u + 1u + 3u + 1u);
  std::set<std::string> names, keys;
  for (const ParameterRow& r : table) {
    EXPECT_TRUE(names.insert(r.name).second) << r.name;
    EXPECT_FALSE(r.unit.empty()) << r.name;
    EXPECT_FALSE(r.scene_key.empty()) << r.name;
    EXPECT_FALSE(r.graph_input.empty()) << r.name;
    PhysicalParameters q = p;
    const double value = r.name.find("polar") != std::string::npos ? 33.0 : r.get(p) * 0.5 + 0.125;
    ASSERT_TRUE(r.value_error(value).empty()) << r.name << ": " << r.value_error(value);
    r.set(q, value);
    EXPECT_NEAR(r.get(q), value, 1e-12) << r.name;
    EXPECT_NEAR(get_parameter(q, r.name), value, 1e-12) << r.name;
    EXPECT_EQ(parameter_row(r.name).unit, r.unit);
  }
  // The vector rows share their scene key's base, each component its own index.
  EXPECT_EQ(find_parameter_row(table, "gravity.y")->scene_key, "gravity[1]");
  EXPECT_EQ(find_parameter_row(table, "ground.planes[1].polar_deg")->scene_key, "ground.planes[1].angles_deg");
  // Rows that feed a graph input entry as they are: the simulation writes them, the gradient
  // reads them there.
  const ParameterRow* mu1 = find_parameter_row(table, "ground.planes[1].friction");
  EXPECT_EQ(mu1->graph_input, "friction");
  EXPECT_EQ(mu1->graph_component, 2);
  ParameterGradient g;
  g.input["friction"] = {1, 2, 3, 4};
  EXPECT_EQ(mu1->gradient(g, p), 3);
  EXPECT_EQ(find_parameter_row(table, "ground.friction_velocity")->gradient(g, p), 2);
  const ParameterRow* region = find_parameter_row(table, "material.regions[0].youngs_modulus");
  ASSERT_NE(region, nullptr);
  EXPECT_EQ(region->graph_input, "region_youngs");
  EXPECT_EQ(parameter_row("material.regions[3].youngs_modulus").unit, "Pa");
  EXPECT_EQ(find_parameter_row(table, "material.stiffness_gradient.z")->scene_key, "material.stiffness_gradient[2]");
  EXPECT_EQ(find_parameter_row(table, "air_drag")->graph_input, "air_drag");
}

TEST(ParameterTable, RangesAndUnitsAreTheModelsOwn) {
  EXPECT_FALSE(parameter_row("youngs_modulus").value_error(0).empty());
  EXPECT_TRUE(parameter_row("mass_damping").value_error(0).empty());
  EXPECT_FALSE(parameter_row("mass_damping").value_error(-1e-9).empty());
  EXPECT_FALSE(parameter_row("poisson_ratio").value_error(0.5).empty());
  EXPECT_TRUE(parameter_row("poisson_ratio").value_error(0.0).empty());
  EXPECT_FALSE(parameter_row("poisson_ratio").value_error(-0.01).empty());
  EXPECT_TRUE(parameter_row("ground.polar_deg").value_error(180).empty());
  EXPECT_FALSE(parameter_row("ground.planes[3].polar_deg").value_error(-1).empty());
  EXPECT_FALSE(parameter_row("gravity.y").value_error(std::nan("")).empty());
  const ParameterRow e = parameter_row("youngs_modulus");
  EXPECT_EQ(e.mass * 100 + e.length * 10 + e.time, 100 - 10 - 2);  // kg m^-1 s^-2
  EXPECT_EQ(parameter_row("ground.planes[2].height").unit, "m");
  EXPECT_THROW(parameter_row("youngs_modulus.x"), InputError);
  EXPECT_TRUE(parameter_row("ground.friction").value_error(0).empty());
  EXPECT_FALSE(parameter_row("ground.friction").value_error(-0.1).empty());
  EXPECT_FALSE(parameter_row("ground.planes[1].friction_velocity").value_error(0).empty());
}

}  // namespace
}  // namespace ssc
