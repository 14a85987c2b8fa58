// Coulomb friction at ground contact, smoothed and treated implicitly.
//
// At a contact point with the contact op's normal force N = -k A softmin(d) (ops/contact.h)
// against a plane with friction coefficient mu and smoothing velocity eps, the tangential
// velocity w = v - (n.v) n meets the force
//   f = -mu N w / s,   s = sqrt(|w|^2 + eps^2),
// of magnitude mu N |w| / s: Coulomb's mu N when sliding (|w| >> eps), a viscous mu N w / eps
// below eps. The step takes it as the damper the start of the step gives,
//   f(v) = -C w(v),  C = mu N P / s(v-),  P = I - n n^T,
// i.e. f(v-) - C (v - v-) with C in the system matrix (ops/newmark.h), lumped to the point's
// corners with the weights that split the force. It opposes the end-of-step sliding
// velocity whatever the step does, so it never adds energy. (The velocity Jacobian
// mu N (P / s - w w^T / s^3) instead makes the step explicit along w once |w| > eps: a node
// whose friction impulse dt mu N / m exceeds its |w| then overshoots every step, and on a cube
// on a slope the contact points went into a growing sideways chatter (period two steps,
// 9 cm/s) that took the friction off the slope direction: at mu = 0.5 > tan 25 deg it crept
// at 4.7 cm/s.) Steady sliding gets Coulomb's force exactly. A body at rest on a slope with
// r = tan(slope) / mu < 1 holds, creeping at most at the speed where
// mu |w| / s = tan(slope): eps r / sqrt(1 - r^2).
//
// The op takes the contact op's point forces and returns them with friction added, so that
// node_force gathers one point force (without them, friction's own: the implicit contact op
// adds its forces later); its second output is C per node.
#pragma once
#include "ops/contact.h"
#include "ops/newmark.h"
#include "ops/part.h"
#include "ops/ssc_math.h"

