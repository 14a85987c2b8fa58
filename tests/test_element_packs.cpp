// The CPU's element apply four cells at a time, and eight where the CPU has AVX-512
// (runtime/element_packs.h), against the scalar apply of one cell (ops::stiffness_apply_cell):
// the same numbers, bit for bit, on the paper's dragon's cut cells, with corners of zero weight
// in every lane of a pack and in one; and eight cells at a time in float, to float's precision.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <cmath>
#include <random>
#include <vector>

#include "models/sim/body.h"
#include "models/sim/scene.h"
#include "ops/corotation.h"
#include "runtime/element_packs.h"

namespace ssc {
namespace {

TEST(ElementPacks, PacksOfCellsGiveTheScalarApplysBits) {
  nlohmann::json j;
  j["object"] = {{"sdf_file", std::string(SSC_TEST_DATA_DIR) + "/dragon_modified_rot.sdf"}};
  j["grid"] = {{"zero_cutoff", 0.1}};
  const SimGrid grid = build_body_grid(parse_scene(j, "element_packs_test.json"));
  const int cells = grid.cell_count;
  ASSERT_NE(cells % 8, 0) << "the test wants a tail of cells the packs leave to the scalar code";
  ASSERT_NE(cells % 4, 0);
  std::vector<double> weights = grid.cell_volume_weights;
  for (int e = 0; e < 8; ++e) weights[8 * size_t(e)] = 0.0;  // corner 0 of the whole first pack
  weights[8 * 5 + 2] = 0.0;                                   // corner 2 of one lane of the second
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> rotation(9 * size_t(cells)), lambda(cells, 0.0), mu(cells, 0.0), p(3 * size_t(grid.node_count));
  for (double& v : rotation) v = u(rng);
  for (int e = 0; e < cells; ++e) {
    lambda[size_t(e)] = 1e4 * (2 + u(rng));
    mu[size_t(e)] = 1e4 * (2 + u(rng));
  }
  for (double& v : p) v = 1e-3 * u(rng);
  std::vector<double> scalar(24 * size_t(cells));
  const ops::PartContext<double> cx{grid.h, cells, grid.node_count, 0, 0, 0};
  for (int e = 0; e < cells; ++e)
    ops::stiffness_apply_cell(e, cx, rotation.data(), weights.data(), lambda.data(), mu.data(), p.data(),
                              grid.cell_nodes.data(), scalar.data());
  std::vector<int> packs = {4};
  if (cell_pack_width() == 8) packs.push_back(8);
  else std::printf("this CPU has no AVX-512: the packs of eight cells are not tested\n");
  for (int pack : packs) {
    std::vector<double> packed(scalar.size());
    stiffness_apply_cells(cells, grid.h, rotation.data(), weights.data(), lambda.data(), mu.data(), p.data(),
                          grid.cell_nodes.data(), packed.data(), pack);
    int differ = 0;
    for (size_t i = 0; i < packed.size(); ++i) differ += packed[i] != scalar[i];
    EXPECT_EQ(differ, 0) << "of " << packed.size() << " corner values, " << pack << " cells a pack";
  }
}

// Eight cells at a time in float (the solve's float stage, runtime/solvers.cpp): the double
// apply's numbers to float's precision, on the same cells, tail included.
TEST(ElementPacks, EightCellsInFloatGiveTheDoubleApplyToFloatPrecision) {
  nlohmann::json j;
  j["object"] = {{"sdf_file", std::string(SSC_TEST_DATA_DIR) + "/dragon_modified_rot.sdf"}};
  j["grid"] = {{"zero_cutoff", 0.1}};
  const SimGrid grid = build_body_grid(parse_scene(j, "element_packs_test.json"));
  const int cells = grid.cell_count;
  ASSERT_NE(cells % 8, 0) << "the test wants a tail of cells the packs leave to the scalar code";
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> rotation(9 * size_t(cells)), lambda(cells), mu(cells), p(3 * size_t(grid.node_count));
  for (int e = 0; e < cells; ++e) {  // rotations, as the corotation gives them
    const double a = u(rng), c = std::cos(a), s = std::sin(a);
    const double R[9] = {c, -s, 0, s, c, 0, 0, 0, 1};
    std::copy(R, R + 9, rotation.begin() + 9 * e);
    lambda[size_t(e)] = 1e4 * (2 + u(rng));
    mu[size_t(e)] = 1e4 * (2 + u(rng));
  }
  for (double& v : p) v = 1e-3 * u(rng);
  std::vector<double> exact(24 * size_t(cells));
  stiffness_apply_cells(cells, grid.h, rotation.data(), grid.cell_volume_weights.data(), lambda.data(), mu.data(),
                        p.data(), grid.cell_nodes.data(), exact.data());
  auto single = [](const std::vector<double>& v) { return std::vector<float>(v.begin(), v.end()); };
  const std::vector<float> rotation_f = single(rotation), weights_f = single(grid.cell_volume_weights),
                           lambda_f = single(lambda), mu_f = single(mu), p_f = single(p);
  std::vector<float> packed(exact.size());
  stiffness_apply_cells(cells, float(grid.h), rotation_f.data(), weights_f.data(), lambda_f.data(), mu_f.data(),
                        p_f.data(), grid.cell_nodes.data(), packed.data());
  double scale = 0, worst = 0;
  for (double v : exact) scale = std::max(scale, std::abs(v));
  for (size_t i = 0; i < exact.size(); ++i) worst = std::max(worst, std::abs(double(packed[i]) - exact[i]));
  std::printf("largest difference %.3g of the largest value %.3g\n", worst, scale);
  EXPECT_GT(scale, 0.0);
  EXPECT_LT(worst, 1e-5 * scale);
}

}  // namespace
}  // namespace ssc
