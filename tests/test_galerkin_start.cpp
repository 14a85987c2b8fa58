// The start of a solve at the best point of an affine space (ops/galerkin_start.h through
// runtime/galerkin_start.h), on the 1-D Laplacian plus identity: the residual of the start is
// orthogonal to every direction, its A-norm error is the smallest over the space (no
// combination of the directions does better), and directions that add nothing (zero, a
// multiple of another, sizes ten orders apart) change nothing.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <vector>

#include "runtime/galerkin_start.h"

namespace ssc {
namespace {

constexpr long kN = 60;

void apply(const double* p, double* q) {
  for (long i = 0; i < kN; ++i) q[i] = 3 * p[i] - (i > 0 ? p[i - 1] : 0) - (i + 1 < kN ? p[i + 1] : 0);
}

template <size_t K>
auto products(const std::array<std::vector<double>, K>& d) {
  return [&d](int j, double* q) { apply(d[j].data(), q); };
}

double a_norm_error(const std::vector<double>& x, const std::vector<double>& solution) {
  std::vector<double> e(kN), ae(kN);
  for (long i = 0; i < kN; ++i) e[i] = x[i] - solution[i];
  apply(e.data(), ae.data());
  double s = 0;
  for (long i = 0; i < kN; ++i) s += e[i] * ae[i];
  return std::sqrt(s);
}

struct Problem {
  std::vector<double> b = std::vector<double>(kN), solution, x0 = std::vector<double>(kN);
  std::array<std::vector<double>, 3> d;
  Problem() {
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(kN, kN);
    for (long i = 0; i < kN; ++i) {
      a(i, i) = 3;
      if (i > 0) a(i, i - 1) = a(i - 1, i) = -1;
      b[i] = std::sin(0.2 * i) + 0.05 * i;
      x0[i] = 0.3 * std::cos(0.5 * i);
    }
    const Eigen::VectorXd s = a.ldlt().solve(Eigen::Map<Eigen::VectorXd>(b.data(), kN));
    solution.assign(s.data(), s.data() + kN);
    for (int j = 0; j < 3; ++j) {
      std::vector<double> v(kN);
      for (long i = 0; i < kN; ++i) v[i] = std::sin(0.1 * (j + 1) * i + j);
      d[j] = v;
    }
  }
};

TEST(GalerkinStart, ItsResidualIsOrthogonalToTheDirectionsAndItsErrorTheSmallest) {
  const Problem p;
  std::vector<double> x = p.x0;
  galerkin_start<3, double>(kN, apply, products(p.d), p.b.data(), p.d, x.data());
  std::vector<double> ax(kN);
  apply(x.data(), ax.data());
  for (const auto& dj : p.d) {
    double dot = 0, scale = 0;
    for (long i = 0; i < kN; ++i) {
      dot += dj[i] * (p.b[i] - ax[i]);
      scale += std::abs(dj[i] * p.b[i]);
    }
    EXPECT_LT(std::abs(dot), 1e-12 * scale);
  }
  const double best = a_norm_error(x, p.solution);
  EXPECT_LT(best, a_norm_error(p.x0, p.solution));
  for (int j = 0; j < 3; ++j)
    for (double step : {-0.01, 0.01}) {  // any nearby point of the space is worse
      std::vector<double> y = x;
      for (long i = 0; i < kN; ++i) y[i] += step * p.d[j][i];
      EXPECT_GT(a_norm_error(y, p.solution), best);
    }
}

TEST(GalerkinStart, DirectionsThatAddNothingChangeNothing) {
  const Problem p;
  std::vector<double> x = p.x0;
  galerkin_start<3, double>(kN, apply, products(p.d), p.b.data(), p.d, x.data());
  std::array<std::vector<double>, 6> more{p.d[0], p.d[1], p.d[2], std::vector<double>(kN, 0.0),
                                          std::vector<double>(kN), std::vector<double>(kN)};
  for (long i = 0; i < kN; ++i) {
    more[4][i] = 2 * p.d[1][i];
    more[5][i] = 1e-10 * p.d[2][i];
  }
  std::vector<double> y = p.x0;
  galerkin_start<6, double>(kN, apply, products(more), p.b.data(), more, y.data());
  for (long i = 0; i < kN; ++i) EXPECT_NEAR(y[i], x[i], 1e-10 * (1 + std::abs(x[i])));
  std::vector<double> z = p.x0;
  const std::array<std::vector<double>, 1> zero{std::vector<double>(kN, 0.0)};
  galerkin_start<1, double>(kN, apply, products(zero), p.b.data(), zero, z.data());
  EXPECT_EQ(z, p.x0);
}

}  // namespace
}  // namespace ssc
