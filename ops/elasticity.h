// Corotated linear elasticity on one hexahedral cell with partial-volume nodal
// quadrature (the paper's discretisation): the cell integral of B^T C B is taken at the
// 8 corners v with the weights w_v = integral over the cut region of N_v, so a cut cell
// needs only its 8 volume weights. In the rotated frame of the cell the element maps
// corner vectors q_c to forces
//   y_c = sum_v w_v sigma(eps_v) grad N_c(v),  eps_v = sym(sum_c q_c (x) grad N_c(v)),
//   sigma = lambda tr(eps) I + 2 mu eps,
// which is applied matrix-free: the stiffness matrix is never assembled.
#pragma once
#include "ops/part.h"
#include "ops/ssc_math.h"

namespace ssc {
namespace ops {

template <class Real>
SSC_HD inline void lame_from_young(Real E, Real nu, Real& lambda, Real& mu) {
  mu = E / (Real(2) * (Real(1) + nu));
  lambda = E * nu / ((Real(1) + nu) * (Real(1) - Real(2) * nu));
}

// Gradient of shape function N_c at corner v of a cell of size h.
template <class Real>
SSC_HD inline Vec3<Real> shape_gradient_at_corner(int c, int v, Real h) {
  Vec3<Real> g;
  for (int a = 0; a < 3; ++a) {
    Real s = corner_bit(c, a) ? Real(1) : Real(-1);
    for (int o = 0; o < 3; ++o)
      if (o != a && corner_bit(c, o) != corner_bit(v, o)) s = Real(0);
    g[a] = s / h;
  }
  return g;
}

// Local (rest) position of corner c relative to corner 0.
template <class Real>
SSC_HD inline Vec3<Real> corner_offset(int c, Real h) {
  return {h * Real(corner_bit(c, 0)), h * Real(corner_bit(c, 1)), h * Real(corner_bit(c, 2))};
}

// The weighted stress columns of quadrature corner v, col[a] = s_v[a] w_v sigma_v e_a, from
// the rotated-frame corner vectors q_v and its edge neighbours qn[a] = q_{v ^ (1 << a)}. At
// corner v only N_v and its three edge neighbours have a non-zero gradient:
// grad N_v(v) = s_v / h and grad N_{v ^ (1 << a)}(v) = -s_v[a] e_a / h, s_v = 2 b_v - 1.
template <class Real>
SSC_HD inline void element_corner_columns(int v, Real w_v, Real lambda, Real mu, Real h, Vec3<Real> q_v,
                                          const Vec3<Real>* qn, Vec3<Real>* col) {
  if (w_v == Real(0)) {
    for (int a = 0; a < 3; ++a) col[a] = zero3<Real>();
    return;
  }
  const Real inv_h = Real(1) / h;
  Real s[3];
  for (int a = 0; a < 3; ++a) s[a] = corner_bit(v, a) ? inv_h : -inv_h;
  Mat3<Real> G;  // displacement gradient at corner v, column a = s_a (q_v - q_{n_a})
  for (int a = 0; a < 3; ++a) {
    const Vec3<Real> d = q_v - qn[a];
    for (int i = 0; i < 3; ++i) G.m[i][a] = s[a] * d[i];
  }
  const Real tr = trace(G);
  Mat3<Real> S;  // w_v * stress
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) S.m[i][j] = w_v * (mu * (G.m[i][j] + G.m[j][i]) + (i == j ? lambda * tr : Real(0)));
  for (int a = 0; a < 3; ++a) col[a] = s[a] * make_vec3(S.m[0][a], S.m[1][a], S.m[2][a]);
}

// Force at corner c from its own columns and the columns its edge neighbours send it,
// y_c = sum_a own[a] - sum_a col_{c ^ (1 << a)}[a]: the element apply with one thread per
// corner (GPU solver loops). The sequential element_stiffness_apply adds the same terms
// in corner order, so the two differ by rounding only.
template <class Real>
SSC_HD inline Vec3<Real> element_corner_assemble(const Vec3<Real>* own, Vec3<Real> from_x, Vec3<Real> from_y,
                                                 Vec3<Real> from_z) {
  return own[0] + own[1] + own[2] - from_x - from_y - from_z;
}

// y = K_e q for the unrotated element (q, y: 8 corner vectors).
template <class Real>
SSC_HD inline void element_stiffness_apply(const Real* w, Real lambda, Real mu, Real h,
                                           const Vec3<Real>* q, Vec3<Real>* y) {
  for (int c = 0; c < 8; ++c) y[c] = zero3<Real>();
  SSC_UNROLL  // corner indices known at compile time: y stays in registers
  for (int v = 0; v < 8; ++v) {
    if (w[v] == Real(0)) continue;
    const Vec3<Real> qn[3] = {q[v ^ 1], q[v ^ 2], q[v ^ 4]};
    Vec3<Real> col[3];
    element_corner_columns(v, w[v], lambda, mu, h, q[v], qn, col);
    for (int a = 0; a < 3; ++a) {
      y[v] += col[a];
      y[v ^ (1 << a)] -= col[a];
    }
  }
}

// y_c = R K_e R^T p_c: the corotated element applied to nodal vectors p.
template <class Real>
SSC_HD inline void corotated_apply(const Mat3<Real>& R, const Real* w, Real lambda, Real mu, Real h,
                                   const Vec3<Real>* p, Vec3<Real>* y) {
  Vec3<Real> q[8], yl[8];
  for (int c = 0; c < 8; ++c) q[c] = mul_transposed(R, p[c]);
  element_stiffness_apply(w, lambda, mu, h, q, yl);
  for (int c = 0; c < 8; ++c) y[c] = R * yl[c];
}

// Force that keeps a rigidly rotated cell free of stress: f_c = -R K_e (R^T x_c - x_c),
// with x_c the local corner positions (K_e annihilates translations).
template <class Real>
SSC_HD inline void corotation_offset_force(const Mat3<Real>& R, const Real* w, Real lambda, Real mu,
                                           Real h, Vec3<Real>* f) {
  Vec3<Real> q[8], yl[8];
  for (int c = 0; c < 8; ++c) {
    const Vec3<Real> x = corner_offset<Real>(c, h);
    q[c] = mul_transposed(R, x) - x;
  }
  element_stiffness_apply(w, lambda, mu, h, q, yl);
  for (int c = 0; c < 8; ++c) f[c] = -(R * yl[c]);
}

// Diagonal entries of the 3x3 diagonal block of corner c of R K_e R^T (Jacobi).
template <class Real>
SSC_HD inline Vec3<Real> corotated_diagonal_corner(const Mat3<Real>& R, const Real* w, Real lambda, Real mu, Real h,
                                                   int c) {
  Mat3<Real> K = zero33<Real>();
  for (int v = 0; v < 8; ++v) {
    const Vec3<Real> a = shape_gradient_at_corner<Real>(c, v, h);
    const Real aa = dot(a, a);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) K.m[i][j] += w[v] * ((lambda + mu) * a[i] * a[j] + (i == j ? mu * aa : Real(0)));
  }
  const Mat3<Real> Kr = R * K * transpose(R);
  return make_vec3(Kr.m[0][0], Kr.m[1][1], Kr.m[2][2]);
}

