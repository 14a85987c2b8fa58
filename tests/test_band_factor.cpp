// The band Laplacian's factor (runtime/band_factor.h) against the matrix it stands for, built
// here from the grid's band arrays as the extension's PCG applies it (runtime/solvers.cpp).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <random>
#include <vector>

#include "models/sim/body.h"
#include "models/sim/scene.h"
#include "runtime/band_factor.h"
#include "runtime/band_operator.h"

namespace ssc {
namespace {

// L x for the three interleaved components: the degree times x minus the band neighbours' x.
std::vector<double> band_laplacian_apply(const StaticArrays& g, const std::vector<double>& x) {
  std::vector<double> y(x.size());
  for (int i = 0; i < g.band_count; ++i)
    for (int k = 0; k < 3; ++k) {
      double s = g.band_degree[size_t(i)] * x[3 * size_t(i) + size_t(k)];
      for (int d = 0; d < 6; ++d)
        if (const int nb = g.band_neighbors[6 * size_t(i) + size_t(d)]; nb >= 0) s -= x[3 * size_t(nb) + size_t(k)];
      y[3 * size_t(i) + size_t(k)] = s;
    }
  return y;
}

double norm(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return std::sqrt(s);
}

TEST(BandFactor, SolvesTheDragonsBandLaplacian) {
  nlohmann::json j;
  j["object"] = {{"sdf_file", std::string(SSC_TEST_DATA_DIR) + "/dragon_modified_rot.sdf"}};
  j["grid"] = {{"zero_cutoff", 0.1}, {"band_width", 0}};
  const SimGrid grid = build_body_grid(parse_scene(j, "band_factor_test.json"));
  ASSERT_EQ(grid.band_count, 11587);  // the paper's dragon: every band node of its SDF grid
  BandFactorCache cache;
  const auto start = std::chrono::steady_clock::now();
  const BandLaplacianFactor* factor = cache.get(grid);
  std::printf("factorised %d band nodes in %.1f ms\n", grid.band_count,
              std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  ASSERT_NE(factor, nullptr);
  EXPECT_EQ(cache.get(grid), factor) << "built once";
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> b(3 * size_t(grid.band_count)), x(b.size());
  for (double& v : b) v = u(rng);
  factor->solve(b.data(), x.data());
  std::vector<double> r = band_laplacian_apply(grid, x);
  for (size_t i = 0; i < r.size(); ++i) r[i] -= b[i];
  EXPECT_LT(norm(r) / norm(b), 1e-12) << "the extension's PCG stops at 1e-8";
  std::vector<float> bf(b.begin(), b.end()), xf(b.size());
  factor->solve(bf.data(), xf.data());
  double worst = 0;
  for (size_t i = 0; i < x.size(); ++i) worst = std::max(worst, std::abs(double(xf[i]) - x[i]) / (std::abs(x[i]) + 1));
  EXPECT_LT(worst, 1e-6) << "float: the double solve, rounded";
}

// The extension's dense operator G = L^-1 B (runtime/band_operator.h): band_u = G u must
// solve L band_u = B u, B summing u over each band node's active neighbours (the
// extension's right-hand side, extension_setup), for u at every active node.
TEST(BandFactor, DenseExtensionOperatorSolvesTheBandForAnyDisplacement) {
  nlohmann::json j;
  j["object"] = {{"sdf_file", std::string(SSC_TEST_DATA_DIR) + "/dragon_modified_rot.sdf"}};
  j["grid"] = {{"zero_cutoff", 0.1}, {"band_width", 0}};
  const SimGrid grid = build_body_grid(parse_scene(j, "band_operator_test.json"));
  const auto start = std::chrono::steady_clock::now();
  const std::shared_ptr<const BandExtensionOperator> op = band_extension_operator(grid);
  ASSERT_NE(op, nullptr);
  std::printf("G: %d band nodes x %zu sources in %.1f ms\n", op->band_count, op->sources.size(),
              std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  EXPECT_EQ(band_extension_operator(grid), op) << "built once per grid";
  std::vector<bool> touches(size_t(grid.node_count), false);
  for (int v : grid.band_neighbors)
    if (v <= -2) touches[size_t(-v - 2)] = true;
  std::vector<int> expected;
  for (int n = 0; n < grid.node_count; ++n)
    if (touches[size_t(n)]) expected.push_back(n);
  EXPECT_EQ(op->sources, expected) << "the sources are the active nodes next to the band, ascending";
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> draw(-1, 1);
  std::vector<double> u(3 * size_t(grid.node_count));
  for (double& v : u) v = draw(rng);
  const size_t n = size_t(op->band_count);
  std::vector<double> band(3 * n, 0.0), rhs(3 * n, 0.0);
  for (size_t s = 0; s < op->sources.size(); ++s)
    for (size_t i = 0; i < n; ++i)
      for (int k = 0; k < 3; ++k) band[3 * i + size_t(k)] += op->columns[s * n + i] * u[3 * size_t(op->sources[s]) + size_t(k)];
  for (size_t i = 0; i < n; ++i)
    for (int d = 0; d < 6; ++d)
      if (const int v = grid.band_neighbors[6 * i + size_t(d)]; v <= -2)
        for (int k = 0; k < 3; ++k) rhs[3 * i + size_t(k)] += u[3 * size_t(-v - 2) + size_t(k)];
  std::vector<double> r = band_laplacian_apply(grid, band);
  for (size_t i = 0; i < r.size(); ++i) r[i] -= rhs[i];
  EXPECT_LT(norm(r) / norm(rhs), 1e-12) << "the extension's PCG stops at 1e-8";
}

TEST(BandFactor, NoBandNoFactor) {
  StaticArrays g;
  BandFactorCache cache;
  EXPECT_EQ(cache.get(g), nullptr);
  EXPECT_EQ(band_extension_operator(g), nullptr);
}

}  // namespace
}  // namespace ssc
