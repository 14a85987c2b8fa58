// Pieces shared by the interpreter's forward and adjoint executors: tensor binding,
// the matrix-free Newmark system (a_m M + a_k R K R^T with fixed nodes eliminated) and
// the band Laplacian of the displacement extension, both solved by Jacobi-PCG.
#pragma once
#include <vector>

#include "graph/graph.h"
#include "runtime/static_arrays.h"
#include "ops/contact.h"
#include "ops/corotation.h"
#include "ops/elasticity.h"
#include "ops/gather.h"
#include "ops/newmark.h"
#include "runtime/pcg.h"
#include "runtime/tensor_store.h"

namespace ssc {

template <class Real>
struct Binder {
  TensorStore<Real>& store;
  const OpNode& op;
  int b;
  const Real* in(const char* slot) const { return store.data(op.input(slot), b); }
  Real* out(const char* slot) const { return store.data(op.output(slot), b); }
  Real scalar(const char* slot, int k = 0) const { return in(slot)[k]; }
  bool has_input(const char* slot) const {
    for (const OpArg& a : op.inputs)
      if (a.slot == slot) return true;
    return false;
  }
};

// The ground planes packed 6 per plane (normal, height, stiffness, alpha); returns the count.
template <class Real>
inline int load_ground_planes(const TensorStore<Real>& store, const OpNode& op, int b, ops::GroundPlane<Real>* planes) {
  const int tensor = op.input("ground_planes");
  const int count = int(store.stride(tensor) / 6);
  const Real* q = store.data(tensor, b);
  for (int p = 0; p < count; ++p, q += 6) planes[p] = {make_vec3(q[0], q[1], q[2]), q[3], q[4], q[5]};
  return count;
}

// Per-corner K p for every cell (the matrix-free stiffness product).
template <class Real>
inline void stiffness_apply_cells(const StaticArrays& g, const Real* rotation, const Real* weights, Real lambda, Real mu,
                                  const Real* p, Real* corner_out) {
  const Real h = Real(g.h);
#pragma omp parallel for schedule(static) if (g.cell_count >= kCellParallelThreshold)
  for (int e = 0; e < g.cell_count; ++e) ops::stiffness_apply_cell(e, rotation, weights, lambda, mu, h, p, g.cell_nodes.data(), corner_out);
}

// Node sums of per-corner vectors: out[i] (+)= sum over the corners touching node i.
template <class Real>
inline void gather_corners_to_nodes(const StaticArrays& g, const Real* corner, Real* out, bool accumulate) {
#pragma omp parallel for schedule(static) if (g.node_count >= kParallelThreshold)
  for (int i = 0; i < g.node_count; ++i) {
    const Vec3<Real> s = ops::gather_corner_sum(corner, g.node_cell_offset.data(), g.node_cell_entry.data(), i);
    if (accumulate)
      add3(out, i, s);
    else
      store3(out, i, s);
  }
}

// The SPD time-step system with fixed nodes eliminated (identity rows and columns).
template <class Real>
struct NewmarkSystem {
  const StaticArrays& g;
  const std::vector<Real>& weights;
  const Real* rotation;
  Real lambda, mu;
  const Real* mass;
  const Real* fixed;
  ops::NewmarkCoefficients<Real> c;

  bool is_fixed(int i) const { return fixed[i] != Real(0); }

  void apply(const Real* p, Real* q, std::vector<Real>& corner) const {
    stiffness_apply_cells(g, rotation, weights.data(), lambda, mu, p, corner.data());
#pragma omp parallel for schedule(static) if (g.node_count >= kParallelThreshold)
    for (int i = 0; i < g.node_count; ++i) {
      const Vec3<Real> kp = ops::gather_corner_sum(corner.data(), g.node_cell_offset.data(), g.node_cell_entry.data(), i);
      store3(q, i, is_fixed(i) ? load3(p, i) : ops::newmark_system_apply(c, mass[i], load3(p, i), kp));
    }
  }

  // Solves A x = rhs (fixed entries of rhs ignored, x starts from its content).
  PcgResult solve(const Real* rhs, Real* x, double tolerance, int max_iterations) const {
    const Real h = Real(g.h);
    const long n = 3L * g.node_count;
    std::vector<Real> corner(24 * size_t(g.cell_count)), inv_diag(n), b(n);
#pragma omp parallel for schedule(static) if (g.cell_count >= kCellParallelThreshold)
    for (int e = 0; e < g.cell_count; ++e) {
      Vec3<Real> d[8];
      ops::corotated_diagonal(ops::load_mat3(rotation, e), weights.data() + 8 * e, lambda, mu, h, d);
      for (int k = 0; k < 8; ++k) store3(corner.data(), 8 * e + k, d[k]);
    }
    for (int i = 0; i < g.node_count; ++i) {
      const Vec3<Real> kd = ops::gather_corner_sum(corner.data(), g.node_cell_offset.data(), g.node_cell_entry.data(), i);
      const Vec3<Real> d = ops::newmark_system_apply(c, mass[i], make_vec3(Real(1), Real(1), Real(1)), kd);
      for (int k = 0; k < 3; ++k) {
        inv_diag[3 * i + k] = is_fixed(i) ? Real(1) : Real(1) / d[k];
        b[3 * i + k] = is_fixed(i) ? Real(0) : rhs[3 * i + k];
        if (is_fixed(i)) x[3 * i + k] = Real(0);
      }
    }
    auto op = [&](const Real* p, Real* q) { apply(p, q, corner); };
    return jacobi_pcg<Real>(n, op, inv_diag.data(), b.data(), x, tolerance, max_iterations);
  }
};

// Solves the band Laplacian L x = rhs (3 components; x starts from its content).
template <class Real>
inline PcgResult solve_band_laplacian(const StaticArrays& g, const Real* rhs, Real* x, double tolerance, int max_iterations) {
  const long n = 3L * g.band_count;
  std::vector<Real> inv_diag(n);
  for (int i = 0; i < g.band_count; ++i)
    for (int k = 0; k < 3; ++k) inv_diag[3 * i + k] = Real(1) / Real(g.band_degree[i]);
  auto apply = [&](const Real* p, Real* q) {
#pragma omp parallel for schedule(static) if (g.band_count >= kParallelThreshold)
    for (int i = 0; i < g.band_count; ++i) {
      Vec3<Real> s = Real(g.band_degree[i]) * load3(p, i);
      for (int d = 0; d < 6; ++d) {
        const int nb = g.band_neighbors[6 * i + d];
        if (nb >= 0) s -= load3(p, nb);
      }
      store3(q, i, s);
    }
  };
  return jacobi_pcg<Real>(n, apply, inv_diag.data(), rhs, x, tolerance, max_iterations);
}

}  // namespace ssc
