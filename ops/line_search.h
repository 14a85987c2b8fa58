// A line search for the implicit contact's Newton iterations (ops/contact_implicit.h).
//
// Each iteration solves (A + dt K_L) u_full = b + dt f(u_k) + dt K_L u_k, with A the step's
// system without the contact (a_m M + a_k R K R^T + friction's and drag's C) and K_L the
// contact stiffness lumped to the nodes. That is a Newton step on the gradient of the convex
//   Phi(u) = u^T A u / 2 - b^T u + dt U(u),   U the soft-min penalty's potential,
// and a full step can overshoot it: an edge above a stiff plane (K = 0) lands deep inside it,
// the next iterate jumps back out, and the contact set alternates without converging. The
// line search takes u_(k+1) = u_k + alpha (u_full - u_k) with alpha the largest of 1, 2^-1/2,
// .., 2^-15/2 (1/181) at which the slope of Phi along delta = u_full - u_k stays below half its
// start's size:
//   phi'(alpha) = (alpha - 1) Q - alpha dt S + dt sum_p delta_p . (f_p(u_k) - f_p(u_k + alpha delta))
//   <= Q / 2 = -phi'(0) / 2,
// with Q = delta^T (A + dt K_L) delta and S = delta^T K_L delta (the solve's equation gives
// A u_k - b). Phi is convex, so this passes the minimum along delta by at most a bounded step
// and accepts the full step wherever the contact is close to linear.
//
// Ops: line_search (the sums Q, S and the contact terms for every alpha, one fixed-order
// reduction per batch item) and line_search_step (alpha from the sums, and the new iterate).
// alpha is piecewise constant in the inputs: the adjoint takes it as a constant, which is the
// exact gradient of what was computed wherever the choice does not change.
#pragma once
#include "ops/contact.h"
#include "ops/corotation.h"
#include "ops/newmark.h"
#include "ops/part.h"
#include "ops/ssc_math.h"

