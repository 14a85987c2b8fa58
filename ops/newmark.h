// The theta-scheme of the paper ("Newmark"), with the reference code's (correct) sign:
//   A = a_m M + a_k K,            a_m = 1/(theta dt) + alpha,  a_k = beta + theta dt
//   b = a_m M u- + b_k K u- + M v- / theta + dt f,             b_k = beta - (1-theta) dt
//   v = (u - u-)/(theta dt) - (1-theta)/theta v-
// with Rayleigh damping D = alpha M + beta K and the lumped mass M (one value per node).
#pragma once
#include "ops/ssc_math.h"

namespace ssc {
namespace ops {

template <class Real>
struct NewmarkCoefficients {
  Real a_m, a_k, b_k, inv_theta, dt, theta;
};

template <class Real>
SSC_HD inline NewmarkCoefficients<Real> newmark_coefficients(Real dt, Real theta, Real alpha, Real beta) {
  NewmarkCoefficients<Real> c;
  c.a_m = Real(1) / (theta * dt) + alpha;
  c.a_k = beta + theta * dt;
  c.b_k = beta - (Real(1) - theta) * dt;
  c.inv_theta = Real(1) / theta;
  c.dt = dt;
  c.theta = theta;
  return c;
}

// Right-hand side of one node; ku_prev = (K u-) at that node.
template <class Real>
SSC_HD inline Vec3<Real> newmark_rhs(const NewmarkCoefficients<Real>& c, Real mass, Vec3<Real> u_prev,
                                     Vec3<Real> v_prev, Vec3<Real> ku_prev, Vec3<Real> force) {
  return (c.a_m * mass) * u_prev + c.b_k * ku_prev + (mass * c.inv_theta) * v_prev + c.dt * force;
}

// (A p) at one node, given (K p) there.
template <class Real>
SSC_HD inline Vec3<Real> newmark_system_apply(const NewmarkCoefficients<Real>& c, Real mass, Vec3<Real> p,
                                              Vec3<Real> kp) {
  return (c.a_m * mass) * p + c.a_k * kp;
}

template <class Real>
SSC_HD inline Vec3<Real> newmark_velocity(const NewmarkCoefficients<Real>& c, Vec3<Real> u, Vec3<Real> u_prev,
                                          Vec3<Real> v_prev) {
  return (Real(1) / (c.theta * c.dt)) * (u - u_prev) - ((Real(1) - c.theta) / c.theta) * v_prev;
}

}  // namespace ops
}  // namespace ssc
