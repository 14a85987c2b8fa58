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

// ---- adjoints (reverse mode); each accumulates (+=) into its bar arguments ----
// dt and theta are not differentiated; the damping parameters reach the coefficients
// through a_m (alpha), a_k and b_k (beta).

template <class Real>
struct NewmarkCoefficientBars {
  Real a_m = Real(0), a_k = Real(0), b_k = Real(0);
};

template <class Real>
SSC_HD inline void adj_newmark_coefficients(const NewmarkCoefficientBars<Real>& c_bar, Real& alpha_bar, Real& beta_bar) {
  alpha_bar += c_bar.a_m;
  beta_bar += c_bar.a_k + c_bar.b_k;
}

template <class Real>
SSC_HD inline void adj_newmark_rhs(const NewmarkCoefficients<Real>& c, Real mass, Vec3<Real> u_prev, Vec3<Real> v_prev,
                                   Vec3<Real> ku_prev, Vec3<Real> rhs_bar, Real& mass_bar, Vec3<Real>& u_prev_bar,
                                   Vec3<Real>& v_prev_bar, Vec3<Real>& ku_prev_bar, Vec3<Real>& force_bar,
                                   NewmarkCoefficientBars<Real>& c_bar) {
  mass_bar += dot(rhs_bar, c.a_m * u_prev + c.inv_theta * v_prev);
  u_prev_bar += (c.a_m * mass) * rhs_bar;
  v_prev_bar += (mass * c.inv_theta) * rhs_bar;
  ku_prev_bar += c.b_k * rhs_bar;
  force_bar += c.dt * rhs_bar;
  c_bar.a_m += mass * dot(rhs_bar, u_prev);
  c_bar.b_k += dot(rhs_bar, ku_prev);
}

template <class Real>
SSC_HD inline void adj_newmark_system_apply(const NewmarkCoefficients<Real>& c, Real mass, Vec3<Real> p, Vec3<Real> kp,
                                            Vec3<Real> y_bar, Real& mass_bar, Vec3<Real>& p_bar, Vec3<Real>& kp_bar,
                                            NewmarkCoefficientBars<Real>& c_bar) {
  mass_bar += c.a_m * dot(y_bar, p);
  p_bar += (c.a_m * mass) * y_bar;
  kp_bar += c.a_k * y_bar;
  c_bar.a_m += mass * dot(y_bar, p);
  c_bar.a_k += dot(y_bar, kp);
}

template <class Real>
SSC_HD inline void adj_newmark_velocity(const NewmarkCoefficients<Real>& c, Vec3<Real> v_bar, Vec3<Real>& u_bar,
                                        Vec3<Real>& u_prev_bar, Vec3<Real>& v_prev_bar) {
  const Real s = Real(1) / (c.theta * c.dt), q = (Real(1) - c.theta) / c.theta;
  u_bar += s * v_bar;
  u_prev_bar -= s * v_bar;
  v_prev_bar -= q * v_bar;
}

}  // namespace ops
}  // namespace ssc
