// The interpreter's Galerkin start of a symmetric positive definite solve A x = b
// (ops/galerkin_start.h): the sums of D^T A D and D^T (b - A x0) from whole applies, in a
// fixed order (deterministic_dot, so the same bits serial or parallel), then the shared
// small solve and x = x0 + D a.
#pragma once
#include <array>
#include <vector>

#include "ops/galerkin_start.h"
#include "runtime/pcg.h"

namespace ssc {

// apply(p, q): q = A p; product(j, q): q = A d_j (where the caller knows a cheaper way).
// x holds x0 on entry and the start on return.
template <int K, class Real, class Apply, class Product>
void galerkin_start(long n, Apply&& apply, Product&& product, const Real* b,
                    const std::array<std::vector<Real>, K>& directions, Real* x) {
  std::vector<Real> r(n), ad(n);
  apply(x, r.data());
#pragma omp parallel for schedule(static) if (n >= kParallelThreshold)
  for (long i = 0; i < n; ++i) r[i] = b[i] - r[i];
  double sums[ops::kStartSums<K>], a[K];
  for (int j = 0; j < K; ++j) {
    product(j, ad.data());
    for (int i = 0; i <= j; ++i) sums[ops::gram_index<K>(i, j)] = deterministic_dot(directions[i].data(), ad.data(), n);
    sums[ops::start_rhs_index<K>(j)] = deterministic_dot(directions[j].data(), r.data(), n);
  }
  ops::galerkin_coefficients<K>(sums, ops::galerkin_cut<Real>(), a);
#pragma omp parallel for schedule(static) if (n >= kParallelThreshold)
  for (long i = 0; i < n; ++i) {
    double s = double(x[i]);
    for (int j = 0; j < K; ++j) s += a[j] * double(directions[j][i]);
    x[i] = Real(s);
  }
}

}  // namespace ssc
