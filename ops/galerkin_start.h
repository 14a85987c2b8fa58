// The start of a symmetric positive definite solve A x = b at the best point of an affine
// space x0 + span(d_0 .. d_{K-1}): x = x0 + sum_j a_j d_j with (D^T A D) a = D^T (b - A x0),
// the point of the space nearest the solution in the A-norm (so never farther than x0).
// The time-step solve's space (newmark_start_direction) holds its predictor and takes the
// best combination instead (docs/benchmarks.md, "the time-step solve started from the best
// point of a small affine space"). Callers sum the K (K + 1) / 2 entries of D^T A D and the
// K of D^T (b - A x0) in their own fixed order (the interpreter from whole applies, the
// GPU kernels per cell corner and node); the small solve below is the one definition both
// use. Directions that add nothing (zero, or a combination of the others) are dropped.
#pragma once
#include "ops/ssc_math.h"

namespace ssc {
namespace ops {

// Where the sums go: the Gram matrix's upper triangle (i <= j) row by row, then the
// right-hand side.
template <int K>
SSC_HD constexpr int gram_index(int i, int j) {
  return i * K - i * (i - 1) / 2 + (j - i);
}
template <int K>
SSC_HD constexpr int start_rhs_index(int j) {
  return K * (K + 1) / 2 + j;
}
template <int K>
constexpr int kStartSums = K * (K + 1) / 2 + K;

// Every loop over the K directions unrolled on the GPU: the small arrays stay in registers
// (the solve runs in every thread of a grid solve, on its critical path).
#if defined(__CUDACC__) || defined(__CUDACC_RTC__)
#define SSC_START_UNROLL _Pragma("unroll")
#else
#define SSC_START_UNROLL
#endif

// The coefficients a from the sums. Each direction is scaled to unit A-norm (their sizes
// differ by orders of magnitude), then a Cholesky factorisation of the scaled Gram matrix
// drops a direction whose pivot (the squared A-norm of its part A-orthogonal to the kept
// directions before it) is at most `cut`: it adds nothing the others do not, up to the
// rounding of the sums. A dropped direction has inv_root 0, so its column of the factor,
// its entry of the solution and its coefficient are 0.
template <int K>
SSC_HD inline void galerkin_coefficients(const double (&sums)[kStartSums<K>], double cut, double (&a)[K]) {
  double scale[K], l[K][K], inv_root[K], y[K];
  SSC_START_UNROLL
  for (int j = 0; j < K; ++j) {
    const double g = sums[gram_index<K>(j, j)];
    scale[j] = g > 0 ? 1 / sqrt(g) : 0;
  }
  SSC_START_UNROLL
  for (int j = 0; j < K; ++j) {
    double pivot = scale[j] * scale[j] * sums[gram_index<K>(j, j)];
    SSC_START_UNROLL
    for (int p = 0; p < j; ++p) pivot -= l[j][p] * l[j][p];
    inv_root[j] = scale[j] > 0 && pivot > cut ? 1 / sqrt(pivot) : 0;
    SSC_START_UNROLL
    for (int i = j + 1; i < K; ++i) {
      double s = scale[i] * scale[j] * sums[gram_index<K>(j, i)];
      SSC_START_UNROLL
      for (int p = 0; p < j; ++p) s -= l[i][p] * l[j][p];
      l[i][j] = s * inv_root[j];
    }
  }
  SSC_START_UNROLL
  for (int i = 0; i < K; ++i) {  // L y = the scaled right-hand side
    double s = scale[i] * sums[start_rhs_index<K>(i)];
    SSC_START_UNROLL
    for (int p = 0; p < i; ++p) s -= l[i][p] * y[p];
    y[i] = s * inv_root[i];
  }
  SSC_START_UNROLL
  for (int i = K - 1; i >= 0; --i) {  // L^T z = y, a = scale z
    double s = y[i];
    SSC_START_UNROLL
    for (int p = i + 1; p < K; ++p) s -= l[p][i] * a[p];
    a[i] = s * inv_root[i];
  }
  SSC_START_UNROLL
  for (int i = 0; i < K; ++i) a[i] *= scale[i];
}

// The pivot cut for sums of Real products: the rounding of a float apply is about 1e-7 of
// it, so smaller pivots in float are noise.
template <class Real>
SSC_HD constexpr double galerkin_cut() {
  return sizeof(Real) == 4 ? 1e-5 : 1e-10;
}

}  // namespace ops
}  // namespace ssc
