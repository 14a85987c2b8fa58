// Soft-min penalty contact resolved within the step (solver.contact = "implicit"): Newton
// iterations on the contact force with the penalty's stiffness in the system.
//
// The paper's contact op predicts the force from the start of the step; with a stiff ground
// that prediction overshoots and the step explodes. Here the step's solve is repeated:
// iteration k takes the iterate u_k (the first the prediction u- + dt v-), the contact force
// f(x) = sum over planes -k A softmin(d) n at the end-of-step position x = X + u_k and its
// stiffness K = -df/dx = sum k A softmin'(d) n n^T (symmetric positive semi-definite), and
// solves the linearisation
//   (A + dt K) u_(k+1) = b + dt f(u_k) + dt K u_k.
// Why the end of the step: the theta-scheme gives M (v - v-) = dt f and
// u - u- = dt (theta v + (1 - theta) v-), so the kinetic energy changes by
// f . (u - u-) - (theta - 1/2) |v - v-|_M^2 <= f . (u - u-); with f = -grad U at the end point
// and U convex (the soft-min penalty is), f . (u - u-) <= U(u-) - U(u): at convergence the
// contact never adds energy, whatever its stiffness and the step. (At the theta-point it can.)
// K is lumped to the point's corners with the weights w_c of the force split (row-sum
// lumping: Newton's fixed point is exact, its convergence a little slower). The engine's
// node-local matrix C (ops/newmark.h) then carries dt K, and since its right-hand side adds
// C (u- + dt v-), the op's node force adds K (u_k - u- - dt v-). The graph unrolls
// solver.nonlinear_iterations iterations (models/sim/timestep_graph.cpp); their adjoint is
// the exact gradient of the iterations computed.
#pragma once
#include "ops/contact.h"
#include "ops/newmark.h"
#include "ops/part.h"
#include "ops/ssc_math.h"

