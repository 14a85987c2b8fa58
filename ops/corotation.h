// The per-index parts of the corotated cell ops, one cell each, called alike by the
// interpreter (runtime/) and the generated kernels (codegen/): the cell's rotation from the
// polar decomposition of its deformation gradient, the corotation offset force, and the
// stiffness product K p, each with its adj_ part. Rotations are stored row-major, 9 Reals a
// cell; per-corner results 8 x 3 Reals a cell. The element math is in elasticity.h and polar.h.
#pragma once
#include "ops/elasticity.h"
#include "ops/gather.h"
#include "ops/part.h"
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
SSC_HD inline void corotation_cell(int i, const PartContext<Real>& cx, const Real* u_prev, const int* cell_nodes,
                                   Real* rotation, Real* status) {
  Vec3<Real> uc[8];
  load_cell_corners(u_prev, cell_nodes, i, uc);
  Mat3<Real> R;
  const int s = polar_rotation(cell_deformation_gradient(uc, cx.h), R);
  store_mat3(rotation, i, R);
  status[i] = Real(s);
}

// The cell's corner cotangents of u_prev (corner_bar, 8 per cell; the engine gathers them to
// the nodes) from the rotation's cotangent.
template <class Real>
SSC_HD inline void adj_corotation_cell(int i, const PartContext<Real>& cx, const Real* u_prev, const int* cell_nodes,
                                       const Real* rotation, const Real* status, const Real* rotation_bar, Real* corner_bar) {
  const Real h = cx.h;
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
SSC_HD inline void corotation_force_cell(int i, const PartContext<Real>& cx, const Real* rotation, const Real* weights,
                                         const Real* lambda, const Real* mu, Real* corner_force) {
  Vec3<Real> fc[8];
  corotation_offset_force(load_mat3(rotation, i), weights + 8 * i, lambda[i], mu[i], cx.h, fc);
  for (int c = 0; c < 8; ++c) store3(corner_force, 8 * i + c, fc[c]);
}

// Accumulates the rotation's and the cell's Lame cotangents.
template <class Real>
SSC_HD inline void adj_corotation_force_cell(int i, const PartContext<Real>& cx, const Real* rotation, const Real* weights,
                                             const Real* lambda, const Real* mu, const Real* corner_force_bar,
                                             Real* rotation_bar, Real* lambda_bar, Real* mu_bar) {
  Vec3<Real> fb[8];
  for (int c = 0; c < 8; ++c) fb[c] = load3(corner_force_bar, 8 * i + c);
  Mat3<Real> R_bar = zero33<Real>();
  adj_corotation_offset_force(load_mat3(rotation, i), weights + 8 * i, lambda[i], mu[i], cx.h, fb, R_bar, lambda_bar[i],
                              mu_bar[i]);
  add_mat3(rotation_bar, i, R_bar);
}

// Per-corner K p of cell i (the matrix-free stiffness product).
template <class Real>
SSC_HD inline void stiffness_apply_cell(int i, const PartContext<Real>& cx, const Real* rotation, const Real* weights,
                                        const Real* lambda, const Real* mu, const Real* p, const int* cell_nodes,
                                        Real* corner_out) {
  Vec3<Real> pc[8], y[8];
  load_cell_corners(p, cell_nodes, i, pc);
  corotated_apply(load_mat3(rotation, i), weights + 8 * i, lambda[i], mu[i], cx.h, pc, y);
  for (int c = 0; c < 8; ++c) store3(corner_out, 8 * i + c, y[c]);
}

// Accumulates the rotation's and the cell's Lame cotangents and stores p's corner cotangents
// (corner_bar, 8 per cell).
template <class Real>
SSC_HD inline void adj_stiffness_apply_cell(int i, const PartContext<Real>& cx, const Real* rotation, const Real* weights,
                                            const Real* lambda, const Real* mu, const Real* p, const int* cell_nodes,
                                            const Real* corner_out_bar, Real* rotation_bar, Real* corner_bar,
                                            Real* lambda_bar, Real* mu_bar) {
  Vec3<Real> pc[8], yb[8], pb[8];
  load_cell_corners(p, cell_nodes, i, pc);
  for (int c = 0; c < 8; ++c) {
    yb[c] = load3(corner_out_bar, 8 * i + c);
    pb[c] = zero3<Real>();
  }
  Mat3<Real> R_bar = zero33<Real>();
  adj_corotated_apply(load_mat3(rotation, i), weights + 8 * i, lambda[i], mu[i], cx.h, pc, yb, R_bar, lambda_bar[i],
                      mu_bar[i], pb);
  add_mat3(rotation_bar, i, R_bar);
  for (int c = 0; c < 8; ++c) store3(corner_bar, 8 * i + c, pb[c]);
}

// The theta-scheme's elastic force with each end of the step at its own rotation
// (solver.corotation = "updated"): theta f(u) + (1 - theta) f(u-), f(u; R) = f_off(R) - K(R) u.
// The end's -theta K_k u is the system's (A u), and the right-hand side's b_k K_k u- holds
// -(1 - theta) dt K_k u-, which the (1 - theta) K_k u- here cancels; what is left of the start
// is its own force f_off(R_n) - K_n u-. A rigid rotation then strains neither end.
template <class Real>
SSC_HD inline void theta_elastic_force_cell(int i, const PartContext<Real>&, const Real* theta, const Real* start_force,
                                            const Real* start_ku, const Real* end_force, const Real* end_ku,
                                            Real* corner_force) {
  const Real t = theta[0], s = Real(1) - t;
  for (int k = 24 * i; k < 24 * i + 24; ++k)
    corner_force[k] = t * end_force[k] + s * (start_force[k] - start_ku[k] + end_ku[k]);
}

template <class Real>
SSC_HD inline void adj_theta_elastic_force_cell(int i, const PartContext<Real>&, const Real* theta,
                                                const Real* corner_force_bar, Real* start_force_bar,
                                                Real* start_ku_bar, Real* end_force_bar, Real* end_ku_bar) {
  const Real t = theta[0], s = Real(1) - t;
  for (int k = 24 * i; k < 24 * i + 24; ++k) {
    const Real b = corner_force_bar[k];
    end_force_bar[k] += t * b;
    start_force_bar[k] += s * b;
    start_ku_bar[k] -= s * b;
    end_ku_bar[k] += s * b;
  }
}

#ifdef SSC_OP_SPECS
// u- gathered at the cell's corners -> its rotation and polar status.
inline OpSpec corotation_spec() {
  OpSpec s;
  s.name = "corotation";
  s.domain = Domain::Cell;
  s.slots = {in("u_prev", Access::Gather), out("rotation"), out("polar_status")};
  s.slots.back().differentiable = false;
  s.scratch = {{"corner", Domain::Cell, 24, ""}};
  s.forward = {part("corotation", Extent::Cell, SSC_PART(corotation_cell),
                    {"u_prev^", "#cell_nodes", "rotation", "polar_status"})};
  s.adjoint = {part("corotation", Extent::Cell, SSC_ADJOINT_PART(adj_corotation_cell),
                    {"u_prev^", "#cell_nodes", "rotation", "polar_status", "d_rotation", "$corner"}),
               part("corotation_gather", Extent::Node, SSC_ADJOINT_PART(add_corner_sum),
                    {"$corner^", "#node_cell_offset", "#node_cell_entry", "d_u_prev"})};
  return s;
}

// The rotation -> the corotation offset force at the cell's corners.
inline OpSpec corotation_force_spec() {
  OpSpec s;
  s.name = "corotation_force";
  s.domain = Domain::Cell;
  s.slots = {in("rotation"), in("lambda"), in("mu"), out("corner_force")};
  s.forward = {part("corotation_force", Extent::Cell, SSC_PART(corotation_force_cell),
                    {"rotation", "#cell_weights", "lambda", "mu", "corner_force"})};
  s.adjoint = {part("corotation_force", Extent::Cell, SSC_ADJOINT_PART(adj_corotation_force_cell),
                    {"rotation", "#cell_weights", "lambda", "mu", "d_corner_force", "d_rotation", "d_lambda", "d_mu"})};
  return s;
}

// R K R^T u- at the cell's corners (the Newmark right-hand side's stiffness term).
inline OpSpec stiffness_apply_spec() {
  OpSpec s;
  s.name = "stiffness_apply";
  s.domain = Domain::Cell;
  s.slots = {in("rotation"), in("lambda"), in("mu"), in("u_prev", Access::Gather), out("ku_corner")};
  s.scratch = {{"corner", Domain::Cell, 24, ""}};
  s.forward = {part("stiffness_apply", Extent::Cell, SSC_PART(stiffness_apply_cell),
                    {"rotation", "#cell_weights", "lambda", "mu", "u_prev^", "#cell_nodes", "ku_corner"})};
  s.adjoint = {part("stiffness_apply", Extent::Cell, SSC_ADJOINT_PART(adj_stiffness_apply_cell),
                    {"rotation", "#cell_weights", "lambda", "mu", "u_prev^", "#cell_nodes", "d_ku_corner", "d_rotation",
                     "$corner", "d_lambda", "d_mu"}),
               part("stiffness_apply_gather", Extent::Node, SSC_ADJOINT_PART(add_corner_sum),
                    {"$corner^", "#node_cell_offset", "#node_cell_entry", "d_u_prev"})};
  return s;
}

// The two ends' corotation forces and stiffness products -> the step's elastic corner force.
inline OpSpec theta_elastic_force_spec() {
  OpSpec s;
  s.name = "theta_elastic_force";
  s.domain = Domain::Cell;
  s.slots = {constant_in("theta"), in("start_force"), in("start_ku"), in("end_force"), in("end_ku"),
             out("corner_force")};
  s.forward = {part("theta_elastic_force", Extent::Cell, SSC_PART(theta_elastic_force_cell),
                    {"theta", "start_force", "start_ku", "end_force", "end_ku", "corner_force"})};
  s.adjoint = {part("theta_elastic_force", Extent::Cell, SSC_ADJOINT_PART(adj_theta_elastic_force_cell),
                    {"theta", "d_corner_force", "d_start_force", "d_start_ku", "d_end_force", "d_end_ku"})};
  return s;
}
#endif

}  // namespace ops
}  // namespace ssc
