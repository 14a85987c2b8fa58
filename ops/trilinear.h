// Trilinear interpolation in a hexahedral cell and its inverse, the core of the sparse
// surface constraint: an observed world point p is mapped back into the rest pose by
// solving X(a,b,c) = sum_c N_c(a,b,c) X_c = p for the local coordinates (a,b,c) of a
// deformed cell with corners X_c (Newton on the 3x3 system). The inverse is an implicit
// op: its adjoint follows from the implicit function theorem,
//   d(abc)/dX_c = -J^-1 N_c(abc),  J = dX/d(abc),
// and never differentiates the Newton iterations (so the initial guess has no gradient).
#pragma once
#include "ops/ssc_math.h"

namespace ssc {
namespace ops {

template <class Real>
SSC_HD inline void trilinear_weights(Vec3<Real> abc, Real* N) {
  for (int c = 0; c < 8; ++c) {
    const Real wx = corner_bit(c, 0) ? abc.x : Real(1) - abc.x;
    const Real wy = corner_bit(c, 1) ? abc.y : Real(1) - abc.y;
    const Real wz = corner_bit(c, 2) ? abc.z : Real(1) - abc.z;
    N[c] = wx * wy * wz;
  }
}

// Gradient of N_c with respect to (a, b, c).
template <class Real>
SSC_HD inline Vec3<Real> trilinear_weight_gradient(Vec3<Real> abc, int c) {
  const Real wx = corner_bit(c, 0) ? abc.x : Real(1) - abc.x;
  const Real wy = corner_bit(c, 1) ? abc.y : Real(1) - abc.y;
  const Real wz = corner_bit(c, 2) ? abc.z : Real(1) - abc.z;
  const Real sx = corner_bit(c, 0) ? Real(1) : Real(-1);
  const Real sy = corner_bit(c, 1) ? Real(1) : Real(-1);
  const Real sz = corner_bit(c, 2) ? Real(1) : Real(-1);
  return make_vec3(sx * wy * wz, wx * sy * wz, wx * wy * sz);
}

template <class Real>
SSC_HD inline Real trilinear_scalar(const Real* values, Vec3<Real> abc) {
  Real N[8];
  trilinear_weights(abc, N);
  Real s = Real(0);
  for (int c = 0; c < 8; ++c) s += N[c] * values[c];
  return s;
}

template <class Real>
SSC_HD inline Vec3<Real> trilinear_point(const Vec3<Real>* X, Vec3<Real> abc) {
  Real N[8];
  trilinear_weights(abc, N);
  Vec3<Real> s = zero3<Real>();
  for (int c = 0; c < 8; ++c) s += N[c] * X[c];
  return s;
}

// J = dX/d(abc): column k is sum_c X_c dN_c/d(abc)_k.
template <class Real>
SSC_HD inline Mat3<Real> trilinear_jacobian(const Vec3<Real>* X, Vec3<Real> abc) {
  Mat3<Real> J = zero33<Real>();
  for (int c = 0; c < 8; ++c) J = J + outer(X[c], trilinear_weight_gradient(abc, c));
  return J;
}

// Newton from the cell centre. Returns true when converged (|X(abc) - p| <= tol) with abc
// inside [-margin, 1 + margin]^3; false if it diverged, left the box [-1, 2]^3 or the
// Jacobian became singular.
template <class Real>
SSC_HD inline bool trilinear_inverse(const Vec3<Real>* X, Vec3<Real> p, Real tol, Vec3<Real>& abc) {
  abc = make_vec3(Real(0.5), Real(0.5), Real(0.5));
  for (int it = 0; it < 30; ++it) {
    const Vec3<Real> r = trilinear_point(X, abc) - p;
    if (dot(r, r) <= tol * tol) return true;
    const Mat3<Real> J = trilinear_jacobian(X, abc);
    const Real d = det(J);
    if (!(d != Real(0))) return false;
    abc = abc - inverse(J) * r;
    for (int k = 0; k < 3; ++k)
      if (!(abc[k] >= Real(-1) && abc[k] <= Real(2))) return false;
  }
  const Vec3<Real> r = trilinear_point(X, abc) - p;
  return dot(r, r) <= tol * tol;
}

// Adjoint of (abc = inverse(X, p), value = trilinear_scalar(phi, abc)) for a cotangent
// value_bar: X_bar_c += -N_c(abc) xi with xi = J^-T (value_bar grad_abc value).
template <class Real>
SSC_HD inline void adj_inverse_then_interpolate(const Vec3<Real>* X, Vec3<Real> abc, const Real* phi,
                                                Real value_bar, Vec3<Real>* X_bar) {
  Vec3<Real> g = zero3<Real>();
  for (int c = 0; c < 8; ++c) g += phi[c] * trilinear_weight_gradient(abc, c);
  const Mat3<Real> J = trilinear_jacobian(X, abc);
  const Vec3<Real> xi = mul_transposed(inverse(J), value_bar * g);
  Real N[8];
  trilinear_weights(abc, N);
  for (int c = 0; c < 8; ++c) X_bar[c] -= N[c] * xi;
}

// The per-point cost of the sparse surface constraint: 1/2 phi^2 near the surface,
// saturating smoothly at 1/2 phi_max^2 (the cost of an unmatched point), monotone in |phi|:
//   cost = 1/2 phi_max^2 (1 - exp(-phi^2 / phi_max^2)).
template <class Real>
SSC_HD inline Real surface_point_cost(Real phi, Real phi_max) {
  return Real(-0.5) * phi_max * phi_max * expm1(-(phi * phi) / (phi_max * phi_max));
}

template <class Real>
SSC_HD inline Real surface_point_cost_derivative(Real phi, Real phi_max) {
  return phi * exp(-(phi * phi) / (phi_max * phi_max));
}

}  // namespace ops
}  // namespace ssc