// The same for all 8 corners.
template <class Real>
SSC_HD inline void corotated_diagonal(const Mat3<Real>& R, const Real* w, Real lambda, Real mu, Real h,
                                      Vec3<Real>* d) {
  for (int c = 0; c < 8; ++c) d[c] = corotated_diagonal_corner(R, w, lambda, mu, h, c);
}

// Elastic energy 1/2 q^T K_e q with q_c = R^T (x_c + u_c) - x_c.
template <class Real>
SSC_HD inline Real corotated_energy(const Mat3<Real>& R, const Real* w, Real lambda, Real mu, Real h,
                                    const Vec3<Real>* u) {
  Vec3<Real> q[8], y[8];
  for (int c = 0; c < 8; ++c) {
    const Vec3<Real> x = corner_offset<Real>(c, h);
    q[c] = mul_transposed(R, x + u[c]) - x;
  }
  element_stiffness_apply(w, lambda, mu, h, q, y);
  Real e = Real(0);
  for (int c = 0; c < 8; ++c) e += dot(q[c], y[c]);
  return Real(0.5) * e;
}

// Cell-average deformation gradient F = I + 1/(4h) sum_c u_c s_c^T, s_c = 2 b_c - 1.
template <class Real>
SSC_HD inline Mat3<Real> cell_deformation_gradient(const Vec3<Real>* u, Real h) {
  Mat3<Real> F = identity3<Real>();
  const Real s = Real(1) / (Real(4) * h);
  for (int c = 0; c < 8; ++c)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) F.m[i][j] += s * u[c][i] * (corner_bit(c, j) ? Real(1) : Real(-1));
  return F;
}

