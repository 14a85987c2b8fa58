// The per-index parts of the corotated cell ops, one cell each, called alike by the
// interpreter (runtime/) and the generated kernels (codegen/): the cell's rotation from the
// polar decomposition of its deformation gradient, the corotation offset force, and the
// stiffness product K p, each with its adj_ part. Rotations are stored row-major, 9 Reals a
// cell; per-corner results 8 x 3 Reals a cell. The element math is in elasticity.h and polar.h.
#pragma once
#include "ops/elasticity.h"
#include "ops/gather.h"
#include "ops/polar.h"
#include "ops/ssc_math.h"

namespace ssc {
namespace ops {

template <class Real>
SSC_HD inline Mat3<Real> load_mat3(const Real* r, int cell) {
  Mat3<Real> m;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m.m[i][j] = r[9 * cell + 3 * i + j];
  return m;
}
template <class Real>
SSC_HD inline void store_mat3(Real* r, int cell, const Mat3<Real>& m) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r[9 * cell + 3 * i + j] = m.m[i][j];
}
template <class Real>
SSC_HD inline void add_mat3(Real* r, int cell, const Mat3<Real>& m) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r[9 * cell + 3 * i + j] += m.m[i][j];
}

// Cell i's rotation and polar status (kPolarDegenerate: the identity was taken).
template <class Real>
SSC_HD inline int corotation_cell(int i, const Real* u_prev, const int* cell_nodes, Real h, Real* rotation, Real* status) {
  Vec3<Real> uc[8];
  load_cell_corners(u_prev, cell_nodes, i, uc);
  Mat3<Real> R;
  const int s = polar_rotation(cell_deformation_gradient(uc, h), R);
  store_mat3(rotation, i, R);
  status[i] = Real(s);
  return s;
}

// The cell's corner cotangents of u_prev (corner_bar, 8 per cell; the engine gathers them to
// the nodes) from the rotation's cotangent.
template <class Real>
SSC_HD inline void adj_corotation_cell(int i, const Real* u_prev, const int* cell_nodes, Real h, const Real* rotation,
                                       const Real* status, const Real* rotation_bar, Real* corner_bar) {
  Vec3<Real> uc[8], ub[8];
  load_cell_corners(u_prev, cell_nodes, i, uc);
  for (int c = 0; c < 8; ++c) ub[c] = zero3<Real>();
  Mat3<Real> F_bar = zero33<Real>();
  adj_polar_rotation(cell_deformation_gradient(uc, h), load_mat3(rotation, i), int(status[i]), load_mat3(rotation_bar, i),
                     F_bar);
  adj_cell_deformation_gradient(F_bar, h, ub);
  for (int c = 0; c < 8; ++c) store3(corner_bar, 8 * i + c, ub[c]);
}

template <class Real>
SSC_HD inline void corotation_force_cell(int i, const Real* rotation, const Real* weights, Real lambda, Real mu, Real h,
                                         Real* corner_force) {
  Vec3<Real> fc[8];
  corotation_offset_force(load_mat3(rotation, i), weights + 8 * i, lambda, mu, h, fc);
  for (int c = 0; c < 8; ++c) store3(corner_force, 8 * i + c, fc[c]);
}

// Accumulates the rotation's cotangent; the cell's shares of the Lame cotangents go to
// lambda_bar and mu_bar (the engine sums them over the cells in a fixed order).
template <class Real>
SSC_HD inline void adj_corotation_force_cell(int i, const Real* rotation, const Real* weights, Real lambda, Real mu, Real h,
                                             const Real* corner_force_bar, Real* rotation_bar, Real& lambda_bar,
                                             Real& mu_bar) {
  Vec3<Real> fb[8];
  for (int c = 0; c < 8; ++c) fb[c] = load3(corner_force_bar, 8 * i + c);
  Mat3<Real> R_bar = zero33<Real>();
  adj_corotation_offset_force(load_mat3(rotation, i), weights + 8 * i, lambda, mu, h, fb, R_bar, lambda_bar, mu_bar);
  add_mat3(rotation_bar, i, R_bar);
}

// Per-corner K p of cell i (the matrix-free stiffness product).
template <class Real>
SSC_HD inline void stiffness_apply_cell(int i, const Real* rotation, const Real* weights, Real lambda, Real mu, Real h,
                                        const Real* p, const int* cell_nodes, Real* corner_out) {
  Vec3<Real> pc[8], y[8];
  load_cell_corners(p, cell_nodes, i, pc);
  corotated_apply(load_mat3(rotation, i), weights + 8 * i, lambda, mu, h, pc, y);
  for (int c = 0; c < 8; ++c) store3(corner_out, 8 * i + c, y[c]);
}

// Accumulates the rotation's cotangent, stores p's corner cotangents (corner_bar, 8 per cell)
// and gives the cell's Lame shares.
template <class Real>
SSC_HD inline void adj_stiffness_apply_cell(int i, const Real* rotation, const Real* weights, Real lambda, Real mu, Real h,
                                            const Real* p, const int* cell_nodes, const Real* corner_out_bar,
                                            Real* rotation_bar, Real* corner_bar, Real& lambda_bar, Real& mu_bar) {
  Vec3<Real> pc[8], yb[8], pb[8];
  load_cell_corners(p, cell_nodes, i, pc);
  for (int c = 0; c < 8; ++c) {
    yb[c] = load3(corner_out_bar, 8 * i + c);
    pb[c] = zero3<Real>();
  }
  Mat3<Real> R_bar = zero33<Real>();
  adj_corotated_apply(load_mat3(rotation, i), weights + 8 * i, lambda, mu, h, pc, yb, R_bar, lambda_bar, mu_bar, pb);
  add_mat3(rotation_bar, i, R_bar);
  for (int c = 0; c < 8; ++c) store3(corner_bar, 8 * i + c, pb[c]);
}

}  // namespace ops
}  // namespace ssc
