// Device code of the solver stages (codegen/solver_snippets.cpp): the Newmark and band
// Laplacian stage bodies, the block-per-item Jacobi-PCG kernels and the persistent grid
// PCG solves. A stage's fragment is a call of a function here with the kernel's bindings
// (pointers already offset to the batch item; tensors as pointers, read where they are
// used). Pasted into every kernel's prelude after device_helpers.cuh
// (codegen/cuda_source.cpp), so NVRTC compiles it with every kernel. Everything is
// __forceinline__ or a lambda inside one: the solves must inline into their kernel whole
// (incidence in registers, the value(source, m) recomputation, no calls in the hot loop).
#pragma once
#include "codegen/device_helpers.cuh"
#include "ops/corotation.h"
#include "ops/elasticity.h"
#include "ops/galerkin_start.h"
#include "ops/gather.h"
#include "ops/newmark.h"
#include "ops/ssc_math.h"
namespace ssc {
namespace gen {

// The component-wise product (a Jacobi diagonal times a vector).
template <class R>
__device__ __forceinline__ Vec3<R> times(Vec3<R> a, Vec3<R> b) {
  return make_vec3(a.x * b.x, a.y * b.y, a.z * b.z);
}

// The optional node-local damping matrix C of the time-step system (friction,
// ops/newmark.h): a fragment passes its pointer, or nullptr when the op's slot is unbound;
// the two are overloads, so an undamped kernel has no trace of C (no run-time test).
using NoDamping = decltype(nullptr);

// y + C e at node n.
template <class R>
__device__ __forceinline__ Vec3<R> add_damping(Vec3<R> y, const R* damping, int n, Vec3<R> e) {
  return y + ops::sym3_apply(damping, n, e);
}
template <class R>
__device__ __forceinline__ Vec3<R> add_damping(Vec3<R> y, NoDamping, int, Vec3<R>) {
  return y;
}
// d + the diagonal of C at node n.
template <class R>
__device__ __forceinline__ void add_damping_diagonal(Vec3<R>& d, const R* damping, int n) {
  d += make_vec3(damping[6 * n], damping[6 * n + 1], damping[6 * n + 2]);
}
template <class R>
__device__ __forceinline__ void add_damping_diagonal(Vec3<R>&, NoDamping, int) {}

// (A + C) e at node n given (K e) there: the time-step system's node part.
template <class R, class Damping>
__device__ __forceinline__ Vec3<R> newmark_node_apply(const ops::NewmarkCoefficients<R>& c, const R* mass,
                                                      Damping damping, int n, Vec3<R> e, Vec3<R> ke) {
  return add_damping(ops::newmark_system_apply(c, mass[n], e, ke), damping, n, e);
}

// ---- Newmark stages (one thread per node, cell or cell corner i) ----

// The solve's initial guess: the guess given (a nonlinear iteration's iterate), else
// ops::newmark_start; 0 on fixed nodes.
template <class R>
__device__ __forceinline__ void newmark_init(int i, const R* dt, const R* theta, const R* u_prev, const R* v_prev,
                                             const R* v_before, const R* fixed, const R* guess, R* u) {
  for (int k = 0; k < 3; ++k)
    u[3 * i + k] = fixed[i] != R(0) ? R(0)
                   : guess          ? guess[3 * i + k]
                                    : ops::newmark_start(dt[0], theta[0], u_prev, v_prev, v_before, 3 * i + k);
}

// Corner i & 7 of cell i >> 3 of the stiffness diagonal.
template <class R>
__device__ __forceinline__ void newmark_diagonal_corner(int i, R h, const R* rotation, const R* cell_weights,
                                                        const R* lambda, const R* mu, R* corner) {
  const int cell = i >> 3;
  store3(corner, i,
         ops::corotated_diagonal_corner(ops::load_mat3(rotation, cell), cell_weights + 8 * cell, lambda[cell], mu[cell], h,
                                        i & 7));
}

// Node i: the Jacobi diagonal from the corner diagonals, the masked right-hand side, and
// x's start (ops::NewmarkXStart; 0 on fixed nodes).
template <class R, class Damping>
__device__ __forceinline__ void newmark_setup(int i, const ops::NewmarkCoefficients<R>& c, const R* mass,
                                              const R* fixed, Damping damping, const R* corner,
                                              const int* node_cell_offset, const int* node_cell_entry, const R* rhs,
                                              int x_start, R* x, R* x_before, R* b, R* inv_diag) {
  const Vec3<R> kd = ops::gather_corner_sum(corner, node_cell_offset, node_cell_entry, i);
  Vec3<R> d = ops::newmark_system_apply(c, mass[i], make_vec3(R(1), R(1), R(1)), kd);
  add_damping_diagonal(d, damping, i);
  const bool is_fixed = fixed[i] != R(0);
  for (int k = 0; k < 3; ++k) {
    inv_diag[3 * i + k] = is_fixed ? R(1) : R(1) / d[k];
    b[3 * i + k] = is_fixed ? R(0) : rhs[3 * i + k];
    if (x_start == ops::kWarmChainX) {
      const R later = x[3 * i + k], before = x_before[3 * i + k];
      x_before[3 * i + k] = later;
      x[3 * i + k] = is_fixed || isnan(later) ? R(0) : isnan(before) ? later : later + (later - before);
    } else if (is_fixed || x_start == ops::kZeroX) {
      x[3 * i + k] = R(0);
    }
  }
}

// Cell i: the corners of R K R^T p.
template <class R>
__device__ __forceinline__ void newmark_apply_cell(int i, R h, const R* rotation, const R* cell_weights,
                                                   const int* cell_nodes, const R* lambda, const R* mu, const R* p,
                                                   R* corner) {
  Vec3<R> pc[8], y[8];
  ops::load_cell_corners(p, cell_nodes, i, pc);
  ops::corotated_apply(ops::load_mat3(rotation, i), cell_weights + 8 * i, lambda[i], mu[i], h, pc, y);
  for (int k = 0; k < 8; ++k) store3(corner, 8 * i + k, y[k]);
}

// Node i: q = (A + C) p from the corners, q = p on fixed nodes.
template <class R, class Damping>
__device__ __forceinline__ void newmark_apply_node(int i, const ops::NewmarkCoefficients<R>& c, const R* mass,
                                                   const R* fixed, Damping damping, const R* corner,
                                                   const int* node_cell_offset, const int* node_cell_entry,
                                                   const R* p, R* q) {
  const Vec3<R> kp = ops::gather_corner_sum(corner, node_cell_offset, node_cell_entry, i);
  store3(q, i, fixed[i] != R(0) ? load3(p, i) : newmark_node_apply(c, mass, damping, i, load3(p, i), kp));
}

// ---- Band Laplacian stages (one thread per band node or node i) ----

// Band node i: b = the sum of u over its active (off-band) neighbours, x = the guess,
// the Jacobi diagonal 1 / deg.
template <class R>
__device__ __forceinline__ void extension_setup(int i, const R* u, const R* band_guess, const int* band_neighbors,
                                                const int* band_degree, R* band_u, R* b, R* inv_diag) {
  Vec3<R> s = zero3<R>();
  for (int d = 0; d < 6; ++d) {
    const int nb = band_neighbors[6 * i + d];
    if (nb <= -2) s += load3(u, -nb - 2);
  }
  store3(b, i, s);
  for (int k = 0; k < 3; ++k) {
    band_u[3 * i + k] = band_guess[3 * i + k];
    inv_diag[3 * i + k] = R(1) / R(band_degree[i]);
  }
}

// Band node i of the adjoint solve: b = band_u's cotangent, x = 0 when zero_x, 1 / deg.
template <class R>
__device__ __forceinline__ void extension_adj_setup(int i, const R* band_u_bar, const int* band_degree, int zero_x,
                                                    R* x, R* b, R* inv_diag) {
  for (int k = 0; k < 3; ++k) {
    b[3 * i + k] = band_u_bar[3 * i + k];
    if (zero_x) x[3 * i + k] = R(0);
    inv_diag[3 * i + k] = R(1) / R(band_degree[i]);
  }
}

// Band node i: q = L p.
template <class R>
__device__ __forceinline__ void extension_apply(int i, const int* band_neighbors, const int* band_degree, const R* p,
                                                R* q) {
  Vec3<R> s = R(band_degree[i]) * load3(p, i);
  for (int d = 0; d < 6; ++d) {
    const int nb = band_neighbors[6 * i + d];
    if (nb >= 0) s -= load3(p, nb);
  }
  store3(q, i, s);
}

// Node i: u_bar += the adjoint solution y at the band nodes that read node i.
template <class R>
__device__ __forceinline__ void extension_solve_node(int i, const int* node_band_offset, const int* node_band_entry,
                                                     const R* y, R* u_bar) {
  for (int k = node_band_offset[i]; k < node_band_offset[i + 1]; ++k) add3(u_bar, i, load3(y, node_band_entry[k]));
}

// ---- The extension as one product (runtime/band_operator.h) ----

// band_u = G u with a block of SSC_BLOCK threads per 32 band nodes: lane l of warp w sums
// band node 32 * blockIdx.x + l over the w-th of the block's warp count of slices of the
// sources (j ascending; G's column j holds band_count values, so a warp's loads are
// contiguous), and warp 0 adds the slices in order. Launched over len = SSC_BLOCK *
// ceil(n_band / 32) threads, so every block is whole.
template <class R>
__device__ __forceinline__ void extension_dense(int n_band, int n_source, const R* columns, const int* sources,
                                                const R* u, R* band_u) {
  constexpr int kWarps = SSC_BLOCK / 32;
  __shared__ R slice_sum[kWarps][32][3];
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5, i = 32 * blockIdx.x + lane;
  const int first = int((long(n_source) * warp) / kWarps), last = int((long(n_source) * (warp + 1)) / kWarps);
  Vec3<R> s = zero3<R>();
  if (i < n_band) {
#pragma unroll 4
    for (int j = first; j < last; ++j) s += columns[size_t(j) * size_t(n_band) + size_t(i)] * load3(u, sources[j]);
  }
  for (int k = 0; k < 3; ++k) slice_sum[warp][lane][k] = s[k];
  __syncthreads();
  if (warp == 0 && i < n_band) {
    Vec3<R> total = zero3<R>();
    for (int w = 0; w < kWarps; ++w) total += make_vec3(slice_sum[w][lane][0], slice_sum[w][lane][1], slice_sum[w][lane][2]);
    store3(band_u, i, total);
  }
}

// Thread t: lane t & 31 of the warp of source j = t >> 5 adds its strided share of
// (G^T band_u_bar)(j), a fixed shuffle tree totals the warp, lane 0 adds it to u_bar.
template <class R>
__device__ __forceinline__ void extension_dense_adjoint(int t, int n_band, const R* columns, const int* sources,
                                                        const R* band_u_bar, R* u_bar) {
  const int j = t >> 5, lane = t & 31;
  const R* column = columns + size_t(j) * size_t(n_band);
  Vec3<R> s = zero3<R>();
  for (int i = lane; i < n_band; i += 32) s += column[i] * load3(band_u_bar, i);
  for (int mask = 16; mask > 0; mask >>= 1) s += shfl_xor3(s, mask);
  if (lane == 0) add3(u_bar, sources[j], s);
}

// ---- Block-per-item Jacobi-PCG (Extent::Item) ----
//
// One block of SSC_ITEM threads per batch item: thread i walks k = i, i + SSC_ITEM, ...
// of the vectors (length len), its partial dot products meet in block_sum (a fixed tree:
// bitwise reproducible), and every thread gets the totals, so the scalar update, the
// axpys and the direction update run in the same launch. One CG iteration is the
// operator's apply kernels plus pcg_iterate. Solver state cg (16 doubles per item):
// 0 |b|, 1 r.z, 2 |r|, 3 p.q, 4 step, 5 beta, 6 active, 7 iterations, 8 relative
// residual, 9 converged.

// Whether an apply kernel of a host-driven loop (gate != 0) finds the item's solve stopped.
__device__ __forceinline__ bool pcg_stopped(int gate, const double* cg) { return gate != 0 && cg[6] == 0.0; }

// The convergence test of runtime/pcg.h on the state.
__device__ __forceinline__ void pcg_check(double* cg, double tol, int max_it) {
  if (cg[0] == 0.0) {
    cg[6] = 0;
    cg[9] = 1;
    cg[8] = 0;
  } else {
    cg[8] = cg[2] / cg[0];
    if (cg[8] <= tol) {
      cg[6] = 0;
      cg[9] = 1;
    } else if (cg[7] >= double(max_it) || !isfinite(cg[2])) {
      cg[6] = 0;
      cg[9] = 0;
    } else {
      cg[6] = 1;
    }
  }
}

// The residual reference of a solve (runtime/pcg.h): mode 0 none (a relative residual),
// 1 the solve's own |b| (the first adjoint solve of a step), 2 the larger of |b| and the
// reference the step's earlier solves left in *reference; modes 1 and 2 store it there.
// Returns the norm the residual is measured against (0 when b is).
__device__ __forceinline__ double residual_scale(double b_norm, const double* reference, int mode) {
  if (b_norm == 0.0 || mode == 0) return b_norm;
  return mode == 1 ? b_norm : fmax(b_norm, __ldcg(reference));
}

// |b|, r = b - q (q = A x), z = M^-1 r, p = z, r.z, |r|, the test; x = 0 when b = 0.
template <class R>
__device__ __forceinline__ void pcg_start(int i, int len, double tol, int max_it, const R* b, const R* q,
                                          const R* inv_diag, R* x, R* r, R* z, R* p, double* cg, double* reference,
                                          int reference_mode) {
  double acc[3] = {0, 0, 0};
  for (int k = i; k < len; k += SSC_ITEM) {
    const R bk = b[k];
    const R rk = bk - q[k];
    const R zk = inv_diag[k] * rk;
    r[k] = rk;
    z[k] = zk;
    p[k] = zk;
    acc[0] += double(bk) * double(bk);
    acc[1] += double(rk) * double(zk);
    acc[2] += double(rk) * double(rk);
  }
  block_sum<3>(acc);
  // A negligible right-hand side (runtime/pcg.h) counts as 0: x = 0.
  const double b_norm = sqrt(acc[0]) < (sizeof(R) == 4 ? 1e-20 : 1e-100) ? 0.0 : sqrt(acc[0]);
  if (b_norm == 0.0)
    for (int k = i; k < len; k += SSC_ITEM) x[k] = R(0);
  if (i == 0) {
    const double scale = residual_scale(b_norm, reference, reference_mode);
    if (reference_mode != 0 && scale != 0.0) *reference = scale;
    for (int k = 0; k < 16; ++k) cg[k] = 0;
    cg[0] = scale;
    cg[1] = acc[1];
    cg[2] = sqrt(acc[2]);
    pcg_check(cg, tol, max_it);
  }
}

// One iteration given q = A p: p.q, step, x += step p, r -= step q, z = M^-1 r, r.z, |r|,
// beta, p = z + beta p, the test. Returns at once when the item has stopped.
template <class R>
__device__ __forceinline__ void pcg_iterate(int i, int len, double tol, int max_it, const R* q, const R* inv_diag,
                                            R* x, R* r, R* z, R* p, double* cg) {
  if (cg[6] == 0.0) return;  // stopped (uniform over the block)
  const double rz = cg[1];
  double pq[1] = {0};
  for (int k = i; k < len; k += SSC_ITEM) pq[0] += double(p[k]) * double(q[k]);
  block_sum<1>(pq);
  const R step = R(rz / pq[0]);
  double acc[2] = {0, 0};
  for (int k = i; k < len; k += SSC_ITEM) {
    x[k] += step * p[k];
    const R rk = r[k] - step * q[k];
    const R zk = inv_diag[k] * rk;
    r[k] = rk;
    z[k] = zk;
    acc[0] += double(rk) * double(zk);
    acc[1] += double(rk) * double(rk);
  }
  block_sum<2>(acc);
  const R beta = R(acc[0] / rz);
  for (int k = i; k < len; k += SSC_ITEM) p[k] = z[k] + beta * p[k];
  if (i == 0) {
    cg[3] = pq[0];
    cg[4] = double(step);
    cg[5] = double(beta);
    cg[1] = acc[0];
    cg[2] = sqrt(acc[1]);
    cg[7] += 1;
    pcg_check(cg, tol, max_it);
  }
}

// ---- Persistent grid solves (Extent::Grid) ----
//
// One cooperative kernel runs a whole Jacobi-PCG solve for every batch item: gridDim.x
// blocks per item, the item's blocks meeting at grid barriers. The iteration is the
// Chronopoulos-Gear form of PCG (the same iterates as runtime/pcg.h in exact arithmetic,
// one reduction per iteration instead of two):
//   s = w + beta s,  p = u + beta p,  x += alpha p,  r -= alpha s,  u = M^-1 r,  w = A u,
//   gamma' = r.u,  delta = w.u,  beta = gamma' / gamma,
//   alpha = gamma' / (delta - beta gamma' / alpha).
// The apply A u needs u at neighbouring nodes before their owners have updated it, so
// every thread evaluates u there from the previous iteration's r, w, s (GridPcg::next_u):
// the same expression, the same bits as the owner's (grid_own_update). Each thread owns
// the same nodes (n = rank, rank + threads, ...) in every phase. The final state goes to
// cg, to slot log_slot of cg_log (read by the host once per step) and the iteration
// count to iterations[0].

// The operand of an apply at node m: the start's x or u, or the loop's next u.
enum Source : int { kSourceX = 0, kSourceU = 1, kSourceNextU = 2 };

// A grid solve's vectors, state and grid plumbing (one batch item).
template <class R>
struct GridPcg {
  R* x;
  const R* b;
  const R* inv_diag;
  R *r, *w, *s, *z, *p;
  R* iterations;
  double tol;
  int max_it, log_slot;
  double *cg, *cg_log;
  double* reference;  // the step's residual reference (residual_scale)
  int reference_mode;
  unsigned long long* bar;
  // Consecutive sums alternate between two partial-sum buffers: a block may write the
  // next sum's partials while another still reads this one's.
  double *partial0, *partial1;
  int parity = 0;
  int rank, threads;
  R step = R(0), beta = R(0);  // alpha and beta of the iteration under way

