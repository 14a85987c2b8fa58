// Compressible Neo-Hookean material (material.model = "neo_hookean", the
// "nonlinear_material" extension), with the body's Lame parameters, so that it agrees with the
// corotated linear model at small strain:
//   psi(F) = mu/2 (tr(F^T F) - 3) - mu ln J + lambda/2 (ln J)^2,
//   P(F) = mu (F - F^-T) + lambda ln J F^-T,   J = det F
// (ln J continued linearly below J = 0.1, see neo_hookean_log).
// It is integrated like the linear element (ops/elasticity.h): at each cell corner v, with the
// partial-volume weight w_v and the displacement gradient G_v there, F_v = I + G_v, and the
// element's nodal vector is y_c = sum_v w_v P(F_v) grad N_c(v) (the internal force is -y).
//
// The step solves for it with the step's iterations (models/sim/timestep_graph.cpp), a
// quasi-Newton method whose matrix is symmetric positive definite by construction: iteration k
// solves the corotated linear system of the rotation R with per-cell Lame parameters scaled to
// the Neo-Hookean tangent at the iterate's theta-point x (neo_hookean_system_cell),
//   lambda_s = s lambda,  mu_s = (mu + m s) / 2,
//   s = (tr(C^-4) / 3)^(1/4)  (C = F^T F; a smooth maximum of the principal 1/stretch^2),
//   m ~ mu - lambda ln J (a smooth positive version of it, neo_hookean_system_scale),
// read off the tangent dP = mu dF + (mu - lambda ln J) F^-T dF^T F^-T + lambda (F^-T : dF) F^-T
// (both agree with the body's at F = I). The step's corner force is f = -y_NH(x) + R K_s R^T x;
// the solve takes R K_s R^T x off again implicitly (its matrix and its right-hand side's
// K_s u-). At a fixed point of the iterations
// the step's elastic force is exactly the Neo-Hookean one. A fixed-point iteration with matrix
// A converges where A^-1 (the true Jacobian) has its eigenvalues in (0, 2); the scaled
// stiffness keeps them near 1 where the corotated one (too soft by 1/stretch^2 in compression)
// does not. The Rayleigh stiffness damping uses K_s. Every quantity is differentiated, so the
// adjoint is the exact gradient of the iterations computed (at convergence, the
// implicit-function adjoint).
#pragma once
#include "ops/corotation.h"
#include "ops/elasticity.h"
#include "ops/gather.h"
#include "ops/part.h"
#include "ops/ssc_math.h"