namespace ssc {
namespace ops {

constexpr int kLineSearchSteps = 16;                    // alpha = 1, 2^-1/2, .., 2^-15/2
// 2^-1/2: with halving, an edge at 1 m/s and 1/240 s on 1e9 Pa/m needed 8 iterations, with this 4.
constexpr double kLineSearchShrink = 0.70710678118654752;
constexpr int kLineSearchSums = 3 + kLineSearchSteps;  // cells' Q, nodes' Q, S, the contact terms

// The step's alpha from the sums (see above); 1 where delta vanishes.
template <class Real>
SSC_HD inline Real line_search_alpha(const Real* sums, Real dt) {
  const Real q = sums[0] + sums[1], s = sums[2];
  Real alpha = Real(1);
  for (int j = 0; j < kLineSearchSteps; ++j) {
    const Real slope = (alpha - Real(1)) * q - alpha * dt * s + dt * sums[3 + j];
    if (slope <= Real(0.5) * q) return alpha;
    if (j + 1 < kLineSearchSteps) alpha *= Real(kLineSearchShrink);
  }
  return alpha;
}

// Cell i: its share of delta^T a_k R K R^T delta (fixed corners take no part in the system).
template <class Real>
SSC_HD inline void line_search_cell(int i, const PartContext<Real>& cx, const Real* dt, const Real* theta,
                                    const Real* mass_damping, const Real* stiffness_damping, const Real* rotation,
                                    const Real* cell_weights, const Real* lambda, const Real* mu, const Real* guess,
                                    const Real* u_full, const Real* fixed, const int* cell_nodes, Real* cell_q) {
  const NewmarkCoefficients<Real> c = newmark_coefficients(dt[0], theta[0], mass_damping[0], stiffness_damping[0]);
  Vec3<Real> d[8], y[8];
  for (int k = 0; k < 8; ++k) {
    const int n = cell_nodes[8 * i + k];
    d[k] = fixed[n] != Real(0) ? zero3<Real>() : load3(u_full, n) - load3(guess, n);
  }
  corotated_apply(load_mat3(rotation, i), cell_weights + 8 * i, lambda[i], mu[i], cx.h, d, y);
  Real q = Real(0);
  for (int k = 0; k < 8; ++k) q += dot(d[k], y[k]);
  cell_q[i] = c.a_k * q;
}

// Node i: its share of delta^T (a_m M + C) delta, C the solve's node-local matrix.
template <class Real>
SSC_HD inline void line_search_node(int i, const PartContext<Real>&, const Real* dt, const Real* theta,
                                    const Real* mass_damping, const Real* stiffness_damping, const Real* mass,
                                    const Real* fixed, const Real* guess, const Real* u_full, const Real* damping,
                                    Real* node_q) {
  if (fixed[i] != Real(0)) {
    node_q[i] = Real(0);
    return;
  }
  const NewmarkCoefficients<Real> c = newmark_coefficients(dt[0], theta[0], mass_damping[0], stiffness_damping[0]);
  const Vec3<Real> d = load3(u_full, i) - load3(guess, i);
  Real q = c.a_m * mass[i] * dot(d, d);
  if (damping) q += dot(d, sym3_apply(damping, i, d));
  node_q[i] = q;
}

// Whether a point is at least kFarFromPlane / alpha from every plane (outside) at both ends
// of its step; the distance is linear along the step, so on all of it. There its soft-min
// force and stiffness are below exp(-kFarFromPlane) = 4e-18 of their scale k A / alpha, under
// double's rounding: its line-search terms are zero (most of a body's points, and most of the
// line search's work).
constexpr double kFarFromPlane = 40;
template <class Real>
SSC_HD inline bool far_from_every_plane(const GroundPlane<Real>* planes, int plane_count, const Vec3<Real>& a,
                                        const Vec3<Real>& b) {
  for (int p = 0; p < plane_count; ++p) {
    const Real da = dot(planes[p].normal, a) - planes[p].height, db = dot(planes[p].normal, b) - planes[p].height;
    if ((da < db ? da : db) * planes[p].alpha < Real(kFarFromPlane)) return false;
  }
  return true;
}

// Point i: its share of S (its stiffness at the iterate, lumped to its corners as the
// solve's) and of each alpha's contact term.
template <class Real>
SSC_HD inline void line_search_point(int i, const PartContext<Real>& cx, const int* point_nodes, const Real* point_weights,
                                     const Real* point_area, const Real* node_rest, const Real* guess,
                                     const Real* u_full, const Real* ground_planes, Real* point_terms) {
  GroundPlane<Real> planes[kMaxGroundPlanes];
  const int plane_count = load_ground_planes(ground_planes, cx.n_plane, planes);
  Vec3<Real> x, x_full, unused;
  contact_point_state(i, point_nodes, point_weights, node_rest, guess, guess, x, unused);
  contact_point_state(i, point_nodes, point_weights, node_rest, u_full, u_full, x_full, unused);
  Real* out = point_terms + (1 + kLineSearchSteps) * i;
  if (far_from_every_plane(planes, plane_count, x, x_full)) {
    for (int j = 0; j <= kLineSearchSteps; ++j) out[j] = Real(0);
    return;
  }
  const Vec3<Real> d = x_full - x;
  Vec3<Real> f = zero3<Real>();
  Real K[6] = {Real(0), Real(0), Real(0), Real(0), Real(0), Real(0)};
  for (int p = 0; p < plane_count; ++p) plane_contact_stiffness(planes[p], point_area[i], x, f, K);
  out[0] = Real(0);
  for (int c = kPointNodes * i; c < kPointNodes * (i + 1); ++c) {
    if (point_weights[c] == Real(0)) continue;
    const int n = point_nodes[c];
    const Vec3<Real> dn = load3(u_full, n) - load3(guess, n);
    out[0] += point_weights[c] * dot(dn, sym3_apply(K, 0, dn));
  }
  Real alpha = Real(1);
  for (int j = 0; j < kLineSearchSteps; ++j, alpha *= Real(kLineSearchShrink)) {
    const Vec3<Real> fa = contact_force(x + alpha * d, zero3<Real>(), point_area[i], planes, plane_count, Real(0), Real(0));
    out[1 + j] = dot(d, f - fa);
  }
}

// ---- the line_search_step op: u_(k+1) = u_k + alpha (u_full - u_k) ----

template <class Real>
SSC_HD inline void line_search_step_node(int i, const PartContext<Real>&, const Real* sums, const Real* dt,
                                         const Real* guess, const Real* u_full, Real* u) {
  const Real alpha = line_search_alpha(sums, dt[0]);
  const Vec3<Real> g = load3(guess, i);
  store3(u, i, g + alpha * (load3(u_full, i) - g));
}

template <class Real>
SSC_HD inline void adj_line_search_step_node(int i, const PartContext<Real>&, const Real* sums, const Real* dt,
                                             const Real* u_bar, Real* guess_bar, Real* u_full_bar) {
  const Real alpha = line_search_alpha(sums, dt[0]);
  const Vec3<Real> ub = load3(u_bar, i);
  add3(guess_bar, i, (Real(1) - alpha) * ub);
  add3(u_full_bar, i, alpha * ub);
}

#ifdef SSC_OP_SPECS
// The iterate, the solve's full step and the solve's system -> the sums alpha is chosen from
// (not differentiated: alpha is piecewise constant).
inline OpSpec line_search_spec() {
  OpSpec s;
  s.name = "line_search";
  s.domain = Domain::Point;
  // Cell and node tensors read by the cell and node parts of this point op are gathers for
  // the planner.
  s.slots = {constant_in("guess", Access::Gather),    constant_in("u_full", Access::Gather),
             constant_in("rotation", Access::Gather), constant_in("lambda", Access::Gather),
             constant_in("mu", Access::Gather),       constant_in("mass", Access::Gather),
             constant_in("fixed", Access::Gather),    optional_in("damping", Access::Gather),
             constant_in("ground_planes"),            constant_in("dt"),
             constant_in("theta"),                    constant_in("mass_damping"),
             constant_in("stiffness_damping"),        out("sums")};
  s.slots[7].differentiable = false;
  s.slots.back().differentiable = false;
  s.scratch = {{"cell_q", Domain::Cell, 1, ""}, {"node_q", Domain::Node, 1, ""}, {"point_terms", Domain::Point, 1 + kLineSearchSteps, ""}};
  s.forward = {part("line_search_cells", Extent::Cell, SSC_PART(line_search_cell),
                    {"dt", "theta", "mass_damping", "stiffness_damping", "rotation", "#cell_weights", "lambda", "mu",
                     "guess^", "u_full^", "fixed^", "#cell_nodes", "$cell_q"}),
               part("line_search_nodes", Extent::Node, SSC_PART(line_search_node),
                    {"dt", "theta", "mass_damping", "stiffness_damping", "mass", "fixed", "guess", "u_full", "damping",
                     "$node_q"}),
               part("line_search_points", Extent::Point, SSC_PART(line_search_point),
                    {"#point_nodes", "#point_weights", "#point_area", "#node_rest^", "guess^", "u_full^", "ground_planes",
                     "$point_terms"}),
               reduction("line_search_reduce", {"$cell_q", "$node_q", "$point_terms"}, {"sums"})};
  return s;
}

inline OpSpec line_search_step_spec() {
  OpSpec s;
  s.name = "line_search_step";
  s.domain = Domain::Node;
  s.slots = {constant_in("sums"), constant_in("dt"), in("guess"), in("u_full"), out("u")};
  s.forward = {part("line_search_step", Extent::Node, SSC_PART(line_search_step_node),
                    {"sums", "dt", "guess", "u_full", "u"})};
  s.adjoint = {part("line_search_step", Extent::Node, SSC_ADJOINT_PART(adj_line_search_step_node),
                    {"sums", "dt", "d_u", "d_guess", "d_u_full"})};
  return s;
}
#endif

}  // namespace ops
}  // namespace ssc