  // partial holds 2 * half doubles; barrier is the kernel's barrier counter.
  __device__ __forceinline__ GridPcg(R* x_, const R* b_, const R* inv_diag_, R* r_, R* w_, R* s_, R* z_, R* p_,
                                     R* iterations_, double tol_, int max_it_, int log_slot_, double* cg_,
                                     double* cg_log_, double* reference_, int reference_mode_, double* partial,
                                     int half, double* barrier)
      : x(x_), b(b_), inv_diag(inv_diag_), r(r_), w(w_), s(s_), z(z_), p(p_), iterations(iterations_), tol(tol_),
        max_it(max_it_), log_slot(log_slot_), cg(cg_), cg_log(cg_log_), reference(reference_),
        reference_mode(reference_mode_), bar(reinterpret_cast<unsigned long long*>(barrier)), partial0(partial),
        partial1(partial + half), rank(grid_rank()), threads(grid_threads()) {}

  // between: work for every thread once all blocks have arrived (grid_sum).
  template <int N, class Between = NoWork>
  __device__ __forceinline__ void sum(double (&v)[N], Between between = {}) {
    grid_sum<N>(v, parity ? partial1 : partial0, bar, between);
    parity ^= 1;
  }
  // u_{k+1} at node m from the previous iteration's vectors in r_old, w_old, s_old.
  __device__ __forceinline__ Vec3<R> next_u(const R* r_old, const R* w_old, const R* s_old, int m) const {
    const Vec3<R> sm = load3(w_old, m) + beta * load3(s_old, m);
    return times(load3(inv_diag, m), load3(r_old, m) - step * sm);
  }
};

// gamma += r.u, delta += w.u, |r|^2 += r.r at one node.
template <class R, int N>
__device__ __forceinline__ void add_pcg_sums(double (&acc)[N], Vec3<R> rn, Vec3<R> un, Vec3<R> wn) {
  static_assert(N >= 3, "gamma, delta and |r|^2");
  for (int k = 0; k < 3; ++k) {
    acc[0] += double(rn[k]) * double(un[k]);
    acc[1] += double(wn[k]) * double(un[k]);
    acc[2] += double(rn[k]) * double(rn[k]);
  }
}

// a . b summed in double.
template <class R>
__device__ __forceinline__ double dot_double(Vec3<R> a, Vec3<R> b) {
  return double(a.x) * double(b.x) + double(a.y) * double(b.y) + double(a.z) * double(b.z);
}

// delta's corner part a_k (corner force y . u) at one cell corner (the Newmark grid solves sum
// delta = w.u over the corners and the node terms over the nodes).
template <class R>
__device__ __forceinline__ void add_corner_delta(double& delta, R a_k, Vec3<R> y, Vec3<R> u) {
  delta += double(a_k) * dot_double(y, u);
}

// The start's first half over the thread's own nodes (count of them in all), given
// q_of_x(n) = (A x)(n): r = b - q, u = M^-1 r, s = p = 0 (the previous directions).
// Returns the thread's share of |b|^2; ends with a grid barrier.
template <class R, class QofX>
__device__ __forceinline__ double grid_start_residual(GridPcg<R>& g, int count, R* r, R* s, QofX q_of_x) {
  double bb = 0;
  for (int n = g.rank; n < count; n += g.threads) {
    const Vec3<R> q = q_of_x(n);
    const Vec3<R> bn = load3(g.b, n), rn = bn - q;
    store3(r, n, rn);
    store3(g.z, n, times(load3(g.inv_diag, n), rn));
    store3(s, n, zero3<R>());
    store3(g.p, n, zero3<R>());
    for (int k = 0; k < 3; ++k) bb += double(bn[k]) * double(bn[k]);
  }
  grid_sync(g.bar);
  return bb;
}

// The start's second half, once u = M^-1 r is complete: w = A u at the own nodes from
// w_of_u(n, un) (which sets un = u(n)), stored in w; acc = {gamma, delta, |r|^2} and bb
// = |b|^2 (the first half's shares) summed over the item in one grid sum.
template <class R, class WofU>
__device__ __forceinline__ void grid_start_sums(GridPcg<R>& g, int count, const R* r, R* w, WofU w_of_u, double& bb,
                                                double (&acc)[3]) {
  for (int k = 0; k < 3; ++k) acc[k] = 0;
  for (int n = g.rank; n < count; n += g.threads) {
    Vec3<R> un;
    const Vec3<R> wn = w_of_u(n, un);
    const Vec3<R> rn = load3(r, n);
    store3(w, n, wn);
    add_pcg_sums(acc, rn, un, wn);
  }
  double sums[4] = {acc[0], acc[1], acc[2], bb};
  g.sum(sums);
  for (int k = 0; k < 3; ++k) acc[k] = sums[k];
  bb = sums[3];
}

// The own-node update of one iteration at node n: s, p, x, r, u from the previous r, w,
// s, and w = w_of_u(n, u) = A u; written to r_out, w_out, s_out (which may be r, w, s);
// the node's sums into acc. u is not stored: p's u = M^-1 r is recomputed from the stored r
// (z holds the start's u only).
template <class R, class WofU>
__device__ __forceinline__ void grid_own_update(GridPcg<R>& g, int n, const R* r, const R* w, const R* s, R* r_out,
                                                R* w_out, R* s_out, WofU w_of_u, double (&acc)[3]) {
  const Vec3<R> inv = load3(g.inv_diag, n), rn_old = load3(r, n);
  const Vec3<R> sn = load3(w, n) + g.beta * load3(s, n);
  const Vec3<R> pn = times(inv, rn_old) + g.beta * load3(g.p, n);  // u = M^-1 r: the bits stored as z before
  const Vec3<R> rn = rn_old - g.step * sn;
  const Vec3<R> un = times(inv, rn);
  const Vec3<R> wn = w_of_u(n, un);
  store3(g.x, n, load3(g.x, n) + g.step * pn);
  store3(s_out, n, sn);
  store3(g.p, n, pn);
  store3(r_out, n, rn);
  store3(w_out, n, wn);
  add_pcg_sums(acc, rn, un, wn);
}

// From the start's sums (start = {gamma, delta, |r|^2}, bb = |b|^2): the convergence test
// of runtime/pcg.h, the loop (iteration(acc) adds the new sums into acc; between() runs inside
// each iteration's grid sum, GridPcg::sum), the final state.
template <class R, class Iteration, class Between = NoWork>
__device__ __forceinline__ void grid_loop(GridPcg<R>& g, int count, const double (&start)[3], double bb,
                                          Iteration iteration, Between between = {}) {
  const double b_norm = sqrt(bb) < (sizeof(R) == 4 ? 1e-20 : 1e-100) ? 0.0 : sqrt(bb);  // runtime/pcg.h
  // Every block reads the reference before rank 0 may overwrite it with the same maximum.
  const double scale = residual_scale(b_norm, g.reference, g.reference_mode);
  double gamma = start[0], alpha = start[0] / start[1], rr = start[2];
  // Off the loop's critical path: the reciprocals the next iteration's step and beta need, and
  // the test as |r|^2 against (tol scale)^2 (no square root or division after the sum).
  double inv_gamma = 1.0 / gamma, inv_alpha = 1.0 / alpha;
  const double bound = g.tol * scale, bound2 = bound * bound;
  int its = 0;
  bool active = false, converged = false;
  auto test = [&]() {
    active = false;
    converged = false;
    if (rr <= bound2) converged = true;
    else if (its < g.max_it && isfinite(rr)) active = true;
  };
  if (b_norm == 0.0) {
    for (int n = g.rank; n < count; n += g.threads) store3(g.x, n, zero3<R>());
    converged = true;
  } else {
    test();
  }
  g.step = R(alpha);
  while (active) {
    double acc[3] = {0, 0, 0};
    iteration(acc);
    g.sum(acc, between);
    const double gamma_next = acc[0];
    const double beta_next = gamma_next * inv_gamma;
    alpha = gamma_next / (acc[1] - beta_next * gamma_next * inv_alpha);
    gamma = gamma_next;
    g.step = R(alpha);
    g.beta = R(beta_next);
    rr = acc[2];
    ++its;
    test();
    inv_gamma = 1.0 / gamma;
    inv_alpha = 1.0 / alpha;
  }
  const double r_norm = sqrt(rr), rel = r_norm / scale;
  if (g.rank == 0) {
    if (g.reference_mode != 0 && scale != 0.0) *g.reference = scale;
    const double st[10] = {scale, gamma, r_norm, 0, alpha, double(g.beta), 0, double(its), rel,
                           converged ? 1.0 : 0.0};
    for (int k = 0; k < 16; ++k) {
      g.cg[k] = k < 10 ? st[k] : 0.0;
      g.cg_log[16 * g.log_slot + k] = g.cg[k];
    }
    g.iterations[0] = R(its);
  }
}

// Corner t & 7 of cell t >> 3 as the element apply needs it: the cell's rotation, Lame
// parameters and the corner's weight (an invalid lane, past the last cell, reads cell 0).
template <class R>
struct CornerElement {
  Mat3<R> rotation;
  R weight, lambda, mu;
  int corner;
  __device__ __forceinline__ CornerElement(int t, bool valid, const R* rotations, const R* cell_weights,
                                           const R* lambdas, const R* mus)
      : corner(t & 7) {
    const int e = valid ? t >> 3 : 0;
    rotation = ops::load_mat3(rotations, e);
    weight = cell_weights[valid ? t : corner];
    lambda = lambdas[e];
    mu = mus[e];
  }
  __device__ __forceinline__ CornerElement(int t, const Mat3<R>& rotation_, R weight_, R lambda_, R mu_)
      : rotation(rotation_), weight(weight_), lambda(lambda_), mu(mu_), corner(t & 7) {}
  // The corner of R K R^T e (newmark_apply_cell's corotated_apply) given e at the corner's
  // node, eight lanes per cell: lane c rotates corner c, gets its edge neighbours' rotated
  // vectors and stress columns by warp shuffles, assembles corner c. All 32 lanes of the
  // warp must call it.
  __device__ __forceinline__ Vec3<R> apply(R h, Vec3<R> ev) const {
    const Vec3<R> q = mul_transposed(rotation, ev);
    const Vec3<R> qn[3] = {shfl_xor3(q, 1), shfl_xor3(q, 2), shfl_xor3(q, 4)};
    Vec3<R> col[3];
    ops::element_corner_columns(corner, weight, lambda, mu, h, q, qn, col);
    return rotation *
           ops::element_corner_assemble(col, shfl_xor3(col[0], 1), shfl_xor3(col[1], 2), shfl_xor3(col[2], 4));
  }
};

// ---- The time-step solve's Galerkin start (ops/galerkin_start.h) ----
//
// The solve starts at x0 + D a, the best point of the span of ops::newmark_start_direction
// around newmark_init's x0. The sums of D^T A D and D^T (b - A x0) are split as delta's are:
// a_k (d_i . K_e d_j) and -a_k (x0 . K_e d_j) per cell corner (at the corner's node), the
// node terms d_i . (a_m m + C) d_j and d_j . (b - (a_m m + C) x0) per free node. K_e of a
// translation (the directions from ops::kFirstStartTranslation on) is zero (the element's
// energy does not change under a rigid shift), so those are applied to the element only in
// warps with a cell that has a fixed corner, where the direction is zeroed.

// The directions at a node, zero on fixed nodes. A fragment passes them, or nullptr (NoStart)
// where the op has a guess. A forward grid kernel also runs the adjoint solves, which start
// elsewhere: there active is false.
template <class R>
struct StartDirections {
  R dt;
  const R* v_prev;
  const R* v_before;  // nullptr when the op has none
  bool active;
  __device__ __forceinline__ Vec3<R> at(int j, int m, bool fixed) const {
    if (fixed) return zero3<R>();
    return make_vec3(ops::newmark_start_direction(j, dt, v_prev, v_before, 3 * m),
                     ops::newmark_start_direction(j, dt, v_prev, v_before, 3 * m + 1),
                     ops::newmark_start_direction(j, dt, v_prev, v_before, 3 * m + 2));
  }
};
using NoStart = decltype(nullptr);
constexpr int kStartDirections = ops::kStartDirections;
constexpr int kStartSums = ops::kStartSums<kStartDirections>;

// Free node n's terms of the sums: d_i . (a_m m + C) d_j and d_j . (b - (a_m m + C) x0).
template <class R, class NodeSystem>
__device__ __forceinline__ void add_start_node_shares(const StartDirections<R>& dirs, int n, const R* x, const R* b,
                                                      NodeSystem node_system, double (&acc)[kStartSums]) {
  const Vec3<R> rest = load3(b, n) - node_system(n, load3(x, n));
#pragma unroll
  for (int j = 0; j < kStartDirections; ++j) {
    const Vec3<R> dj = dirs.at(j, n, false), mj = node_system(n, dj);
#pragma unroll
    for (int i = 0; i <= j; ++i) acc[ops::gram_index<kStartDirections>(i, j)] += dot_double(dirs.at(i, n, false), mj);
    acc[ops::start_rhs_index<kStartDirections>(j)] += dot_double(dj, rest);
  }
}

// Whether cell corner t is the first corner entry of its node m, which then takes the node's
// share of the work (the one-phase solve spreads the nodes so over all its blocks).
__device__ __forceinline__ bool owns_node(int t, int m, const int* node_cell_offset, const int* node_cell_entry) {
  return node_cell_entry[node_cell_offset[m]] == t;
}

// The thread's shares of the sums: cell corners t = first, first + stride, ... (whole warps:
// the element apply shuffles) and the nodes: n = first, first + stride, ..., or, given
// node_cell_entry, each node at the corner that owns it (owns_node); x holds x0, b the masked
// right-hand side. node_system(n, e) = (a_m m + C) e at free node n.
template <class R, class NodeSystem>
__device__ __forceinline__ void start_shares(const StartDirections<R>& dirs, int first, int stride, int n_cell,
                                             int n_node, R h, R a_k, const R* rotation, const R* cell_weights,
                                             const int* cell_nodes, const R* lambda, const R* mu, const R* fixed,
                                             const int* node_cell_offset, const int* node_cell_entry, const R* x,
                                             const R* b, NodeSystem node_system, double (&acc)[kStartSums]) {
  for (int k = 0; k < kStartSums; ++k) acc[k] = 0;
  const int lanes = 8 * n_cell, lanes_warps = (lanes + 31) / 32 * 32;
  for (int t = first; t < lanes_warps; t += stride) {
    const bool valid = t < lanes;
    const int m = valid ? cell_nodes[t] : 0;
    const bool free = valid && fixed[m] == R(0);
    const CornerElement<R> element(t, valid, rotation, cell_weights, lambda, mu);
    const Vec3<R> x0 = load3(x, m);
    const bool near_fixed = __any_sync(0xffffffffu, valid && !free);
#pragma unroll
    for (int j = 0; j < kStartDirections; ++j) {
      if (j >= ops::kFirstStartTranslation && !near_fixed) break;  // warp-uniform
      const Vec3<R> y = element.apply(h, dirs.at(j, m, !free));
      if (!free) continue;
#pragma unroll
      for (int i = 0; i <= j; ++i)
        add_corner_delta(acc[ops::gram_index<kStartDirections>(i, j)], a_k, y, dirs.at(i, m, false));
      add_corner_delta(acc[ops::start_rhs_index<kStartDirections>(j)], -a_k, y, x0);
    }
    if (node_cell_entry && free && owns_node(t, m, node_cell_offset, node_cell_entry))
      add_start_node_shares(dirs, m, x, b, node_system, acc);
  }
  if (node_cell_entry) return;
  for (int n = first; n < n_node; n += stride)
    if (fixed[n] == R(0)) add_start_node_shares(dirs, n, x, b, node_system, acc);
}

// x += D a at free node n.
template <class R>
__device__ __forceinline__ void start_move(const StartDirections<R>& dirs, int n, const double (&a)[kStartDirections],
                                           R* x) {
  for (int k = 0; k < 3; ++k) {
    double s = double(x[3 * n + k]);
#pragma unroll
    for (int j = 0; j < kStartDirections; ++j)
      s += a[j] * double(ops::newmark_start_direction(j, dirs.dt, dirs.v_prev, dirs.v_before, 3 * n + k));
    x[3 * n + k] = R(s);
  }
}

// From the item's sums: x += D a at the free nodes, spread as in start_shares.
template <class R>
__device__ __forceinline__ void start_moves(const StartDirections<R>& dirs, int first, int stride, int n_cell,
                                            int n_node, const int* cell_nodes, const R* fixed,
                                            const int* node_cell_offset, const int* node_cell_entry,
                                            const double (&sums)[kStartSums], R* x) {
  double a[kStartDirections];
  ops::galerkin_coefficients<kStartDirections>(sums, ops::galerkin_cut<R>(), a);
  if (node_cell_entry) {
    for (int t = first; t < 8 * n_cell; t += stride) {
      const int m = cell_nodes[t];
      if (fixed[m] == R(0) && owns_node(t, m, node_cell_offset, node_cell_entry)) start_move(dirs, m, a, x);
    }
    return;
  }
  for (int n = first; n < n_node; n += stride)
    if (fixed[n] == R(0)) start_move(dirs, n, a, x);
}

// The start in a grid solve, after its setup: the shares, one grid sum, the moves at the own
// nodes, a grid barrier. Nothing without a start. node_cell_entry: as in start_shares.
template <class R, class NodeSystem>
__device__ __forceinline__ void newmark_grid_start(GridPcg<R>& g, const StartDirections<R>& dirs, int n_cell,
                                                   int n_node, R h, R a_k, const R* rotation, const R* cell_weights,
                                                   const int* cell_nodes, const R* lambda, const R* mu,
                                                   const R* fixed, const int* node_cell_offset,
                                                   const int* node_cell_entry, NodeSystem node_system) {
  if (!dirs.active) return;
  double sums[kStartSums];
  start_shares(dirs, g.rank, g.threads, n_cell, n_node, h, a_k, rotation, cell_weights, cell_nodes, lambda, mu, fixed,
               node_cell_offset, node_cell_entry, g.x, g.b, node_system, sums);
  g.sum(sums);
  start_moves(dirs, g.rank, g.threads, n_cell, n_node, cell_nodes, fixed, node_cell_offset, node_cell_entry, sums,
              g.x);
  grid_sync(g.bar);
}
template <class R, class NodeSystem>
__device__ __forceinline__ void newmark_grid_start(GridPcg<R>&, NoStart, int, int, R, R, const R*, const R*,
                                                   const int*, const R*, const R*, const R*, const int*, const int*,
                                                   NodeSystem) {}

// The start in the host-driven sequence (after newmark_setup): one block per batch item.
template <class R, class Damping>
__device__ __forceinline__ void newmark_start_item(int i, const ops::NewmarkCoefficients<R>& c,
                                                   const StartDirections<R>& dirs, int n_cell, int n_node, R h,
                                                   const R* rotation, const R* cell_weights, const int* cell_nodes,
                                                   const R* lambda, const R* mu, const R* mass, const R* fixed,
                                                   Damping damping, const R* b, R* x) {
  auto node_system = [&](int n, Vec3<R> e) { return newmark_node_apply(c, mass, damping, n, e, zero3<R>()); };
  double sums[kStartSums];
  start_shares(dirs, i, SSC_ITEM, n_cell, n_node, h, c.a_k, rotation, cell_weights, cell_nodes, lambda, mu, fixed,
               nullptr, nullptr, x, b, node_system, sums);
  block_sum<kStartSums>(sums);
  start_moves(dirs, i, SSC_ITEM, n_cell, n_node, cell_nodes, fixed, nullptr, nullptr, sums, x);
}

// A grid solve's setup (newmark_diag and newmark_setup of the host-driven sequence): the
// corners of the stiffness diagonal, a grid barrier, per node the Jacobi diagonal, the
// masked right-hand side and x's start (ops::NewmarkXStart), a grid barrier.
template <class R, class Damping>
__device__ __forceinline__ void newmark_grid_setup(GridPcg<R>& g, const ops::NewmarkCoefficients<R>& c, int n_cell,
                                                   int n_node, R h, const R* rotation, const R* cell_weights,
                                                   const int*, const R* lambda, const R* mu, const R* mass,
                                                   const R* fixed, Damping damping, const int* node_cell_offset,
                                                   const int* node_cell_entry, const R* rhs, int x_start,
                                                   R* x_before, R* b, R* inv_diag, R* corner) {
  for (int t = g.rank; t < 8 * n_cell; t += g.threads)
    newmark_diagonal_corner(t, h, rotation, cell_weights, lambda, mu, corner);
  grid_sync(g.bar);
  for (int n = g.rank; n < n_node; n += g.threads)
    newmark_setup(n, c, mass, fixed, damping, corner, node_cell_offset, node_cell_entry, rhs, x_start, g.x, x_before, b,
                  inv_diag);
  grid_sync(g.bar);
}

// The time-step system (A + C on the free nodes, identity on fixed ones) in one kernel, two
// phases per iteration, for throughput (threads loop over several cell corners; batches of
// more than one): the node update (w = A u gathered from the corners; s, p, x, r and u =
// M^-1 r stored; gamma, |r|^2 and delta's node part of the new u), a grid barrier, the
// corners of A u with u read at each corner's node (one vector, where evaluating it from the
// last r, w and s would read three) and delta's corner part, the reduction. delta = w.u is
// summed as a_k (corner force . u) over the corners plus the node terms (a_m m u + C u) . u
// over the nodes (a fixed node's u is 0), so the reduction can follow the cell phase and no w
// is stored.
template <class R, class Damping, class Start>
__device__ __forceinline__ void newmark_pcg_grid(GridPcg<R>& g, const ops::NewmarkCoefficients<R>& c, int n_cell,
                                                 int n_node, R h, const R* rotation, const R* cell_weights,
                                                 const int* cell_nodes, const R* lambda, const R* mu, const R* mass,
                                                 const R* fixed, Damping damping, const int* node_cell_offset,
                                                 const int* node_cell_entry, R* corner, Start directions) {
  const int rank = g.rank, threads = g.threads, lanes = 8 * n_cell, lanes_warps = (lanes + 31) / 32 * 32;
  // What the element apply of the thread's first kCachedCorners cell corners reads that stays
  // fixed for the solve, in shared memory: from global memory every iteration read it again
  // after a grid barrier's acquire (measured 6-7 % faster at batch 32 in shared memory,
  // docs/benchmarks.md). A cell's 8 lanes are 8 threads of one block in every pass, so the
  // cell's values are kept once (by its first lane).
  constexpr int kCachedCorners = 10, kCells = SSC_GRID / 8;
  __shared__ int s_node[kCachedCorners][SSC_GRID];
  __shared__ R s_weight[kCachedCorners][SSC_GRID];
  __shared__ R s_cell[kCachedCorners][kCells][11];  // rotation (9), lambda, mu
  const int tid = threadIdx.x;
  for (int k = 0, t = rank; k < kCachedCorners && t < lanes_warps; ++k, t += threads) {
    const bool valid = t < lanes;
    s_node[k][tid] = valid ? cell_nodes[t] : 0;
    s_weight[k][tid] = cell_weights[valid ? t : (t & 7)];
    if ((tid & 7) == 0) {
      const int e = valid ? t >> 3 : 0;
      for (int j = 0; j < 9; ++j) s_cell[k][tid >> 3][j] = rotation[9 * e + j];
      s_cell[k][tid >> 3][9] = lambda[e];
      s_cell[k][tid >> 3][10] = mu[e];
    }
  }
  __syncthreads();
  auto node_at = [&](int k, int t) { return t >= lanes ? 0 : k < kCachedCorners ? s_node[k][tid] : cell_nodes[t]; };
  auto element_at = [&](int k, int t) {
    if (k >= kCachedCorners) return CornerElement<R>(t, t < lanes, rotation, cell_weights, lambda, mu);
    const R* v = s_cell[k][tid >> 3];
    Mat3<R> m;
#pragma unroll
    for (int i = 0; i < 3; ++i)
#pragma unroll
      for (int j = 0; j < 3; ++j) m.m[i][j] = v[3 * i + j];
    return CornerElement<R>(t, m, s_weight[k][tid], v[9], v[10]);
  };
  // The corner entries of the thread's first kCachedNodes nodes, in shared memory too (a node
  // in more than 8 cells, none on a hexahedral grid, reads its own from global memory).
  constexpr int kCachedNodes = 3;
  __shared__ int s_entries[kCachedNodes][SSC_GRID];
  __shared__ int s_entry[kCachedNodes][8][SSC_GRID];
  for (int k = 0, n = rank; k < kCachedNodes && n < n_node; ++k, n += threads) {
    const int first = node_cell_offset[n];
    const int entries = node_cell_offset[n + 1] - first;
    s_entries[k][tid] = entries;
#pragma unroll
    for (int j = 0; j < 8; ++j) s_entry[k][j][tid] = j < entries ? node_cell_entry[first + j] : 0;
  }
  __syncthreads();
  // K e at node n, the thread's k-th.
  auto gather = [&](int k, int n) {
    const int entries = k < kCachedNodes ? s_entries[k][tid] : 9;
    if (entries > 8) return ops::gather_corner_sum(corner, node_cell_offset, node_cell_entry, n);
    Vec3<R> kp = zero3<R>();
#pragma unroll
    for (int j = 0; j < 8; ++j)
      if (j < entries) kp += load3(corner, s_entry[k][j][tid]);
    return kp;
  };
  // (A + C) e at node n given K e there.
  auto system = [&](int n, Vec3<R> e, Vec3<R> ke) {
    return fixed[n] != R(0) ? e : newmark_node_apply(c, mass, damping, n, e, ke);
  };
  // The corners of A e for the nodal values e in `from`; a_k (corner force . e) into delta.
  // The next corner's e is loaded before this one's element apply.
  auto cells = [&](const R* from, double& delta) {
    Vec3<R> e = rank < lanes_warps ? load3(from, node_at(0, rank)) : zero3<R>();
    for (int k = 0, t = rank; t < lanes_warps; ++k, t += threads) {  // whole warps stay in the loop
      const int t_next = t + threads;
      const Vec3<R> e_next = t_next < lanes_warps ? load3(from, node_at(k + 1, t_next)) : zero3<R>();
      const Vec3<R> y = element_at(k, t).apply(h, e);
      if (t < lanes) {
        store3(corner, t, y);
        add_corner_delta(delta, c.a_k, y, e);
      }
      e = e_next;
    }
  };
  // Node n's sums of the new r and u: gamma, delta's node part, |r|^2.
  auto node_sums = [&](int n, Vec3<R> rn, Vec3<R> un, double (&acc)[3]) {
    add_pcg_sums(acc, rn, un, system(n, un, zero3<R>()));
  };
  newmark_grid_start(g, directions, n_cell, n_node, h, c.a_k, rotation, cell_weights, cell_nodes, lambda, mu, fixed,
                     node_cell_offset, static_cast<const int*>(nullptr),
                     [&](int n, Vec3<R> e) { return newmark_node_apply(c, mass, damping, n, e, zero3<R>()); });
  double unused = 0;
  cells(g.x, unused);
  grid_sync(g.bar);
  double sums[4] = {0, 0, 0, 0};
  for (int k = 0, n = rank; n < n_node; ++k, n += threads) {
    const Vec3<R> bn = load3(g.b, n), rn = bn - system(n, load3(g.x, n), gather(k, n));
    const Vec3<R> un = times(load3(g.inv_diag, n), rn);
    store3(g.r, n, rn);
    store3(g.z, n, un);
    store3(g.s, n, zero3<R>());
    store3(g.p, n, zero3<R>());
    double acc[3] = {0, 0, 0};
    node_sums(n, rn, un, acc);
    for (int k = 0; k < 3; ++k) sums[k] += acc[k];
    for (int k = 0; k < 3; ++k) sums[3] += double(bn[k]) * double(bn[k]);
  }
  grid_sync(g.bar);
  cells(g.z, sums[1]);
  g.sum(sums);
  const double start[3] = {sums[0], sums[1], sums[2]};
  grid_loop(g, n_node, start, sums[3], [&](double (&acc)[3]) {
    for (int k = 0, n = rank; n < n_node; ++k, n += threads) {
      const Vec3<R> inv = load3(g.inv_diag, n), um = load3(g.z, n);
      const Vec3<R> sn = system(n, um, gather(k, n)) + g.beta * load3(g.s, n);
      const Vec3<R> pn = um + g.beta * load3(g.p, n);
      const Vec3<R> rn = load3(g.r, n) - g.step * sn;
      const Vec3<R> un = times(inv, rn);
      store3(g.x, n, load3(g.x, n) + g.step * pn);
      store3(g.s, n, sn);
      store3(g.p, n, pn);
      store3(g.r, n, rn);
      store3(g.z, n, un);
      node_sums(n, rn, un, acc);
    }
    grid_sync(g.bar);
    cells(g.z, acc[1]);
  });
}

// Where a corner lane's node is and who owns it (the part of CornerLane kept in registers).
struct LaneIncidence {
  int node, entries, entry[8];
  bool valid, fixed, owner;
};

// What a corner lane of the one-phase solve reads that stays fixed for the whole solve: its
// cell's element, its node with the node's Jacobi diagonal, mass and fixed flag, whether the
// lane owns the node (the node's first corner entry, node_cell_entry[node_cell_offset[n]]),
// and the node's corner entries (up to 8; more are read from the arrays).
template <class R>
struct CornerLane : LaneIncidence {
  CornerElement<R> element;
  Vec3<R> inv;
  R mass;
  __device__ __forceinline__ CornerLane(int t, int lanes, const R* rotation, const R* cell_weights,
                                        const R* lambda, const R* mu, const int* cell_nodes, const R* inv_diag,
                                        const R* masses, const R* fixed_flags, const int* node_cell_offset,
                                        const int* node_cell_entry)
      : element(t, t < lanes, rotation, cell_weights, lambda, mu) {
    valid = t < lanes;
    node = valid ? cell_nodes[t] : 0;
    inv = load3(inv_diag, node);
    mass = masses[node];
    fixed = fixed_flags[node] != R(0);
    const int first = node_cell_offset[node];
    entries = node_cell_offset[node + 1] - first;
#pragma unroll
    for (int k = 0; k < 8; ++k) entry[k] = k < entries ? node_cell_entry[first + k] : 0;
    owner = valid && node_cell_entry[first] == t;
  }
  __device__ __forceinline__ CornerLane(const LaneIncidence& at, const CornerElement<R>& element_, Vec3<R> inv_,
                                        R mass_)
      : LaneIncidence(at), element(element_), inv(inv_), mass(mass_) {}
  // K e at the lane's node from a corner buffer (ops::gather_corner_sum's order).
  __device__ __forceinline__ Vec3<R> gather(const R* from, const int* node_cell_offset,
                                            const int* node_cell_entry) const {
    if (entries > 8) return ops::gather_corner_sum(from, node_cell_offset, node_cell_entry, node);
    Vec3<R> kp = zero3<R>();
#pragma unroll
    for (int k = 0; k < 8; ++k)
      if (k < entries) kp += load3(from, entry[k]);
    return kp;
  }
};

// The same solve with one phase per iteration, for latency (a thread per cell corner; batch 1
// on the dragon). The corner forces of A u are not gathered into w after a barrier: every
// corner lane gathers them at its own node from the previous phase's corner buffer, forms
// w, s, r and u there itself and applies the element to u, so an iteration is one phase and
// the reduction's barrier. The node's first corner lane owns it and stores its r, s, p and
// x; the others compute the same values with the same code. delta = w.u is summed as
// a_k (corner force . u) over the corner lanes of free nodes plus the node terms
// (a_m m u + C u) . u over the owners: the same sum in exact arithmetic as the two-phase
// form's, in another order. r, s and the corner forces alternate between two buffers (read
// at other nodes while owners write the next ones); u = M^-1 r is not stored. The thread's
// first corner lane stays in registers for the whole solve; further ones (small grids) are
// read each phase.
template <class R, class Damping, class Start>
__device__ __forceinline__ void newmark_pcg_grid_one_phase(GridPcg<R>& g, const ops::NewmarkCoefficients<R>& c,
                                                           int n_cell, int n_node, R h, const R* rotation,
                                                           const R* cell_weights, const int* cell_nodes,
                                                           const R* lambda, const R* mu, const R* mass,
                                                           const R* fixed, Damping damping,
                                                           const int* node_cell_offset, const int* node_cell_entry,
                                                           R* corner, R* corner2, R* r2, R* s2, Start directions) {
  const int rank = g.rank, threads = g.threads, lanes = 8 * n_cell, lanes_warps = (lanes + 31) / 32 * 32;
  auto lane = [&](int t) {
    return CornerLane<R>(t, lanes, rotation, cell_weights, lambda, mu, cell_nodes, g.inv_diag, mass, fixed,
                         node_cell_offset, node_cell_entry);
  };
  // The thread's first corner lane: its incidence in registers, its element, Jacobi diagonal
  // and mass in shared memory (a cell's values once, by its first lane). Kept in registers
  // for the whole solve, they pushed the kernel into spills.
  __shared__ R s_cell[SSC_GRID / 8][11];  // rotation (9), lambda, mu
  __shared__ R s_lane[SSC_GRID][5];       // weight, inv (3), mass
  const int tid = threadIdx.x;
  LaneIncidence own_at;
  {
    const CornerLane<R> L = lane(rank);
    own_at = L;
    if ((tid & 7) == 0) {
#pragma unroll
      for (int i = 0; i < 3; ++i)
#pragma unroll
        for (int j = 0; j < 3; ++j) s_cell[tid >> 3][3 * i + j] = L.element.rotation.m[i][j];
      s_cell[tid >> 3][9] = L.element.lambda;
      s_cell[tid >> 3][10] = L.element.mu;
    }
    const R v[5] = {L.element.weight, L.inv.x, L.inv.y, L.inv.z, L.mass};
#pragma unroll
    for (int k = 0; k < 5; ++k) s_lane[tid][k] = v[k];
  }
  __syncthreads();
  auto own = [&]() {
    const R* cv = s_cell[tid >> 3];
    const R* lv = s_lane[tid];
    Mat3<R> m;
#pragma unroll
    for (int i = 0; i < 3; ++i)
#pragma unroll
      for (int j = 0; j < 3; ++j) m.m[i][j] = cv[3 * i + j];
    return CornerLane<R>(own_at, CornerElement<R>(rank, m, lv[0], cv[9], cv[10]), make_vec3(lv[1], lv[2], lv[3]),
                         lv[4]);
  };
  // (A + C) e at the lane's node given K e there.
  auto system = [&](const CornerLane<R>& L, Vec3<R> e, Vec3<R> ke) {
    return L.fixed ? e : add_damping(ops::newmark_system_apply(c, L.mass, e, ke), damping, L.node, e);
  };
  // What a lane's phase reads of other lanes' results before it knows the iteration's step
  // and beta: K e at its node from the corner buffer `in`, and the node's r and s from r_in and
  // s_in (at the start: b and x).
  struct Loads {
    Vec3<R> ke, r, s;
  };
  auto fetch = [&](const CornerLane<R>& L, bool start, const R* in, const R* r_in, const R* s_in) {
    const int m = L.node;
    return Loads{L.gather(in, node_cell_offset, node_cell_entry), load3(start ? g.b : r_in, m),
                 load3(start ? g.x : s_in, m)};
  };
  // One lane of a phase from its loads f: start (r = b - A x, s = p = 0) or an iteration
  // (w = A u and u = M^-1 r; s, p, r, x updated with the step and beta of g); then u = M^-1 r,
  // the corners of A u into `out`, and the sums {r.u, (A u).u, r.r} (start: and b.b in
  // acc[3]) into acc.
  auto work = [&](int t, const CornerLane<R>& L, bool start, const Loads& f, R* out, R* r_out, R* s_out,
                  double (&acc)[4]) {
    const int m = L.node;
    Vec3<R> sn = zero3<R>(), pn = zero3<R>(), rn;
    if (start) {
      rn = f.r - system(L, f.s, f.ke);
    } else {
      const Vec3<R> um = times(L.inv, f.r);
      sn = system(L, um, f.ke) + g.beta * f.s;
      rn = f.r - g.step * sn;
      if (L.owner) pn = um + g.beta * load3(g.p, m);
    }
    const Vec3<R> un = times(L.inv, rn);
    const Vec3<R> y = L.element.apply(h, un);
    if (!L.valid) return;
    store3(out, t, y);
    if (!L.fixed) add_corner_delta(acc[1], c.a_k, y, un);
    if (!L.owner) return;
    store3(r_out, m, rn);
    store3(s_out, m, sn);
    store3(g.p, m, pn);
    if (!start) store3(g.x, m, load3(g.x, m) + g.step * pn);
    add_pcg_sums(acc, rn, un, system(L, un, zero3<R>()));
    if (start)
      for (int k = 0; k < 3; ++k) acc[3] += double(f.r[k]) * double(f.r[k]);
  };
  // t == rank on every thread of a warp at once (the first pass), so the branch is uniform. The
  // own lane's loads come in own_loads (fetched inside the grid sum before, GridPcg::sum);
  // further lanes fetch theirs here.
  auto phase = [&](bool start, const Loads& own_loads, const R* in, R* out, const R* r_in, const R* s_in, R* r_out,
                   R* s_out, double (&acc)[4]) {
    for (int t = rank; t < lanes_warps; t += threads) {  // whole warps stay in the loop
      if (t == rank) {
        work(t, own(), start, own_loads, out, r_out, s_out, acc);
      } else {
        const CornerLane<R> L = lane(t);
        work(t, L, start, fetch(L, start, in, r_in, s_in), out, r_out, s_out, acc);
      }
    }
  };
  newmark_grid_start(g, directions, n_cell, n_node, h, c.a_k, rotation, cell_weights, cell_nodes, lambda, mu, fixed,
                     node_cell_offset, node_cell_entry,
                     [&](int n, Vec3<R> e) { return newmark_node_apply(c, mass, damping, n, e, zero3<R>()); });
  // The corners of A x.
  for (int t = rank; t < lanes_warps; t += threads) {
    const CornerLane<R> L = t == rank ? own() : lane(t);
    const Vec3<R> y = L.element.apply(h, load3(g.x, L.node));
    if (L.valid) store3(corner, t, y);
  }
  grid_sync(g.bar);
  R *c_in = corner2, *c_out = corner, *r_in = g.r, *r_out = r2, *s_in = g.s, *s_out = s2;
  Loads own_loads = fetch(own(), true, corner, nullptr, nullptr);
  auto fetch_own = [&]() { own_loads = fetch(own(), false, c_in, r_in, s_in); };
  double sums[4] = {0, 0, 0, 0};
  phase(true, own_loads, corner, corner2, nullptr, nullptr, g.r, g.s, sums);
  g.sum(sums, fetch_own);
  const double start[3] = {sums[0], sums[1], sums[2]};
  grid_loop(
      g, n_node, start, sums[3],
      [&](double (&acc)[3]) {
        double a4[4] = {0, 0, 0, 0};
        phase(false, own_loads, c_in, c_out, r_in, s_in, r_out, s_out, a4);
        for (int k = 0; k < 3; ++k) acc[k] = a4[k];
        swap_pointers(c_in, c_out);
        swap_pointers(r_in, r_out);
        swap_pointers(s_in, s_out);
      },
      fetch_own);
}

// The band solves' incidence: the thread's first band node keeps its degree and
// neighbours in registers.
struct BandIncidence {
  const int* neighbors;
  const int* degrees;
  int rank;
  int own_nb[6];
  int own_degree;