// ---- adjoints (reverse mode); each accumulates (+=) into its bar arguments ----

// Adjoint of cell_deformation_gradient: u_bar_c += 1/(4h) F_bar s_c.
template <class Real>
SSC_HD inline void adj_cell_deformation_gradient(const Mat3<Real>& F_bar, Real h, Vec3<Real>* u_bar) {
  const Real s = Real(1) / (Real(4) * h);
  for (int c = 0; c < 8; ++c)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) u_bar[c][i] += s * F_bar.m[i][j] * (corner_bit(c, j) ? Real(1) : Real(-1));
}

// K = lambda K_l + mu K_m is linear in the Lame parameters; z = K q and the two parts.
template <class Real>
SSC_HD inline void element_stiffness_parts(const Real* w, Real h, const Vec3<Real>* q, Vec3<Real>* z_lambda,
                                           Vec3<Real>* z_mu) {
  element_stiffness_apply(w, Real(1), Real(0), h, q, z_lambda);
  element_stiffness_apply(w, Real(0), Real(1), h, q, z_mu);
}

// Adjoint of corotated_apply (y = R K R^T p) for the cotangent y_bar.
template <class Real>
SSC_HD inline void adj_corotated_apply(const Mat3<Real>& R, const Real* w, Real lambda, Real mu, Real h,
                                       const Vec3<Real>* p, const Vec3<Real>* y_bar, Mat3<Real>& R_bar,
                                       Real& lambda_bar, Real& mu_bar, Vec3<Real>* p_bar) {
  Vec3<Real> q[8], zl[8], zm[8], z_bar[8], q_bar[8];
  for (int c = 0; c < 8; ++c) q[c] = mul_transposed(R, p[c]);
  element_stiffness_parts(w, h, q, zl, zm);
  for (int c = 0; c < 8; ++c) {
    const Vec3<Real> z = lambda * zl[c] + mu * zm[c];
    R_bar = R_bar + outer(y_bar[c], z);
    z_bar[c] = mul_transposed(R, y_bar[c]);
    lambda_bar += dot(z_bar[c], zl[c]);
    mu_bar += dot(z_bar[c], zm[c]);
  }
  element_stiffness_apply(w, lambda, mu, h, z_bar, q_bar);  // K is symmetric
  for (int c = 0; c < 8; ++c) {
    p_bar[c] += R * q_bar[c];
    R_bar = R_bar + outer(p[c], q_bar[c]);
  }
}

