// The diagnosis's models that are not extensions: the discretization controls' specs
// (models/diagnosis/candidates.h) and the two-material spec the interface
// search fits.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "models/diagnosis/candidates.h"
#include "models/sim/scene.h"

namespace ssc {
namespace {

bool has(const std::vector<std::string>& list, const std::string& item) {
  return std::find(list.begin(), list.end(), item) != list.end();
}

TEST(DiagnosisModels, TheFinerGridHalvesTheCellAndKeepsTheBandInMetres) {
  Scene scene;
  scene.cell_size = 0.025;
  std::string skipped;
  ModelSpec spec = finer_grid_spec(scene, &skipped);
  EXPECT_EQ(skipped, "");
  EXPECT_EQ(spec.name, "finer_grid");
  EXPECT_TRUE(has(spec.overrides, "grid.cell_size=0.0125")) << spec.overrides[0];
  EXPECT_TRUE(spec.extra.empty());  // no parameter of its own: it stands for no missing effect

  scene.grid.band_width = 3;
  spec = finer_grid_spec(scene, &skipped);
  EXPECT_TRUE(has(spec.overrides, "grid.band_width=6"));

  scene.cell_size = -20;  // grid.resolution 20
  spec = finer_grid_spec(scene, &skipped);
  EXPECT_TRUE(has(spec.overrides, "grid.resolution=40"));
}

TEST(DiagnosisModels, TheFinerStepHalvesTheTimeStepOverTheSameDuration) {
  Scene scene;
  scene.time.dt = 0.01;
  scene.time.steps = 80;
  std::string skipped;
  const ModelSpec spec = discretization_spec("finer_step", scene, &skipped);
  EXPECT_EQ(skipped, "");
  EXPECT_EQ(spec.name, "finer_step");
  EXPECT_TRUE(has(spec.overrides, "time.dt=0.005"));
  EXPECT_TRUE(has(spec.overrides, "time.steps=160"));
  EXPECT_TRUE(spec.extra.empty());
  EXPECT_EQ(discretization_controls(), (std::vector<std::string>{"finer_grid", "finer_step"}));
  // theta 0.6 is a numerical damping of (theta - 1/2) dt: halved with the step, a quarter in
  // all. The step does not iterate, so its iterations are left alone.
  EXPECT_TRUE(has(spec.overrides, "time.theta=0.55"));
  EXPECT_EQ(spec.overrides.size(), 3u);

  scene.time.theta = 0.5;
  scene.solver.implicit_contact = true;  // iterates only against a plane
  scene.solver.nonlinear_iterations = 4;
  EXPECT_EQ(finer_step_spec(scene).overrides.size(), 2u);
  scene.planes.emplace_back();
  const ModelSpec iterating = finer_step_spec(scene);
  EXPECT_TRUE(has(iterating.overrides, "solver.nonlinear_iterations=8"));
  for (const std::string& o : iterating.overrides) EXPECT_EQ(o.find("time.theta"), std::string::npos) << o;
}

TEST(DiagnosisModels, AGridThatCannotBeRefinedIsSkippedWithTheReason) {
  Scene scene;
  scene.cell_size = -200;  // twice is above the scene reader's 300 cells
  std::string skipped;
  EXPECT_EQ(finer_grid_spec(scene, &skipped).name, "");
  EXPECT_NE(skipped.find("resolution"), std::string::npos) << skipped;
  scene.cell_size = 0;  // an sdf_file body: the file's grid
  skipped.clear();
  EXPECT_EQ(finer_grid_spec(scene, &skipped).name, "");
  EXPECT_NE(skipped.find("sdf_file"), std::string::npos) << skipped;
}

TEST(DiagnosisModels, TheTwoMaterialSpecPutsTheInterfaceInTheSceneAndFitsTheSecondModulus) {
  const ModelSpec spec = two_materials_spec(Eigen::Vector3d(0.6, 0.8, 0), 0.05, 2e5, "note");
  ASSERT_EQ(spec.overrides.size(), 1u);
  EXPECT_EQ(spec.overrides[0].rfind("material.regions=", 0), 0u);
  EXPECT_EQ(spec.extra, std::vector<std::string>{"material.regions[0].youngs_modulus"});
  const auto range = spec.ranges.at("material.regions[0].youngs_modulus");
  EXPECT_NEAR(range.first, 2e5 / 3, 1e-6);
  EXPECT_NEAR(range.second, 6e5, 1e-6);
  // The override is a scene key the reader takes.
  const nlohmann::json regions = nlohmann::json::parse(spec.overrides[0].substr(std::string("material.regions=").size()));
  EXPECT_DOUBLE_EQ(regions[0]["normal"][1].get<double>(), 0.8);
  EXPECT_DOUBLE_EQ(regions[0]["offset"].get<double>(), 0.05);
  EXPECT_DOUBLE_EQ(regions[0]["youngs_modulus"].get<double>(), 2e5);
}

}  // namespace
}  // namespace ssc