  __device__ __forceinline__ BandIncidence(const int* band_neighbors, const int* band_degree, int n_band,
                                           int thread_rank)
      : neighbors(band_neighbors), degrees(band_degree), rank(thread_rank) {
#pragma unroll
    for (int d = 0; d < 6; ++d) own_nb[d] = rank < n_band ? neighbors[6 * rank + d] : -1;
    own_degree = rank < n_band ? degrees[rank] : 0;
  }
  __device__ __forceinline__ int degree(int m) const { return m == rank ? own_degree : degrees[m]; }
  // L e at band node n for the nodal values e = value(source, node); e(n) into en
  // (extension_apply).
  template <class R, class Value>
  __device__ __forceinline__ Vec3<R> laplacian(int n, int source, const Value& value, Vec3<R>& en) const {
    const bool mine = n == rank;
    en = value(source, n);
    Vec3<R> s = R(mine ? own_degree : degrees[n]) * en;
#pragma unroll
    for (int d = 0; d < 6; ++d) {
      const int nb = mine ? own_nb[d] : neighbors[6 * n + d];
      if (nb >= 0) s -= value(source, nb);
    }
    return s;
  }
};

// The start of a band solve on the vectors r, s, w (L over value(source, node)).
template <class R, class Value>
__device__ __forceinline__ double band_start(GridPcg<R>& g, const BandIncidence& band, int n_band, const Value& value,
                                             R* r, R* s, R* w, double (&start)[3]) {
  double bb = grid_start_residual(g, n_band, r, s, [&](int n) {
    Vec3<R> xn;
    return band.laplacian(n, kSourceX, value, xn);
  });
  grid_start_sums(
      g, n_band, r, w, [&](int n, Vec3<R>& un) { return band.laplacian(n, kSourceU, value, un); }, bb, start);
  return bb;
}

// The band Laplacian L e(n) = deg(n) e(n) - sum of e over the band neighbours: one phase
// per iteration, each thread evaluating u at its node's neighbours (next_u), so r, w, s
// alternate between two buffers (r, r2 and so on: neighbours read the previous
// iteration's while owners write the next).
template <class R>
__device__ __forceinline__ void extension_pcg_grid(GridPcg<R>& g, int n_band, const int* band_neighbors,
                                                   const int* band_degree, R* r2, R* w2, R* s2) {
  R *r_now = g.r, *w_now = g.w, *s_now = g.s, *r_next = r2, *w_next = w2, *s_next = s2;
  auto value = [&](int source, int m) {
    return source == kSourceX ? load3(g.x, m) : source == kSourceU ? load3(g.z, m) : g.next_u(r_now, w_now, s_now, m);
  };
  const BandIncidence band(band_neighbors, band_degree, n_band, g.rank);
  double start[3];
  const double bb = band_start(g, band, n_band, value, r_now, s_now, w_now, start);
  grid_loop(g, n_band, start, bb, [&](double (&acc)[3]) {
    for (int n = g.rank; n < n_band; n += g.threads) {
      Vec3<R> u_own;
      const Vec3<R> wn = band.laplacian(n, kSourceNextU, value, u_own);
      grid_own_update(
          g, n, r_now, w_now, s_now, r_next, w_next, s_next, [&](int, Vec3<R>) { return wn; }, acc);
    }
    swap_pointers(r_now, r_next);
    swap_pointers(w_now, w_next);
    swap_pointers(s_now, s_next);
  });
}

// The same solve for throughput, when each thread owns several band nodes (large
// batches): two phases per iteration, the own-node update (s, p, x, r) and, after a grid
// barrier, w = L u with u = M^-1 r read at the neighbours, then the reduction. Neighbours
// read one stored vector instead of evaluating u from three, no vector is double
// buffered, and the Jacobi diagonal 1/deg comes from the degree: per node five vectors
// (x, r, w, s, p) instead of ten, so a batch's solver state stays in L2. Every value is
// the same expression as in extension_pcg_grid, so both give the same bits.
template <class R>
__device__ __forceinline__ void extension_pcg_grid_two_phase(GridPcg<R>& g, int n_band, const int* band_neighbors,
                                                             const int* band_degree) {
  const BandIncidence band(band_neighbors, band_degree, n_band, g.rank);
  // M^-1 = 1 / deg as a vector (extension_setup's inv_diag, the same bits).
  auto inv_diag = [&](int m) {
    const R d = R(1) / R(band.degree(m));
    return make_vec3(d, d, d);
  };
  auto value = [&](int source, int m) {
    return source == kSourceX ? load3(g.x, m) : times(inv_diag(m), load3(g.r, m));
  };
  double start[3];
  const double bb = band_start(g, band, n_band, value, g.r, g.s, g.w, start);
  grid_loop(g, n_band, start, bb, [&](double (&acc)[3]) {
    for (int n = g.rank; n < n_band; n += g.threads) {
      const Vec3<R> inv = inv_diag(n), rn_old = load3(g.r, n);
      const Vec3<R> sn = load3(g.w, n) + g.beta * load3(g.s, n);
      const Vec3<R> pn = times(inv, rn_old) + g.beta * load3(g.p, n);
      store3(g.x, n, load3(g.x, n) + g.step * pn);
      store3(g.s, n, sn);
      store3(g.p, n, pn);
      store3(g.r, n, rn_old - g.step * sn);
    }
    grid_sync(g.bar);
    for (int n = g.rank; n < n_band; n += g.threads) {
      Vec3<R> un;
      const Vec3<R> wn = band.laplacian(n, kSourceU, value, un);
      const Vec3<R> rn = load3(g.r, n);
      store3(g.w, n, wn);
      add_pcg_sums(acc, rn, un, wn);
    }
  });
}

}  // namespace gen
}  // namespace ssc
