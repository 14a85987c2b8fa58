// Unit conversion of scenes written in other scales (models/sim/units.h).
#include <gtest/gtest.h>

#include <cmath>

#include "runtime/errors.h"
#include "models/sim/body.h"
#include "models/sim/units.h"

namespace ssc {
namespace {

Scene sphere_scene(const std::string& units) {
  return parse_scene(nlohmann::json::parse(R"({"object": {"primitive": "sphere", "radius": 5, "position": [0, 6, 0]},
      "grid": {"cell_size": 1}, "material": {"density": 2}, "units": )" + units + "}"),
                     "units-test.json");
}

TEST(Units, YoungsModulusConvertsByItsDimensions) {
  UnitScales u;
  u.length = 0.01, u.mass = 3.0, u.time = 0.5;
  // Pa = kg / (m s^2)
  EXPECT_DOUBLE_EQ(to_si("youngs_modulus", 1000, u), 1000 * 3.0 / (0.01 * 0.25));
  EXPECT_DOUBLE_EQ(to_si("density", 2, u), 2 * 3.0 / 1e-6);
  EXPECT_DOUBLE_EQ(to_si("gravity.y", -10, u), -10 * 0.01 / 0.25);
  EXPECT_DOUBLE_EQ(to_si("initial.linear_velocity.x", 4, u), 4 * 0.01 / 0.5);
  EXPECT_DOUBLE_EQ(to_si("initial.angular_velocity.z", 4, u), 8);
  EXPECT_DOUBLE_EQ(to_si("mass_damping", 0.1, u), 0.2);
  EXPECT_DOUBLE_EQ(to_si("stiffness_damping", 0.1, u), 0.05);
  EXPECT_DOUBLE_EQ(to_si("poisson_ratio", 0.4, u), 0.4);
  EXPECT_DOUBLE_EQ(to_si("ground.height", 2, u), 0.02);
  // The paper's factor f_mass f_length / f_time^2 agrees only when f_length = 1.
  u.length = 1;
  EXPECT_DOUBLE_EQ(to_si("youngs_modulus", 1000, u), 1000 * u.mass * u.length / (u.time * u.time));
}

TEST(Units, ScalesFromTheMeasuredObject) {
  const Scene scene = sphere_scene(R"({"object_size": 0.2, "object_mass": 1.5})");
  const SimGrid grid = build_body_grid(scene);
  const UnitScales u = unit_scales(scene, grid);
  // Diameter 10 scene units, measured on the surface's grid-edge crossings.
  EXPECT_NEAR(u.length, 0.2 / 10.0, 0.2 / 10.0 * 0.02);
  EXPECT_NEAR(u.mass, 1.5 / (2 * grid.total_volume), 1e-12);
  EXPECT_DOUBLE_EQ(u.time, 1.0);
}

TEST(Units, NoSectionMeansSi) {
  Scene scene = sphere_scene("{}");
  scene.extra.erase("units");
  const SimGrid grid = build_body_grid(scene);
  EXPECT_TRUE(unit_scales(scene, grid).identity());
}

TEST(Units, BadSectionsAreNamed) {
  const Scene scene = sphere_scene(R"({"length": -1})");
  const SimGrid grid = build_body_grid(scene);
  try {
    unit_scales(scene, grid);
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("units.length"), std::string::npos) << e.what();
  }
  const Scene mixed = sphere_scene(R"({"length": 1, "object_size": 0.2})");
  EXPECT_THROW(unit_scales(mixed, build_body_grid(mixed)), InputError);
  const Scene unknown = sphere_scene(R"({"lenght": 1})");
  EXPECT_THROW(unit_scales(unknown, build_body_grid(unknown)), InputError);
}

}  // namespace
}  // namespace ssc
