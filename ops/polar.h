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
  const Real tol = sizeof(Real) == 8 ? Real(1e-14) : Real(1e-6);
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

}  // namespace ops
}  // namespace ssc