namespace ssc {
namespace ops {

constexpr int kFrictionValues = 2;  // per plane: mu, smoothing velocity (m/s)

// Adds one plane's friction force at a point (position x, velocity v, area A) to f and its C
// (6 values: xx yy zz xy xz yz) to C.
template <class Real>
SSC_HD inline void plane_friction(const GroundPlane<Real>& g, Real mu, Real eps, Real area, Vec3<Real> x, Vec3<Real> v,
                                  Vec3<Real>& f, Real* C) {
  const Vec3<Real> n = g.normal;
  const Real N = -g.stiffness * area * softmin(dot(n, x) - g.height, g.alpha);
  const Real q = mu * N;
  const Vec3<Real> w = v - dot(n, v) * n;
  const Real s = sqrt(dot(w, w) + eps * eps);
  const Real a = q / s;
  f += (-a) * w;
  C[0] += a * (Real(1) - n.x * n.x);
  C[1] += a * (Real(1) - n.y * n.y);
  C[2] += a * (Real(1) - n.z * n.z);
  C[3] += -a * n.x * n.y;
  C[4] += -a * n.x * n.z;
  C[5] += -a * n.y * n.z;
}

// Adjoint of plane_friction for the cotangents f_bar and C_bar (of the 6 stored values).
// With G the symmetric matrix whose entries give <G, dC> = sum_k C_bar[k] dC[k] (the
// off-diagonal ones C_bar / 2), q = mu N and GP = <G, P> (C = q P / s, f = -q w / s):
//   q_bar = (GP - f_bar.w) / s,  s_bar = q (f_bar.w - GP) / s^2,
//   w_bar = -q / s f_bar + s_bar w / s,  n_bar = -2 q / s G n + (from w, d).
template <class Real>
SSC_HD inline void adj_plane_friction(const GroundPlane<Real>& g, Real mu, Real eps, Real area, Vec3<Real> x,
                                      Vec3<Real> v, Vec3<Real> f_bar, const Real* C_bar, Vec3<Real>& x_bar,
                                      Vec3<Real>& v_bar, Vec3<Real>& normal_bar, Real& height_bar,
                                      Real& stiffness_bar, Real& alpha_bar, Real& mu_bar, Real& eps_bar) {
  const Vec3<Real> n = g.normal;
  const Real d = dot(n, x) - g.height;
  const Real kA = g.stiffness * area;
  const Real N = -kA * softmin(d, g.alpha);
  const Real q = mu * N;
  const Real nv = dot(n, v);
  const Vec3<Real> w = v - nv * n;
  const Real s = sqrt(dot(w, w) + eps * eps);
  const Vec3<Real> Gn = sym3_cotangent_apply(C_bar, n);
  // <G, P> summed over P's entries as plane_friction stores them, not as tr G - n.Gn: C_bar's
  // part along n n^T, which <G, P> does not contain, was up to 1.2e8 times the tangential one
  // on the random torus step (tests/test_gpu_kernels.cpp), and that difference in float kept
  // little of it (the friction values' cotangents off by up to 3.7e-3, v_prev's by 9.3e-4).
  const Real GP = C_bar[0] * (Real(1) - n.x * n.x) + C_bar[1] * (Real(1) - n.y * n.y) +
                  C_bar[2] * (Real(1) - n.z * n.z) - C_bar[3] * n.x * n.y - C_bar[4] * n.x * n.z - C_bar[5] * n.y * n.z;
  const Real fw = dot(f_bar, w);
  const Real q_bar = (GP - fw) / s;
  const Real s_bar = q * (fw - GP) / (s * s);
  const Vec3<Real> w_bar = (-q / s) * f_bar + (s_bar / s) * w;
  Vec3<Real> n_bar = (Real(-2) * q / s) * Gn;
  eps_bar += s_bar * eps / s;
  const Real nw = dot(n, w_bar);
  v_bar += w_bar - nw * n;
  n_bar += (-nv) * w_bar - nw * v;
  mu_bar += N * q_bar;
  const Real N_bar = mu * q_bar;
  stiffness_bar += N_bar * N / g.stiffness;
  Real ds, ds1;
  softmin_alpha_derivatives(d, g.alpha, ds, ds1);
  alpha_bar += N_bar * (-kA) * ds;
  const Real d_bar = N_bar * (-kA * softmin_derivative(d, g.alpha));
  x_bar += d_bar * n;
  n_bar += d_bar * x;
  height_bar -= d_bar;
  normal_bar += n_bar;
}

// ---- the friction op ----

template <class Real>
SSC_HD inline void friction_point(int i, const PartContext<Real>& cx, const int* point_nodes, const Real* point_weights,
                                  const Real* point_area, const Real* node_rest, const Real* u_prev, const Real* v_prev,
                                  const Real* ground_planes, const Real* friction, const Real* contact_force,
                                  Real* point_force, Real* point_damping) {
  GroundPlane<Real> planes[kMaxGroundPlanes];
  const int plane_count = load_ground_planes(ground_planes, cx.n_plane, planes);
  Vec3<Real> x, v;
  contact_point_state(i, point_nodes, point_weights, node_rest, u_prev, v_prev, x, v);
  Vec3<Real> f = contact_force ? load3(contact_force, i) : zero3<Real>();
  Real C[6] = {Real(0), Real(0), Real(0), Real(0), Real(0), Real(0)};
  for (int k = 0; k < plane_count; ++k)
    plane_friction(planes[k], friction[kFrictionValues * k], friction[kFrictionValues * k + 1], point_area[i], x, v, f, C);
  store3(point_force, i, f);
  for (int j = 0; j < 6; ++j) point_damping[6 * i + j] = C[j];
}

// C at node i: its contact points' C with the weights (1 - t, t) of the force split.
template <class Real>
SSC_HD inline void friction_damping_node(int i, const PartContext<Real>&, const Real* point_damping, const Real* point_weights,
                                         const int* node_point_offset, const int* node_point_entry, Real* damping) {
  gather_point_sym3(point_damping, point_weights, node_point_offset, node_point_entry, i, damping + 6 * i);
}

// The contact force's cotangent passes through; the point's position and velocity cotangents
// (gathered to the point's corners by the next parts) and its shares of the planes' and the
// friction values' (laid out like their tensors; summed by reductions).
template <class Real>
SSC_HD inline void adj_friction_point(int i, const PartContext<Real>& cx, const int* point_nodes, const Real* point_weights,
                                      const Real* point_area, const Real* node_rest, const Real* u_prev,
                                      const Real* v_prev, const Real* ground_planes, const Real* friction,
                                      const Real* point_force_bar, const Real* damping_bar, Real* contact_force_bar,
                                      Real* x_bar, Real* v_bar, Real* plane_bar_share, Real* friction_bar_share) {
  GroundPlane<Real> planes[kMaxGroundPlanes];
  const int plane_count = load_ground_planes(ground_planes, cx.n_plane, planes);
  Vec3<Real> x, v, xb = zero3<Real>(), vb = zero3<Real>();
  contact_point_state(i, point_nodes, point_weights, node_rest, u_prev, v_prev, x, v);
  const Vec3<Real> f_bar = load3(point_force_bar, i);
  if (contact_force_bar) add3(contact_force_bar, i, f_bar);
  Real C_bar[6];
  point_sym3(i, point_nodes, point_weights, damping_bar, C_bar);
  Real* pb = plane_bar_share + kPlaneValues * cx.n_plane * i;
  Real* fb = friction_bar_share + kFrictionValues * cx.n_plane * i;
  for (int k = 0; k < cx.n_plane; ++k) {
    for (int j = 0; j < kPlaneValues; ++j) pb[kPlaneValues * k + j] = Real(0);
    for (int j = 0; j < kFrictionValues; ++j) fb[kFrictionValues * k + j] = Real(0);
  }
  for (int k = 0; k < plane_count; ++k) {
    Vec3<Real> normal_bar = zero3<Real>();
    Real height_bar = Real(0), stiffness_bar = Real(0), alpha_bar = Real(0), mu_bar = Real(0), eps_bar = Real(0);
    adj_plane_friction(planes[k], friction[kFrictionValues * k], friction[kFrictionValues * k + 1], point_area[i], x, v,
                       f_bar, C_bar, xb, vb, normal_bar, height_bar, stiffness_bar, alpha_bar, mu_bar, eps_bar);
    Real* p = pb + kPlaneValues * k;
    p[0] = normal_bar.x, p[1] = normal_bar.y, p[2] = normal_bar.z, p[3] = height_bar;
    p[4] = stiffness_bar, p[5] = alpha_bar;
    fb[kFrictionValues * k] = mu_bar;
    fb[kFrictionValues * k + 1] = eps_bar;
  }
  store3(x_bar, i, xb);
  store3(v_bar, i, vb);
}

#ifdef SSC_OP_SPECS
inline OpSpec friction_spec() {
  OpSpec s;
  s.name = "friction";
  s.domain = Domain::Point;
  s.slots = {in("u_prev", Access::Gather), in("v_prev", Access::Gather), in("ground_planes"), in("friction"),
             optional_in("contact_force"), out("point_force"), out("damping")};
  s.scratch = {{"pdamp", Domain::Point, 6, ""},
               {"xbar", Domain::Point, 3, ""},
               {"vbar", Domain::Point, 3, ""},
               {"planebar", Domain::Point, 0, "ground_planes"},
               {"frictionbar", Domain::Point, 0, "friction"}};
  s.forward = {part("friction", Extent::Point, SSC_PART(friction_point),
                    {"#point_nodes", "#point_weights", "#point_area", "#node_rest^", "u_prev^", "v_prev^", "ground_planes",
                     "friction", "contact_force", "point_force", "$pdamp"}),
               part("friction_damping", Extent::Node, SSC_PART(friction_damping_node),
                    {"$pdamp^", "#point_weights", "#node_point_offset", "#node_point_entry", "damping"})};
  s.adjoint = {part("friction", Extent::Point, SSC_ADJOINT_PART(adj_friction_point),
                    {"#point_nodes", "#point_weights", "#point_area", "#node_rest^", "u_prev^", "v_prev^", "ground_planes",
                     "friction", "d_point_force", "d_damping^", "d_contact_force", "$xbar", "$vbar", "$planebar",
                     "$frictionbar"}),
               part("friction_gather", Extent::Node, SSC_ADJOINT_PART(add_point_sum),
                    {"$xbar^", "#point_weights", "#node_point_offset", "#node_point_entry", "d_u_prev"}),
               part("friction_gather", Extent::Node, SSC_ADJOINT_PART(add_point_sum),
                    {"$vbar^", "#point_weights", "#node_point_offset", "#node_point_entry", "d_v_prev"}),
               reduction("friction_reduce", {"$planebar", "$frictionbar"}, {"d_ground_planes", "d_friction"})};
  return s;
}
#endif

}  // namespace ops
}  // namespace ssc