namespace ssc {
namespace ops {

// ln J continued below J0 by its tangent, so that an iterate of the step that inverts a corner
// (J <= 0; a quasi-Newton step can overshoot) meets a finite, strongly restoring force instead
// of a NaN. A state at rest with J < J0 (90 % of a corner's volume lost) is outside the model.
constexpr double kNeoHookeanJ0 = 0.1;

template <class Real>
SSC_HD inline void neo_hookean_log(Real J, Real& L, Real& dL, Real& ddL) {
  const Real J0 = Real(kNeoHookeanJ0);
  if (J >= J0) {
    L = Real(log(J)), dL = Real(1) / J, ddL = Real(-1) / (J * J);
  } else {
    L = Real(log(J0)) + (J - J0) / J0, dL = Real(1) / J0, ddL = Real(0);
  }
}

// P = mu F + (lambda L - mu) L' cof(F)  (dJ/dF = cof F; with L = ln J: mu (F - F^-T) + lambda ln J F^-T).
template <class Real>
SSC_HD inline Mat3<Real> neo_hookean_stress(const Mat3<Real>& F, Real lambda, Real mu) {
  Real L, dL, ddL;
  neo_hookean_log(det(F), L, dL, ddL);
  return mu * F + ((lambda * L - mu) * dL) * cofactor(F);
}

// The tensor cross product A x B = cof(A + B) - cof(A) - cof(B): d cof(F)[dF] = dF x F, and
// <C, A x B> is symmetric in A, B, C, so the cotangent of F through cof is C_bar x F.
template <class Real>
SSC_HD inline Mat3<Real> tensor_cross(const Mat3<Real>& A, const Mat3<Real>& B) {
  return cofactor(A + B) - cofactor(A) - cofactor(B);
}

// Adjoint of neo_hookean_stress for P_bar, with g = (lambda L - mu) L':
//   F_bar += mu P_bar + g' <P_bar, cof F> cof F + g (P_bar x F),
//   lambda_bar += L L' <P_bar, cof F>,  mu_bar += <P_bar, F> - L' <P_bar, cof F>.
template <class Real>
SSC_HD inline void adj_neo_hookean_stress(const Mat3<Real>& F, Real lambda, Real mu, const Mat3<Real>& P_bar,
                                          Mat3<Real>& F_bar, Real& lambda_bar, Real& mu_bar) {
  Real L, dL, ddL;
  neo_hookean_log(det(F), L, dL, ddL);
  const Mat3<Real> C = cofactor(F);
  const Real pc = frobenius_dot(P_bar, C);
  const Real g = (lambda * L - mu) * dL, dg = lambda * dL * dL + (lambda * L - mu) * ddL;
  F_bar = F_bar + mu * P_bar + (dg * pc) * C + g * tensor_cross(P_bar, F);
  lambda_bar += L * dL * pc;
  mu_bar += frobenius_dot(P_bar, F) - dL * pc;
}

// Displacement gradient at corner v from its corner vectors u_v and edge neighbours' un[a]
// (ops/elasticity.h, element_corner_columns): column a = s_a (u_v - u_(v ^ (1 << a))).
template <class Real>
SSC_HD inline Mat3<Real> corner_displacement_gradient(int v, Real h, Vec3<Real> u_v, const Vec3<Real>* un) {
  Mat3<Real> G;
  for (int a = 0; a < 3; ++a) {
    const Real s = corner_bit(v, a) ? Real(1) / h : Real(-1) / h;
    const Vec3<Real> d = u_v - un[a];
    for (int i = 0; i < 3; ++i) G.m[i][a] = s * d[i];
  }
  return G;
}

// y_c = sum_v w_v P(F_v) grad N_c(v) for the corner displacements u.
template <class Real>
SSC_HD inline void neo_hookean_element(const Real* w, Real lambda, Real mu, Real h, const Vec3<Real>* u, Vec3<Real>* y) {
  for (int c = 0; c < 8; ++c) y[c] = zero3<Real>();
  for (int v = 0; v < 8; ++v) {
    if (w[v] == Real(0)) continue;
    const Vec3<Real> un[3] = {u[v ^ 1], u[v ^ 2], u[v ^ 4]};
    const Mat3<Real> P = neo_hookean_stress(identity3<Real>() + corner_displacement_gradient(v, h, u[v], un), lambda, mu);
    for (int a = 0; a < 3; ++a) {
      const Real s = (corner_bit(v, a) ? Real(1) / h : Real(-1) / h) * w[v];
      const Vec3<Real> col = s * make_vec3(P.m[0][a], P.m[1][a], P.m[2][a]);
      y[v] += col;
      y[v ^ (1 << a)] -= col;
    }
  }
}

template <class Real>
SSC_HD inline void adj_neo_hookean_element(const Real* w, Real lambda, Real mu, Real h, const Vec3<Real>* u,
                                           const Vec3<Real>* y_bar, Vec3<Real>* u_bar, Real& lambda_bar, Real& mu_bar) {
  for (int v = 0; v < 8; ++v) {
    if (w[v] == Real(0)) continue;
    const Vec3<Real> un[3] = {u[v ^ 1], u[v ^ 2], u[v ^ 4]};
    const Mat3<Real> F = identity3<Real>() + corner_displacement_gradient(v, h, u[v], un);
    Mat3<Real> P_bar = zero33<Real>();
    for (int a = 0; a < 3; ++a) {
      const Real s = (corner_bit(v, a) ? Real(1) / h : Real(-1) / h) * w[v];
      const Vec3<Real> col_bar = y_bar[v] - y_bar[v ^ (1 << a)];
      for (int i = 0; i < 3; ++i) P_bar.m[i][a] = s * col_bar[i];
    }
    Mat3<Real> F_bar = zero33<Real>();
    adj_neo_hookean_stress(F, lambda, mu, P_bar, F_bar, lambda_bar, mu_bar);
    for (int a = 0; a < 3; ++a) {
      const Real s = corner_bit(v, a) ? Real(1) / h : Real(-1) / h;
      const Vec3<Real> g = s * make_vec3(F_bar.m[0][a], F_bar.m[1][a], F_bar.m[2][a]);
      u_bar[v] += g;
      u_bar[v ^ (1 << a)] -= g;
    }
  }
}

// The cell's energy: sum_v w_v psi(F_v).
template <class Real>
SSC_HD inline Real neo_hookean_energy(const Real* w, Real lambda, Real mu, Real h, const Vec3<Real>* u) {
  Real e = Real(0);
  for (int v = 0; v < 8; ++v) {
    if (w[v] == Real(0)) continue;
    const Vec3<Real> un[3] = {u[v ^ 1], u[v ^ 2], u[v ^ 4]};
    const Mat3<Real> F = identity3<Real>() + corner_displacement_gradient(v, h, u[v], un);
    Real L, dL, ddL;
    neo_hookean_log(det(F), L, dL, ddL);
    e += w[v] * (Real(0.5) * mu * (frobenius_dot(F, F) - Real(3)) - mu * L + Real(0.5) * lambda * L * L);
  }
  return e;
}

// ---- the neo_hookean_system op: the per-cell Lame parameters of the iteration's matrix ----

// The scale's cap, reached only near a singular F (an iterate through which a cell inverts).
constexpr double kNeoHookeanSystemMaxScale = 100.0;

template <class Real>
struct NeoHookeanSystemScale {
  Real s, m;                 // the scale and the dF^T coefficient
  Mat3<Real> ds_dF, dm_dF;   // their derivatives (ds/dF zero where capped)
  Real dm_dlambda, dm_dmu;
};

// m uses neo_hookean_log's ln J, continued below J = 0.1, so that s and m are continuous in F
// for every iterate: a discontinuity would make the step a discontinuous function of the
// parameters.
template <class Real>
SSC_HD inline NeoHookeanSystemScale<Real> neo_hookean_system_scale(const Mat3<Real>& F, Real lambda, Real mu) {
  NeoHookeanSystemScale<Real> r;
  r.ds_dF = zero33<Real>();
  const Real J = det(F);
  Real L, dL, ddL;
  neo_hookean_log(J, L, dL, ddL);
  // m = mu g(x) / g(0), x = -lambda L / mu, g(x) = (1 + x + sqrt((1 + x)^2 + 4 delta)) / 2:
  // about mu - lambda ln J in compression, positive and falling in dilation, smooth.
  const Real delta = Real(0.1), x = -lambda * L / mu, q = sqrt((Real(1) + x) * (Real(1) + x) + Real(4) * delta);
  const Real g = Real(0.5) * (Real(1) + x + q), dg = Real(0.5) * (Real(1) + (Real(1) + x) / q);
  const Real g0 = Real(0.5) * (Real(1) + sqrt(Real(1) + Real(4) * delta));
  r.m = mu * g / g0;
  const Real dm_dL = -lambda * dg / g0;
  r.dm_dlambda = -L * dg / g0;
  r.dm_dmu = (g - dg * x) / g0;
  r.dm_dF = (dm_dL * dL) * cofactor(F);
  r.s = Real(kNeoHookeanSystemMaxScale);
  if (J == Real(0)) return r;
  const Mat3<Real> Fi = inverse(F), FiT = transpose(Fi);
  const Mat3<Real> B = Fi * FiT, B2 = B * B, B4 = B2 * B2;
  const Real t = trace(B4), s = sqrt(sqrt(t / Real(3)));
  if (s < r.s) {
    r.s = s;
    r.ds_dF = (Real(-2) * s / t) * (FiT * B4);
  }
  return r;
}

template <class Real>
SSC_HD inline void neo_hookean_system_cell(int i, const PartContext<Real>& cx, const Real* u_theta, const int* cell_nodes,
                                           const Real* lambda, const Real* mu, Real* lambda_system, Real* mu_system) {
  Vec3<Real> u[8];
  load_cell_corners(u_theta, cell_nodes, i, u);
  const Mat3<Real> F = cell_deformation_gradient(u, cx.h);
  const NeoHookeanSystemScale<Real> r = neo_hookean_system_scale(F, lambda[i], mu[i]);
  lambda_system[i] = r.s * lambda[i];
  mu_system[i] = Real(0.5) * (mu[i] + r.m * r.s);
}

template <class Real>
SSC_HD inline void adj_neo_hookean_system_cell(int i, const PartContext<Real>& cx, const Real* u_theta,
                                               const int* cell_nodes, const Real* lambda, const Real* mu,
                                               const Real* lambda_system_bar, const Real* mu_system_bar,
                                               Real* lambda_bar, Real* mu_bar, Real* corner_bar) {
  Vec3<Real> u[8], ub[8];
  load_cell_corners(u_theta, cell_nodes, i, u);
  const Mat3<Real> F = cell_deformation_gradient(u, cx.h);
  const NeoHookeanSystemScale<Real> r = neo_hookean_system_scale(F, lambda[i], mu[i]);
  const Real lsb = lambda_system_bar[i], msb = mu_system_bar[i];
  const Real s_bar = lambda[i] * lsb + Real(0.5) * r.m * msb, m_bar = Real(0.5) * r.s * msb;
  lambda_bar[i] += r.s * lsb + m_bar * r.dm_dlambda;
  mu_bar[i] += Real(0.5) * msb + m_bar * r.dm_dmu;
  for (int c = 0; c < 8; ++c) ub[c] = zero3<Real>();
  adj_cell_deformation_gradient(s_bar * r.ds_dF + m_bar * r.dm_dF, cx.h, ub);
  for (int c = 0; c < 8; ++c) store3(corner_bar, 8 * i + c, ub[c]);
}

#ifdef SSC_OP_SPECS
inline OpSpec neo_hookean_system_spec() {
  OpSpec s;
  s.name = "neo_hookean_system";
  s.domain = Domain::Cell;
  s.slots = {in("u_theta", Access::Gather), in("lambda"), in("mu"), out("lambda_system"), out("mu_system")};
  s.scratch = {{"corner", Domain::Cell, 24, ""}};
  s.forward = {part("neo_hookean_system", Extent::Cell, SSC_PART(neo_hookean_system_cell),
                    {"u_theta^", "#cell_nodes", "lambda", "mu", "lambda_system", "mu_system"})};
  s.adjoint = {part("neo_hookean_system", Extent::Cell, SSC_ADJOINT_PART(adj_neo_hookean_system_cell),
                    {"u_theta^", "#cell_nodes", "lambda", "mu", "d_lambda_system", "d_mu_system", "d_lambda", "d_mu",
                     "$corner"}),
               part("neo_hookean_system_gather", Extent::Node, SSC_ADJOINT_PART(add_corner_sum),
                    {"$corner^", "#node_cell_offset", "#node_cell_entry", "d_u_theta"})};
  return s;
}
#endif

// ---- the neo_hookean_correction op: the step's corner force, -y_NH(x) + R K_s R^T x ----
// (x = u_theta; the solve then takes R K_s R^T x off again, implicitly).

template <class Real>
SSC_HD inline void neo_hookean_correction_cell(int i, const PartContext<Real>& cx, const Real* u_theta,
                                               const int* cell_nodes, const Real* rotation, const Real* weights,
                                               const Real* lambda, const Real* mu, const Real* lambda_system,
                                               const Real* mu_system, Real* corner_force) {
  Vec3<Real> u[8], y[8], ku[8];
  load_cell_corners(u_theta, cell_nodes, i, u);
  neo_hookean_element(weights + 8 * i, lambda[i], mu[i], cx.h, u, y);
  corotated_apply(load_mat3(rotation, i), weights + 8 * i, lambda_system[i], mu_system[i], cx.h, u, ku);
  for (int c = 0; c < 8; ++c) store3(corner_force, 8 * i + c, ku[c] - y[c]);
}

// The rotation's and the Lame parameters' cotangents (accumulated), and the theta-point's
// corner cotangents (corner_bar, 8 a cell; gathered to the nodes by the next part).
template <class Real>
SSC_HD inline void adj_neo_hookean_correction_cell(int i, const PartContext<Real>& cx, const Real* u_theta,
                                                   const int* cell_nodes, const Real* rotation, const Real* weights,
                                                   const Real* lambda, const Real* mu, const Real* lambda_system,
                                                   const Real* mu_system, const Real* corner_force_bar,
                                                   Real* rotation_bar, Real* lambda_bar, Real* mu_bar,
                                                   Real* lambda_system_bar, Real* mu_system_bar, Real* corner_bar) {
  Vec3<Real> u[8], fb[8], minus_fb[8], ub[8];
  load_cell_corners(u_theta, cell_nodes, i, u);
  for (int c = 0; c < 8; ++c) {
    fb[c] = load3(corner_force_bar, 8 * i + c);
    minus_fb[c] = -fb[c];
    ub[c] = zero3<Real>();
  }
  Mat3<Real> R_bar = zero33<Real>();
  adj_neo_hookean_element(weights + 8 * i, lambda[i], mu[i], cx.h, u, minus_fb, ub, lambda_bar[i], mu_bar[i]);
  adj_corotated_apply(load_mat3(rotation, i), weights + 8 * i, lambda_system[i], mu_system[i], cx.h, u, fb, R_bar,
                      lambda_system_bar[i], mu_system_bar[i], ub);
  add_mat3(rotation_bar, i, R_bar);
  for (int c = 0; c < 8; ++c) store3(corner_bar, 8 * i + c, ub[c]);
}

#ifdef SSC_OP_SPECS
inline OpSpec neo_hookean_correction_spec() {
  OpSpec s;
  s.name = "neo_hookean_correction";
  s.domain = Domain::Cell;
  s.slots = {in("u_theta", Access::Gather), in("rotation"), in("lambda"), in("mu"), in("lambda_system"),
             in("mu_system"), out("corner_force")};
  s.scratch = {{"corner", Domain::Cell, 24, ""}};
  s.forward = {part("neo_hookean_correction", Extent::Cell, SSC_PART(neo_hookean_correction_cell),
                    {"u_theta^", "#cell_nodes", "rotation", "#cell_weights", "lambda", "mu", "lambda_system",
                     "mu_system", "corner_force"})};
  s.adjoint = {part("neo_hookean_correction", Extent::Cell, SSC_ADJOINT_PART(adj_neo_hookean_correction_cell),
                    {"u_theta^", "#cell_nodes", "rotation", "#cell_weights", "lambda", "mu", "lambda_system",
                     "mu_system", "d_corner_force", "d_rotation", "d_lambda", "d_mu", "d_lambda_system",
                     "d_mu_system", "$corner"}),
               part("neo_hookean_correction_gather", Extent::Node, SSC_ADJOINT_PART(add_corner_sum),
                    {"$corner^", "#node_cell_offset", "#node_cell_entry", "d_u_theta"})};
  return s;
}
#endif

}  // namespace ops
}  // namespace ssc
