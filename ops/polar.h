// Polar decomposition F = R S (R a rotation, S symmetric positive definite), the
// rotation used by corotated elasticity.
//
// Forward: Higham's Newton iteration X <- (g X + g^-1 X^-T)/2 with determinant
// scaling g = |det X|^(-1/3), iterated to convergence (not a fixed count). Cells whose
// deformation gradient is inverted or nearly degenerate (det F < kPolarMinDet) get
// R = I and a non-zero status so that the caller can report them.
// The adjoint (issue: gradients) is implicit, from dR = R [w]x with
// (tr S I - S) w = axial(R^T dF - dF^T R); it never differentiates the iterations.
#pragma once
#include "ops/ssc_math.h"

namespace ssc {
namespace ops {

constexpr double kPolarMinDet = 1e-5;
enum PolarStatus { kPolarOk = 0, kPolarDegenerate = 1, kPolarNotConverged = 2 };

template <class Real>
SSC_HD inline int polar_rotation(const Mat3<Real>& F, Mat3<Real>& R) {
  const Real d = det(F);
  if (!(d >= Real(kPolarMinDet))) {
    R = identity3<Real>();
    return kPolarDegenerate;
  }
  const Real tol = Real(sizeof(Real) == 4 ? 1e-6 : 1e-14);
  Mat3<Real> X = F;
  for (int it = 0; it < 40; ++it) {
    const Real dx = det(X);
    const Real g = Real(1) / cbrt(dx);
    // X^-T = cof(X) / det(X)
    const Mat3<Real> c = cofactor(X);
    Mat3<Real> next;
    Real change = Real(0);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        next.m[i][j] = Real(0.5) * (g * X.m[i][j] + c.m[i][j] / (g * dx));
        const Real e = next.m[i][j] - X.m[i][j];
        change += e * e;
      }
    X = next;
    if (change <= tol * tol) {
      R = X;
      return kPolarOk;
    }
  }
  R = X;
  return kPolarNotConverged;
}

// Adjoint of polar_rotation by the implicit function theorem: with S = R^T F,
//   F_bar = R [h]x,   h = (tr(S) I - S)^-1 axial(R^T R_bar - R_bar^T R),
// where axial(K) = (K32, K13, K21). A degenerate cell (R = I, a constant) has F_bar = 0.
template <class Real>
SSC_HD inline void adj_polar_rotation(const Mat3<Real>& F, const Mat3<Real>& R, int status, const Mat3<Real>& R_bar,
                                      Mat3<Real>& F_bar) {
  if (status == kPolarDegenerate) return;
  const Mat3<Real> S = mul_transposed_left(R, F);
  const Mat3<Real> X = mul_transposed_left(R, R_bar);
  const Vec3<Real> a = make_vec3(X.m[2][1] - X.m[1][2], X.m[0][2] - X.m[2][0], X.m[1][0] - X.m[0][1]);
  Mat3<Real> G = (-Real(1)) * S;
  const Real tr = trace(S);
  for (int i = 0; i < 3; ++i) G.m[i][i] += tr;
  const Vec3<Real> hv = inverse(G) * a;
  Mat3<Real> H;  // [h]x
  H.m[0][0] = Real(0); H.m[0][1] = -hv.z; H.m[0][2] = hv.y;
  H.m[1][0] = hv.z;    H.m[1][1] = Real(0); H.m[1][2] = -hv.x;
  H.m[2][0] = -hv.y;   H.m[2][1] = hv.x;  H.m[2][2] = Real(0);
  F_bar = F_bar + R * H;
}

}  // namespace ops
}  // namespace ssc
