// Jacobi-preconditioned conjugate gradients with deterministic reductions.
//
// Dot products are summed in fixed blocks (parallel over blocks, blocks added in order,
// in double), so the result does not depend on the number of threads. Stops when
// ||r|| <= tolerance * max(||b||, reference): with reference 0 a relative residual; a
// reference norm makes it an absolute one for right-hand sides smaller than it (the
// adjoint solves of one step, runtime/solvers.cpp). The caller decides what
// non-convergence means. A right-hand
// side below negligible_rhs_norm gives x = 0: an adjoint cotangent that has decayed to
// 1e-150 (through the contact's exp(-alpha d)) would otherwise underflow p.Ap to 0 and
// break the iteration with 0/0, and it adds nothing a double (or float) gradient can hold.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace ssc {

// Loops over fewer elements than this run on one thread: a parallel region costs more than
// it saves on small grids, and busy-waiting threads stall badly on a loaded machine. Vector,
// node and band-node entries cost a few dozen flops each; a cell (element matrices, a polar
// decomposition) a few thousand, so cell loops go parallel from far fewer entries.
constexpr long kParallelThreshold = 8192;
constexpr long kCellParallelThreshold = 256;

struct PcgResult {
  int iterations = 0;
  double relative_residual = 0;  // ||r|| / max(||b||, reference)
  double rhs_norm = 0;           // ||b||
  bool converged = false;
};

// N sums over i < n of what body(i, acc) adds into acc[0..N): summed in blocks of kBlock,
// blocks added in order, so the same bits serial or parallel. A loop that updates vectors
// can sum their products in the same pass.
template <int N, class Body>
std::array<double, N> blocked_sums(long n, Body&& body) {
  constexpr long kBlock = 2048;
  const long blocks = (n + kBlock - 1) / kBlock;
  auto block_sum = [&](long k, double* acc) {
    for (int j = 0; j < N; ++j) acc[j] = 0;
    const long end = std::min(n, (k + 1) * kBlock);
    for (long i = k * kBlock; i < end; ++i) body(i, acc);
  };
  std::array<double, N> total{};
  auto add = [&](const double* acc) {
    for (int j = 0; j < N; ++j) total[j] += acc[j];
  };
  if (n < kParallelThreshold) {
    double acc[N];
    for (long k = 0; k < blocks; ++k) {
      block_sum(k, acc);
      add(acc);
    }
    return total;
  }
  std::vector<double> partial(size_t(blocks) * N, 0.0);
#pragma omp parallel for schedule(static)
  for (long k = 0; k < blocks; ++k) block_sum(k, partial.data() + k * N);
  for (long k = 0; k < blocks; ++k) add(partial.data() + k * N);
  return total;
}

template <class Real>
double deterministic_dot(const Real* a, const Real* b, long n) {
  return blocked_sums<1>(n, [&](long i, double* acc) { acc[0] += double(a[i]) * double(b[i]); })[0];
}

template <class Real>
constexpr double negligible_rhs_norm() {
  return sizeof(Real) == 4 ? 1e-20 : 1e-100;
}

// |b| in the result; for a negligible b, x = 0 and a converged result.
template <class Real>
PcgResult rhs_norm_of(const Real* b, Real* x, long n) {
  PcgResult result;
  result.rhs_norm = std::sqrt(deterministic_dot(b, b, n));
  if (result.rhs_norm < negligible_rhs_norm<Real>()) {
    for (long i = 0; i < n; ++i) x[i] = Real(0);
    result.converged = true;
  }
  return result;
}

// x += step p, r -= step q, z = M^-1 r; the new r.z and |r|^2 in the same pass.
template <class Real>
std::array<double, 2> cg_update(long n, Real step, const Real* p, const Real* q, const Real* inv_diag, Real* x,
                                Real* r, Real* z) {
  return blocked_sums<2>(n, [&](long i, double* acc) {
    x[i] += step * p[i];
    r[i] -= step * q[i];
    z[i] = inv_diag[i] * r[i];
    acc[0] += double(r[i]) * double(z[i]);
    acc[1] += double(r[i]) * double(r[i]);
  });
}