namespace ssc {
namespace ops {

// ---- the step_iterate op: the iterate u_k, its theta-point and its offset from the prediction ----

// u_iter given: guess = u_iter, theta-point theta u_iter + (1 - theta) u-, offset
// u_iter - (u- + dt v-); else the prediction guess = u- + dt v-, theta-point u- + theta dt v-
// and offset 0 (exactly: no rounding of a difference that vanishes).
template <class Real>
SSC_HD inline void step_iterate_node(int i, const PartContext<Real>&, const Real* u_iter, const Real* u_prev,
                                     const Real* v_prev, const Real* dt, const Real* theta, Real* guess,
                                     Real* u_theta, Real* offset) {
  const Vec3<Real> up = load3(u_prev, i), vp = load3(v_prev, i);
  if (u_iter) {
    const Vec3<Real> u = load3(u_iter, i);
    store3(guess, i, u);
    store3(u_theta, i, theta[0] * u + (Real(1) - theta[0]) * up);
    store3(offset, i, u - up - dt[0] * vp);
  } else {
    store3(guess, i, up + dt[0] * vp);
    store3(u_theta, i, up + (theta[0] * dt[0]) * vp);
    store3(offset, i, zero3<Real>());
  }
}

template <class Real>
SSC_HD inline void adj_step_iterate_node(int i, const PartContext<Real>&, const Real* u_iter, const Real* dt,
                                         const Real* theta, const Real* guess_bar, const Real* u_theta_bar,
                                         const Real* offset_bar, Real* u_iter_bar, Real* u_prev_bar,
                                         Real* v_prev_bar) {
  const Vec3<Real> gb = load3(guess_bar, i), tb = load3(u_theta_bar, i);
  if (u_iter) {
    const Vec3<Real> ob = load3(offset_bar, i);
    add3(u_iter_bar, i, gb + theta[0] * tb + ob);
    add3(u_prev_bar, i, (Real(1) - theta[0]) * tb - ob);
    add3(v_prev_bar, i, (-dt[0]) * ob);
  } else {
    add3(u_prev_bar, i, gb + tb);
    add3(v_prev_bar, i, dt[0] * gb + (theta[0] * dt[0]) * tb);
  }
}

// ---- the contact_implicit op ----

// One plane's force on a point and its stiffness (6 values: xx yy zz xy xz yz) added to K.
template <class Real>
SSC_HD inline void plane_contact_stiffness(const GroundPlane<Real>& g, Real area, Vec3<Real> x, Vec3<Real>& f, Real* K) {
  const Real d = dot(g.normal, x) - g.height;
  const Real kA = g.stiffness * area;
  f += (-kA * softmin(d, g.alpha)) * g.normal;
  add_sym3_outer(K, kA * softmin_derivative(d, g.alpha), g.normal);
}

// Adjoint of plane_contact_stiffness for f_bar and K_bar (of the 6 stored values).
template <class Real>
SSC_HD inline void adj_plane_contact_stiffness(const GroundPlane<Real>& g, Real area, Vec3<Real> x, Vec3<Real> f_bar,
                                               const Real* K_bar, Vec3<Real>& x_bar, Vec3<Real>& normal_bar,
                                               Real& height_bar, Real& stiffness_bar, Real& alpha_bar) {
  const Vec3<Real> n = g.normal;
  const Real d = dot(n, x) - g.height;
  const Real kA = g.stiffness * area;
  const Real s = softmin(d, g.alpha), s1 = softmin_derivative(d, g.alpha);
  const Real s2 = -g.alpha * s1 * (Real(1) - s1);
  const Vec3<Real> Gn = sym3_cotangent_apply(K_bar, n);
  const Real nGn = dot(n, Gn), fn = dot(f_bar, n);
  const Real d_bar = -kA * s1 * fn + kA * s2 * nGn;
  x_bar += d_bar * n;
  normal_bar += (-kA * s) * f_bar + (Real(2) * kA * s1) * Gn + d_bar * x;
  height_bar -= d_bar;
  stiffness_bar += area * (-s * fn + s1 * nGn);
  Real ds, ds1;
  softmin_alpha_derivatives(d, g.alpha, ds, ds1);
  alpha_bar += kA * (-ds * fn + ds1 * nGn);
}

// Point i at the iterate: its force (added to point_force_in, friction's, where given) and its
// stiffness K (point_stiffness, 6 a point).
template <class Real>
SSC_HD inline void contact_implicit_point(int i, const PartContext<Real>& cx, const int* point_nodes,
                                          const Real* point_weights, const Real* point_area, const Real* node_rest,
                                          const Real* guess, const Real* ground_planes, const Real* point_force_in,
                                          Real* point_force, Real* point_stiffness) {
  GroundPlane<Real> planes[kMaxGroundPlanes];
  const int plane_count = load_ground_planes(ground_planes, cx.n_plane, planes);
  Vec3<Real> x, unused;
  contact_point_state(i, point_nodes, point_weights, node_rest, guess, guess, x, unused);
  Vec3<Real> f = point_force_in ? load3(point_force_in, i) : zero3<Real>();
  Real K[6] = {Real(0), Real(0), Real(0), Real(0), Real(0), Real(0)};
  for (int p = 0; p < plane_count; ++p) plane_contact_stiffness(planes[p], point_area[i], x, f, K);
  store3(point_force, i, f);
  for (int j = 0; j < 6; ++j) point_stiffness[6 * i + j] = K[j];
}

// The stiffness K of point i alone (the adjoint's: a forward scratch buffer does not survive
// to the adjoint of a kept step).
template <class Real>
SSC_HD inline void contact_implicit_point_stiffness(int i, const PartContext<Real>& cx, const int* point_nodes,
                                                    const Real* point_weights, const Real* point_area, const Real* node_rest,
                                                    const Real* guess, const Real* ground_planes,
                                                    Real* point_stiffness) {
  GroundPlane<Real> planes[kMaxGroundPlanes];
  const int plane_count = load_ground_planes(ground_planes, cx.n_plane, planes);
  Vec3<Real> x, unused, f = zero3<Real>();
  contact_point_state(i, point_nodes, point_weights, node_rest, guess, guess, x, unused);
  Real K[6] = {Real(0), Real(0), Real(0), Real(0), Real(0), Real(0)};
  for (int p = 0; p < plane_count; ++p) plane_contact_stiffness(planes[p], point_area[i], x, f, K);
  for (int j = 0; j < 6; ++j) point_stiffness[6 * i + j] = K[j];
}

// Node i: C += dt K_i and the force K_i (u_k - u- - dt v-) (the iterate's offset; added to
// force_in, air drag's, where given), K_i the w_c-weighted sum of its points' K.
template <class Real>
SSC_HD inline void contact_implicit_node(int i, const PartContext<Real>&, const Real* point_stiffness,
                                         const Real* point_weights, const int* node_point_offset,
                                         const int* node_point_entry, const Real* offset, const Real* dt,
                                         const Real* damping_in, const Real* force_in, Real* damping,
                                         Real* node_force) {
  Real K[6];
  gather_point_sym3(point_stiffness, point_weights, node_point_offset, node_point_entry, i, K);
  for (int j = 0; j < 6; ++j) damping[6 * i + j] = (damping_in ? damping_in[6 * i + j] : Real(0)) + dt[0] * K[j];
  const Vec3<Real> f = sym3_apply(K, 0, load3(offset, i));
  store3(node_force, i, force_in ? load3(force_in, i) + f : f);
}

// Node i's cotangents: K_bar (point_stiffness's at the node, 6; the points gather them) and
// the offset's.
template <class Real>
SSC_HD inline void adj_contact_implicit_node(int i, const PartContext<Real>&, const Real* point_stiffness,
                                             const Real* point_weights, const int* node_point_offset,
                                             const int* node_point_entry, const Real* offset, const Real* dt,
                                             const Real* damping_bar, const Real* node_force_bar, Real* K_bar,
                                             Real* offset_bar, Real* damping_in_bar, Real* force_in_bar) {
  Real K[6];
  gather_point_sym3(point_stiffness, point_weights, node_point_offset, node_point_entry, i, K);
  const Vec3<Real> fb = load3(node_force_bar, i);
  for (int j = 0; j < 6; ++j) K_bar[6 * i + j] = dt[0] * damping_bar[6 * i + j];
  adj_sym3_apply(K_bar, i, load3(offset, i), fb);
  add3(offset_bar, i, sym3_apply(K, 0, fb));
  if (damping_in_bar)
    for (int j = 0; j < 6; ++j) damping_in_bar[6 * i + j] += damping_bar[6 * i + j];
  if (force_in_bar) add3(force_in_bar, i, fb);
}

// Point i: its position's cotangent (x_bar, gathered to the iterate's nodes by the next part)
// and its shares of the planes' (laid out like their tensor; summed by a reduction), from its
// force's and (gathered from its corners) its stiffness's cotangents.
template <class Real>
SSC_HD inline void adj_contact_implicit_point(int i, const PartContext<Real>& cx, const int* point_nodes,
                                              const Real* point_weights, const Real* point_area, const Real* node_rest,
                                              const Real* guess, const Real* ground_planes, const Real* K_bar,
                                              const Real* point_force_bar, Real* point_force_in_bar, Real* x_bar,
                                              Real* plane_bar_share) {
  GroundPlane<Real> planes[kMaxGroundPlanes];
  const int plane_count = load_ground_planes(ground_planes, cx.n_plane, planes);
  Vec3<Real> x, unused, xb = zero3<Real>();
  contact_point_state(i, point_nodes, point_weights, node_rest, guess, guess, x, unused);
  const Vec3<Real> fb = load3(point_force_bar, i);
  if (point_force_in_bar) add3(point_force_in_bar, i, fb);
  Real Kb[6];
  point_sym3(i, point_nodes, point_weights, K_bar, Kb);
  Real* pb = plane_bar_share + kPlaneValues * cx.n_plane * i;
  for (int j = 0; j < kPlaneValues * cx.n_plane; ++j) pb[j] = Real(0);
  for (int p = 0; p < plane_count; ++p, pb += kPlaneValues) {
    Vec3<Real> normal_bar = zero3<Real>();
    Real height_bar = Real(0), stiffness_bar = Real(0), alpha_bar = Real(0);
    adj_plane_contact_stiffness(planes[p], point_area[i], x, fb, Kb, xb, normal_bar, height_bar, stiffness_bar,
                                alpha_bar);
    pb[0] = normal_bar.x, pb[1] = normal_bar.y, pb[2] = normal_bar.z, pb[3] = height_bar;
    pb[4] = stiffness_bar, pb[5] = alpha_bar;
  }
  store3(x_bar, i, xb);
}

#ifdef SSC_OP_SPECS
inline OpSpec step_iterate_spec() {
  OpSpec s;
  s.name = "step_iterate";
  s.domain = Domain::Node;
  s.slots = {optional_in("u_iter"), in("u_prev"), in("v_prev"), constant_in("dt"), constant_in("theta"), out("guess"),
             out("u_theta"), out("offset")};
  s.forward = {part("step_iterate", Extent::Node, SSC_PART(step_iterate_node),
                    {"u_iter", "u_prev", "v_prev", "dt", "theta", "guess", "u_theta", "offset"})};
  s.adjoint = {part("step_iterate", Extent::Node, SSC_ADJOINT_PART(adj_step_iterate_node),
                    {"u_iter", "dt", "theta", "d_guess", "d_u_theta", "d_offset", "d_u_iter", "d_u_prev", "d_v_prev"})};
  return s;
}

inline OpSpec contact_implicit_spec() {
  OpSpec s;
  s.name = "contact_implicit";
  s.domain = Domain::Point;
  // Node tensors read by the node parts of this point op are gathers for the planner.
  s.slots = {in("guess", Access::Gather), in("offset", Access::Gather), in("ground_planes"),
             optional_in("point_force_in"), optional_in("damping_in", Access::Gather),
             optional_in("force_in", Access::Gather), constant_in("dt"), out("point_force"), out("damping"),
             out("node_force")};
  s.scratch = {{"pstiff", Domain::Point, 6, ""},
               {"kbar", Domain::Node, 6, ""},
               {"xbar", Domain::Point, 3, ""},
               {"planebar", Domain::Point, 0, "ground_planes"}};
  s.forward = {part("contact_implicit", Extent::Point, SSC_PART(contact_implicit_point),
                    {"#point_nodes", "#point_weights", "#point_area", "#node_rest^", "guess^", "ground_planes",
                     "point_force_in", "point_force", "$pstiff"}),
               part("contact_implicit_nodes", Extent::Node, SSC_PART(contact_implicit_node),
                    {"$pstiff^", "#point_weights", "#node_point_offset", "#node_point_entry", "offset", "dt", "damping_in",
                     "force_in", "damping", "node_force"})};
  s.adjoint = {part("contact_implicit_stiffness", Extent::Point, SSC_ADJOINT_PART(contact_implicit_point_stiffness),
                    {"#point_nodes", "#point_weights", "#point_area", "#node_rest^", "guess^", "ground_planes", "$pstiff"}),
               part("contact_implicit_nodes", Extent::Node, SSC_ADJOINT_PART(adj_contact_implicit_node),
                    {"$pstiff^", "#point_weights", "#node_point_offset", "#node_point_entry", "offset", "dt", "d_damping",
                     "d_node_force", "$kbar", "d_offset", "d_damping_in", "d_force_in"}),
               part("contact_implicit", Extent::Point, SSC_ADJOINT_PART(adj_contact_implicit_point),
                    {"#point_nodes", "#point_weights", "#point_area", "#node_rest^", "guess^", "ground_planes", "$kbar^",
                     "d_point_force", "d_point_force_in", "$xbar", "$planebar"}),
               part("contact_implicit_gather", Extent::Node, SSC_ADJOINT_PART(add_point_sum),
                    {"$xbar^", "#point_weights", "#node_point_offset", "#node_point_entry", "d_guess"}),
               reduction("contact_implicit_reduce", {"$planebar"}, {"d_ground_planes"})};
  return s;
}
#endif

}  // namespace ops
}  // namespace ssc