// Adjoint of corotation_offset_force (f = -R K (R^T x - x)) for the cotangent f_bar.
template <class Real>
SSC_HD inline void adj_corotation_offset_force(const Mat3<Real>& R, const Real* w, Real lambda, Real mu, Real h,
                                               const Vec3<Real>* f_bar, Mat3<Real>& R_bar, Real& lambda_bar,
                                               Real& mu_bar) {
  Vec3<Real> x[8], q[8], zl[8], zm[8], z_bar[8], q_bar[8];
  for (int c = 0; c < 8; ++c) {
    x[c] = corner_offset<Real>(c, h);
    q[c] = mul_transposed(R, x[c]) - x[c];
  }
  element_stiffness_parts(w, h, q, zl, zm);
  for (int c = 0; c < 8; ++c) {
    const Vec3<Real> z = lambda * zl[c] + mu * zm[c];
    R_bar = R_bar - outer(f_bar[c], z);
    z_bar[c] = -mul_transposed(R, f_bar[c]);
    lambda_bar += dot(z_bar[c], zl[c]);
    mu_bar += dot(z_bar[c], zm[c]);
  }
  element_stiffness_apply(w, lambda, mu, h, z_bar, q_bar);
  for (int c = 0; c < 8; ++c) R_bar = R_bar + outer(x[c], q_bar[c]);
}

// Adjoint of lame_from_young.
template <class Real>
SSC_HD inline void adj_lame_from_young(Real E, Real nu, Real lambda_bar, Real mu_bar, Real& E_bar, Real& nu_bar) {
  const Real a = Real(1) + nu, b = Real(1) - Real(2) * nu;
  E_bar += mu_bar / (Real(2) * a) + lambda_bar * nu / (a * b);
  // d mu/d nu = -E / (2 a^2);  d lambda/d nu = E (1 + 2 nu^2) / (a b)^2
  nu_bar += -mu_bar * E / (Real(2) * a * a) + lambda_bar * E * (Real(1) + Real(2) * nu * nu) / (a * a * b * b);
}

// ---- the lame op: (E, nu) -> (lambda, mu) per cell; E is the cell's entry of cell_youngs
// (ops/stiffness_field.h) where the body is heterogeneous, else youngs_modulus ----

template <class Real>
SSC_HD inline void lame_cell(int i, const PartContext<Real>&, const Real* youngs_modulus, const Real* cell_youngs,
                             const Real* poisson_ratio, Real* lambda, Real* mu) {
  lame_from_young(cell_youngs ? cell_youngs[i] : youngs_modulus[0], poisson_ratio[0], lambda[i], mu[i]);
}

// The cell's E cotangent goes to cell_youngs where bound, else to its share of youngs_modulus's;
// the shares (2 a cell: E, nu; double) are summed by a reduction part.
template <class Real>
SSC_HD inline void adj_lame_cell(int i, const PartContext<Real>&, const Real* youngs_modulus, const Real* cell_youngs,
                                 const Real* poisson_ratio, const Real* lambda_bar, const Real* mu_bar,
                                 Real* cell_youngs_bar, double* lame_bar_share) {
  Real E_bar = Real(0), nu_bar = Real(0);
  adj_lame_from_young(cell_youngs ? cell_youngs[i] : youngs_modulus[0], poisson_ratio[0], lambda_bar[i], mu_bar[i], E_bar,
                      nu_bar);
  if (cell_youngs_bar) cell_youngs_bar[i] += E_bar;
  lame_bar_share[2 * i] = cell_youngs_bar ? 0.0 : double(E_bar);
  lame_bar_share[2 * i + 1] = double(nu_bar);
}

#ifdef SSC_OP_SPECS
inline OpSpec lame_spec() {
  OpSpec s;
  s.name = "lame";
  s.domain = Domain::Cell;
  s.slots = {in("youngs_modulus"), optional_in("cell_youngs"), in("poisson_ratio"), out("lambda"), out("mu")};
  s.scratch = {{"red", Domain::Cell, 2, ""}};
  s.forward = {part("lame", Extent::Cell, SSC_PART(lame_cell),
                    {"youngs_modulus", "cell_youngs", "poisson_ratio", "lambda", "mu"})};
  s.adjoint = {part("lame", Extent::Cell, SSC_ADJOINT_PART(adj_lame_cell),
                    {"youngs_modulus", "cell_youngs", "poisson_ratio", "d_lambda", "d_mu", "d_cell_youngs", "$red"}),
               reduction("lame_reduce", {"$red"}, {"d_youngs_modulus", "d_poisson_ratio"})};
  return s;
}
#endif

}  // namespace ops
}  // namespace ssc
