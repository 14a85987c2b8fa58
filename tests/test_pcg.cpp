// The CG solver (runtime/pcg.h) on a small SPD system: it solves an ordinary right-hand side,
// and a negligible one (an adjoint cotangent decayed to 1e-160 through the contact's
// exp(-alpha d)) gives x = 0 instead of breaking down with 0/0 once p.Ap underflows; a
// reference norm bounds the residual of right-hand sides smaller than it. With reliable updates,
// iterations on a float operator reach the double operator's tolerance far below float's.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "runtime/pcg.h"

namespace ssc {
namespace {

// The 1-D Laplacian plus identity, n = 40.
struct Tridiagonal {
  long n = 40;
  void operator()(const double* p, double* q) const {
    for (long i = 0; i < n; ++i) q[i] = 3 * p[i] - (i > 0 ? p[i - 1] : 0) - (i + 1 < n ? p[i + 1] : 0);
  }
};

TEST(Pcg, SolvesAndReturnsZeroForANegligibleRightHandSide) {
  const Tridiagonal A;
  std::vector<double> inv_diag(A.n, 1.0 / 3), b(A.n), x(A.n, 0.0), Ax(A.n);
  for (long i = 0; i < A.n; ++i) b[i] = std::sin(0.3 * i) + 0.1;
  PcgResult r = jacobi_pcg<double>(A.n, A, inv_diag.data(), b.data(), x.data(), 1e-12, 200);
  ASSERT_TRUE(r.converged);
  A(x.data(), Ax.data());
  for (long i = 0; i < A.n; ++i) EXPECT_NEAR(Ax[i], b[i], 1e-10);
  for (double& v : b) v *= 1e-160;  // what a decayed cotangent looks like
  std::fill(x.begin(), x.end(), 0.0);
  r = jacobi_pcg<double>(A.n, A, inv_diag.data(), b.data(), x.data(), 1e-10, 200);
  EXPECT_TRUE(r.converged);
  for (double v : x) EXPECT_EQ(v, 0.0);
  for (double& v : b) v *= 1e150;  // 1e-10: small, but solved
  r = jacobi_pcg<double>(A.n, A, inv_diag.data(), b.data(), x.data(), 1e-10, 200);
  EXPECT_TRUE(r.converged);
  EXPECT_GT(std::abs(x[5]), 0.0);
}

// A reference norm makes the residual absolute below it: a right-hand side far smaller than
// the reference stops at once (x = 0, the residual |b| already within tolerance times the
// reference); one larger than the reference is solved as without it, bit for bit.
TEST(Pcg, AReferenceNormBoundsTheResidualOfSmallRightHandSides) {
  const Tridiagonal A;
  std::vector<double> inv_diag(A.n, 1.0 / 3), b(A.n), x(A.n, 0.0), y(A.n, 0.0);
  for (long i = 0; i < A.n; ++i) b[i] = std::sin(0.3 * i) + 0.1;
  const PcgResult plain = jacobi_pcg<double>(A.n, A, inv_diag.data(), b.data(), x.data(), 1e-10, 200);
  const PcgResult below = jacobi_pcg<double>(A.n, A, inv_diag.data(), b.data(), y.data(), 1e-10, 200, 0.5 * plain.rhs_norm);
  EXPECT_EQ(below.iterations, plain.iterations);
  EXPECT_GT(plain.iterations, 5);
  for (long i = 0; i < A.n; ++i) EXPECT_EQ(x[i], y[i]);
  const double reference = plain.rhs_norm;
  for (double& v : b) v *= 1e-12;
  std::fill(x.begin(), x.end(), 0.0);
  const PcgResult tiny = jacobi_pcg<double>(A.n, A, inv_diag.data(), b.data(), x.data(), 1e-10, 200, reference);
  EXPECT_TRUE(tiny.converged);
  EXPECT_EQ(tiny.iterations, 0);
  EXPECT_NEAR(tiny.relative_residual, 1e-12, 1e-14);
  for (double v : x) EXPECT_EQ(v, 0.0);
  for (double& v : b) v *= 1e6;  // 1e-6 of the reference: solved, to 1e-10 of the reference
  const PcgResult small = jacobi_pcg<double>(A.n, A, inv_diag.data(), b.data(), x.data(), 1e-10, 200, reference);
  EXPECT_TRUE(small.converged);
  EXPECT_GT(small.iterations, 0);
  EXPECT_LT(small.iterations, plain.iterations);
  std::vector<double> Ax(A.n);
  A(x.data(), Ax.data());
  double r2 = 0;
  for (long i = 0; i < A.n; ++i) r2 += (Ax[i] - b[i]) * (Ax[i] - b[i]);
  EXPECT_LE(std::sqrt(r2), 1e-10 * reference);
}

// The same operator with its arithmetic in float, as the CPU's element apply in the solve's
// float stage (runtime/solvers.cpp).
struct TridiagonalInFloat {
  long n = 40;
  void operator()(const double* p, double* q) const {
    for (long i = 0; i < n; ++i) {
      const float left = i > 0 ? float(p[i - 1]) : 0.0f, right = i + 1 < n ? float(p[i + 1]) : 0.0f;
      q[i] = double(3.0f * float(p[i]) - left - right);
    }
  }
};

// Reliable updates (jacobi_pcg_reliable): the iterations apply the float operator, and the
// solve still stops at the double operator's residual of 1e-12, in about as many iterations
// as CG on the double operator alone. Plain CG on the float operator cannot get there: its
// recursive residual passes the test while the true one stays near float's precision.
TEST(Pcg, ReliableUpdatesReachTheExactOperatorsToleranceThroughAFloatOperator) {
  const long n = 400;
  const Tridiagonal exact{n};
  const TridiagonalInFloat fast{n};
  std::vector<double> inv_diag(n, 1.0 / 3), b(n), x(n, 0.0), y(n, 0.0), z(n, 0.0), Ax(n);
  for (long i = 0; i < n; ++i) b[i] = std::sin(0.037 * double(i * i)) + 0.1;
  const double tolerance = 1e-12;
  const PcgResult reliable = jacobi_pcg_reliable<double>(n, fast, exact, inv_diag.data(), b.data(), x.data(),
                                                         tolerance, 2000);
  const PcgResult plain = jacobi_pcg<double>(n, exact, inv_diag.data(), b.data(), y.data(), tolerance, 2000);
  const PcgResult float_only = jacobi_pcg<double>(n, fast, inv_diag.data(), b.data(), z.data(), tolerance, 2000);
  auto true_residual = [&](const std::vector<double>& v) {
    exact(v.data(), Ax.data());
    double r2 = 0, b2 = 0;
    for (long i = 0; i < n; ++i) r2 += (Ax[i] - b[i]) * (Ax[i] - b[i]), b2 += b[i] * b[i];
    return std::sqrt(r2 / b2);
  };
  std::printf("iterations: reliable %d, double %d, float only %d; true residual %.3g, %.3g, %.3g\n",
              reliable.iterations, plain.iterations, float_only.iterations, true_residual(x), true_residual(y),
              true_residual(z));
  ASSERT_TRUE(reliable.converged);
  EXPECT_LE(true_residual(x), tolerance);
  EXPECT_NEAR(reliable.relative_residual, true_residual(x), 1e-3 * tolerance);
  EXPECT_LE(reliable.iterations, plain.iterations + plain.iterations / 10 + 2);
  EXPECT_GT(true_residual(z), 100 * tolerance);
}

}  // namespace
}  // namespace ssc
