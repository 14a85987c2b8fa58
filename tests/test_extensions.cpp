// The extension table (models/sim/extensions.h) and plausible ranges:
//  - every row is complete, its parameters belong to it (owner) and to no other row;
//  - fitting a parameter puts its extension's op in the model; a switch takes it out;
//  - plausible ranges come from the parameter table, the body's size, or the scene, which can
//    widen them; a bad "plausible" section is an input error naming the key;
//  - bounds keep a fit inside a plausible range (ReconstructionOptions::bounds).
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <set>

#include "models/optim/parameter_space.h"
#include "models/sim/extensions.h"
#include "models/sim/parameters.h"
#include "models/sim/timestep_graph.h"
#include "runtime/errors.h"

namespace ssc {
namespace {

using json = nlohmann::json;

json two_plane_scene() {
  json j;
  j["object"] = {{"primitive", "sphere"}, {"radius", 0.1}, {"position", {0, 0.2, 0}}};
  j["grid"] = {{"cell_size", 0.05}};
  j["ground"] = {{"planes", {{{"height", 0.0}}, {{"angles_deg", {90, 0}}, {"height", -1.0}}}}};
  return j;
}

TEST(ExtensionTable, EveryRowIsCompleteAndOwnsItsParameters) {
  const Scene scene = parse_scene(two_plane_scene(), "table.json");
  const PhysicalParameters p = PhysicalParameters::from_scene(scene);
  std::set<std::string> names;
  for (const ExtensionRow& row : extension_table()) {
    EXPECT_TRUE(names.insert(row.name).second) << row.name << " twice";
    EXPECT_FALSE(row.what.empty()) << row.name;
    // A measurement corrects the recording: no op; one parameter with a range around its off value.
    EXPECT_EQ(row.ops.empty(), row.fit == ExtensionRow::Fit::Measurement) << row.name;
    ASSERT_TRUE(row.parameters && row.owns && row.model_on && row.switch_off) << row.name;
    if (row.fit == ExtensionRow::Fit::Measurement) {
      ASSERT_EQ(row.parameters(scene).size(), 1u) << row.name;
      const std::string name = row.parameters(scene)[0];
      EXPECT_TRUE(is_measurement_parameter(name)) << name;
      EXPECT_FALSE(row.unit.empty()) << row.name;
      ASSERT_TRUE(row.tell) << row.name;
      const auto [lo, hi] = plausible_range(scene, name, 0.2);
      EXPECT_LT(lo, row.off_value) << name;
      EXPECT_GT(hi, row.off_value) << name;
    }
    if (row.fit == ExtensionRow::Fit::OffValue) {
      ASSERT_TRUE(row.typical && row.start_range) << row.name;
      EXPECT_GT(row.typical(0.2), 0) << row.name;
      const auto [lo, hi] = row.start_range(0.2);
      EXPECT_LT(lo, hi) << row.name;
    }
    EXPECT_EQ(find_extension(row.name), &row);
    for (const std::string& name : row.parameters(scene)) {
      EXPECT_EQ(owner(name), row.name) << name;
      if (row.fit == ExtensionRow::Fit::OffValue)
        for (const std::string& component : expand_parameter_names({name}, p)) {
          EXPECT_EQ(owner(component), row.name) << component;
          const auto [lo, hi] = plausible_range(scene, component, 0.2);
          EXPECT_TRUE(std::isfinite(lo) && std::isfinite(hi)) << component << " has no plausible range";
          EXPECT_GE(row.off_value, lo) << component;
          EXPECT_LT(row.off_value, hi) << component;
        }
    }
  }
  EXPECT_EQ(find_extension("frition"), nullptr);
  EXPECT_EQ(owner("youngs_modulus"), "youngs_modulus");
  EXPECT_EQ(owner("mass_damping"), "mass_damping");
  EXPECT_EQ(owner("ground.planes[1].friction"), "friction");
  EXPECT_EQ(owner("ground.planes[1].height"), "second_plane");
  EXPECT_EQ(owner("ground.height"), "ground.height");  // the first plane is the scene's, not an extension
  EXPECT_EQ(owner("material.stiffness_gradient.z"), "heterogeneous_stiffness");
  EXPECT_EQ(owner("camera.focal_scale"), "focal_length");
  EXPECT_FALSE(is_measurement_parameter("youngs_modulus"));
  EXPECT_EQ(find_extension("focal_length")->tell(1 / 1.05), "the cameras' focal lengths (fx, fy in cameras.json) look "
                                                             "5.0 % too large");
}

TEST(ExtensionTable, FittingAParameterPutsItsOpInTheModelAndASwitchTakesItOut) {
  Scene scene = parse_scene(two_plane_scene(), "table.json");
  EXPECT_FALSE(timestep_model(scene).friction);
  EXPECT_FALSE(timestep_model(scene).air_drag);
  model_fitted_extensions(scene, {"ground.planes[1].friction", "air_drag"});
  EXPECT_TRUE(timestep_model(scene).friction);
  EXPECT_TRUE(timestep_model(scene).air_drag);
  scene.extensions_off = {"friction", "air_drag", "second_plane"};
  switch_off_extensions(scene);
  EXPECT_FALSE(timestep_model(scene).friction);
  EXPECT_FALSE(timestep_model(scene).air_drag);
  EXPECT_EQ(scene.planes.size(), 1u);
}

TEST(PlausibleRanges, ComeFromTheTableTheBodyAndTheScene) {
  json j = two_plane_scene();
  std::string source;
  const Scene defaults = parse_scene(j, "plausible.json");
  EXPECT_EQ(plausible_range(defaults, "air_drag", 0.2, &source), std::make_pair(0.0, 1.5));
  EXPECT_NE(source.find("air"), std::string::npos) << source;
  EXPECT_EQ(plausible_range(defaults, "ground.planes[1].friction", 0.2), std::make_pair(0.0, 1.5));
  EXPECT_EQ(plausible_range(defaults, "youngs_modulus", 0.2).first, 10.0);
  // A stiffness gradient: the modulus changes at most 1000 times across the body.
  EXPECT_NEAR(plausible_range(defaults, "material.stiffness_gradient.x", 0.5).second * 0.5, std::log(1000.0), 1e-12);
  EXPECT_FALSE(std::isfinite(plausible_range(defaults, "ground.height", 0.2).second));
  EXPECT_EQ(implausibility(defaults, "air_drag", 1.2, 0.2), "");
  const std::string why = implausibility(defaults, "air_drag", 20, 0.2);
  EXPECT_NE(why.find("air_drag = 20 kg/m^3 is outside its plausible range [0, 1.5]"), std::string::npos) << why;
  EXPECT_NE(why.find("\"plausible\""), std::string::npos) << why;
  // A body in water: the scene widens the range.
  j["plausible"] = {{"air_drag", {0, 1100}}};
  EXPECT_EQ(plausible_range(parse_scene(j, "plausible.json"), "air_drag", 0.2, &source), std::make_pair(0.0, 1100.0));
  EXPECT_NE(source.find("plausible.air_drag"), std::string::npos) << source;
  EXPECT_EQ(implausibility(parse_scene(j, "plausible.json"), "air_drag", 20, 0.2), "");
  for (const json& bad : {json{{"air_drag", {1100, 0}}}, json{{"air_drag", 3}}, json{{"air_dreg", {0, 1}}},
                          json::array({0, 1})}) {
    j["plausible"] = bad;
    try {
      parse_scene(j, "plausible.json");
      ADD_FAILURE() << bad.dump() << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("plausible"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("plausible.json"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace ssc
