// The CG solver (runtime/pcg.h) on a small SPD system: it solves an ordinary right-hand side,
// and a negligible one (an adjoint cotangent decayed to 1e-160 through the contact's
// exp(-alpha d)) gives x = 0 instead of breaking down with 0/0 once p.Ap underflows; a
// reference norm bounds the residual of right-hand sides smaller than it.
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

}  // namespace
}  // namespace ssc