// apply(p, Ap) computes the (SPD) operator; inv_diag is the Jacobi preconditioner.
template <class Real, class Apply>
PcgResult jacobi_pcg(long n, Apply&& apply, const Real* inv_diag, const Real* b, Real* x, double tolerance,
                     int max_iterations, double reference = 0) {
  std::vector<Real> r(n), z(n), p(n), q(n);
  PcgResult result = rhs_norm_of(b, x, n);
  if (result.converged) return result;
  const double b_norm = result.rhs_norm;
  apply(x, q.data());
  // r = b - A x, z = M^-1 r, p = z; r.z and |r|^2 in the same pass.
  auto start = blocked_sums<2>(n, [&](long i, double* acc) {
    r[i] = b[i] - q[i];
    z[i] = inv_diag[i] * r[i];
    p[i] = z[i];
    acc[0] += double(r[i]) * double(z[i]);
    acc[1] += double(r[i]) * double(r[i]);
  });
  double rz = start[0];
  double r_norm = std::sqrt(start[1]);
  const double scale = std::max(b_norm, reference);
  while (true) {
    result.relative_residual = r_norm / scale;
    if (result.relative_residual <= tolerance) {
      result.converged = true;
      return result;
    }
    if (result.iterations >= max_iterations || !std::isfinite(r_norm)) return result;
    apply(p.data(), q.data());
    const double pq = deterministic_dot(p.data(), q.data(), n);
    const auto sums = cg_update(n, Real(rz / pq), p.data(), q.data(), inv_diag, x, r.data(), z.data());
    const Real beta = Real(sums[0] / rz);
    rz = sums[0];
#pragma omp parallel for schedule(static) if (n >= kParallelThreshold)
    for (long i = 0; i < n; ++i) p[i] = z[i] + beta * p[i];
    r_norm = std::sqrt(sums[1]);
    ++result.iterations;
  }
}

// The residual is recomputed with the exact operator once it has fallen by this factor since it
// last was, and before the solve stops.
constexpr double kReliableUpdateFactor = 0.01;

// Jacobi PCG whose iterations apply `fast`, an approximation of the operator (the element
// arithmetic in float), with reliable updates: x is accumulated in Real, and the residual is
// recomputed as b - exact(x) whenever it has fallen by kReliableUpdateFactor since the last
// recomputation, and before the solve stops, so that the stopping test and the solution are
// the exact operator's to its tolerance (Sleijpen and van der Vorst 1996; as in mixed-precision
// CG on GPUs, Clark et al. 2010). The recomputations are not counted as iterations.
template <class Real, class Fast, class Exact>
PcgResult jacobi_pcg_reliable(long n, Fast&& fast, Exact&& exact, const Real* inv_diag, const Real* b, Real* x,
                              double tolerance, int max_iterations, double reference = 0) {
  std::vector<Real> r(n), z(n), p(n), q(n);
  PcgResult result = rhs_norm_of(b, x, n);
  if (result.converged) return result;
  const double b_norm = result.rhs_norm;
  double rz = 0, r_norm = 0;
  // r = b - exact(x), z = M^-1 r; r.z and |r|^2.
  auto exact_residual = [&] {
    exact(x, q.data());
    const auto sums = blocked_sums<2>(n, [&](long i, double* acc) {
      r[i] = b[i] - q[i];
      z[i] = inv_diag[i] * r[i];
      acc[0] += double(r[i]) * double(z[i]);
      acc[1] += double(r[i]) * double(r[i]);
    });
    rz = sums[0];
    r_norm = std::sqrt(sums[1]);
  };
  exact_residual();
  for (long i = 0; i < n; ++i) p[i] = z[i];
  double last_exact = r_norm;
  bool exact_now = true;
  const double scale = std::max(b_norm, reference);
  while (true) {
    if (r_norm / scale <= tolerance && !exact_now) {
      exact_residual();
      last_exact = r_norm;
      exact_now = true;
    }
    result.relative_residual = r_norm / scale;
    if (result.relative_residual <= tolerance) {
      result.converged = true;
      return result;
    }
    if (result.iterations >= max_iterations || !std::isfinite(r_norm)) {
      if (!exact_now && std::isfinite(r_norm)) {
        exact_residual();
        result.relative_residual = r_norm / scale;
        result.converged = result.relative_residual <= tolerance;
      }
      return result;
    }
    fast(p.data(), q.data());
    const double pq = deterministic_dot(p.data(), q.data(), n);
    const double rz_old = rz;
    const auto sums = cg_update(n, Real(rz / pq), p.data(), q.data(), inv_diag, x, r.data(), z.data());
    rz = sums[0];
    r_norm = std::sqrt(sums[1]);
    exact_now = false;
    if (r_norm < kReliableUpdateFactor * last_exact) {
      exact_residual();
      last_exact = r_norm;
      exact_now = true;
    }
    const Real beta = Real(rz / rz_old);
#pragma omp parallel for schedule(static) if (n >= kParallelThreshold)
    for (long i = 0; i < n; ++i) p[i] = z[i] + beta * p[i];
    ++result.iterations;
  }
}

}  // namespace ssc
