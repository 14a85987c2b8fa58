// The theta-scheme of the paper ("Newmark"), with the reference code's (correct) sign:
//   A = a_m M + a_k K,            a_m = 1/(theta dt) + alpha,  a_k = beta + theta dt
//   b = a_m M u- + b_k K u- + M v- / theta + dt f,             b_k = beta - (1-theta) dt
//   v = (u - u-)/(theta dt) - (1-theta)/theta v-
// with Rayleigh damping D = alpha M + beta K and the lumped mass M (one value per node).
// Ops with a velocity-dependent force f(v) ~ f(v-) - C (v - v-) whose Jacobian -C is
// node-local (friction) hand the engine C as a symmetric 3x3 per node ("damping", 6 values:
// xx yy zz xy xz yz); the theta-scheme then reads
//   (A + C) u = b + dt f(v-) + C (u- + dt v-),
// since theta dt (v - v-) = u - u- - dt v-.
#pragma once
#include "ops/corotation.h"
#include "ops/gather.h"
#include "ops/part.h"
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

// ---- node-local symmetric 3x3 matrices, 6 values a node (xx yy zz xy xz yz) ----

template <class Real>
SSC_HD inline Vec3<Real> sym3_apply(const Real* s, int i, Vec3<Real> p) {
  const Real* m = s + 6 * i;
  return make_vec3(m[0] * p.x + m[3] * p.y + m[4] * p.z, m[3] * p.x + m[1] * p.y + m[5] * p.z,
                   m[4] * p.x + m[5] * p.y + m[2] * p.z);
}

// S += c n n^T.
template <class Real>
SSC_HD inline void add_sym3_outer(Real* s, Real c, Vec3<Real> n) {
  s[0] += c * n.x * n.x;
  s[1] += c * n.y * n.y;
  s[2] += c * n.z * n.z;
  s[3] += c * n.x * n.y;
  s[4] += c * n.x * n.z;
  s[5] += c * n.y * n.z;
}

// G p for the cotangent s_bar of the 6 stored values of a symmetric S: G is the symmetric
// matrix with <G, dS> = sum_k s_bar[k] dS[k] (its off-diagonal entries s_bar / 2).
template <class Real>
SSC_HD inline Vec3<Real> sym3_cotangent_apply(const Real* s_bar, Vec3<Real> p) {
  const Real h = Real(0.5);
  return make_vec3(s_bar[0] * p.x + h * s_bar[3] * p.y + h * s_bar[4] * p.z,
                   h * s_bar[3] * p.x + s_bar[1] * p.y + h * s_bar[5] * p.z,
                   h * s_bar[4] * p.x + h * s_bar[5] * p.y + s_bar[2] * p.z);
}

// The cotangent of the stored values of S for y = S p and the cotangent y_bar.
template <class Real>
SSC_HD inline void adj_sym3_apply(Real* s_bar, int i, Vec3<Real> p, Vec3<Real> y_bar) {
  Real* m = s_bar + 6 * i;
  m[0] += y_bar.x * p.x;
  m[1] += y_bar.y * p.y;
  m[2] += y_bar.z * p.z;
  m[3] += y_bar.x * p.y + y_bar.y * p.x;
  m[4] += y_bar.x * p.z + y_bar.z * p.x;
  m[5] += y_bar.y * p.z + y_bar.z * p.y;
}

// ---- the newmark_rhs op: b at every node, from K u- gathered at the node's corners ----

template <class Real>
SSC_HD inline void newmark_rhs_node(int i, const PartContext<Real>&, const Real* dt, const Real* theta,
                                    const Real* mass_damping, const Real* stiffness_damping, const Real* ku_corner,
                                    const int* node_cell_offset, const int* node_cell_entry, const Real* mass,
                                    const Real* u_prev, const Real* v_prev, const Real* force, const Real* damping,
                                    Real* rhs) {
  const NewmarkCoefficients<Real> c = newmark_coefficients(dt[0], theta[0], mass_damping[0], stiffness_damping[0]);
  const Vec3<Real> kui = gather_corner_sum(ku_corner, node_cell_offset, node_cell_entry, i);
  Vec3<Real> r = newmark_rhs(c, mass[i], load3(u_prev, i), load3(v_prev, i), kui, load3(force, i));
  if (damping) r += sym3_apply(damping, i, load3(u_prev, i) + c.dt * load3(v_prev, i));
  store3(rhs, i, r);
}

// The corners' share of (K u-)'s cotangent: b_k times their node's right-hand side cotangent.
template <class Real>
SSC_HD inline void adj_newmark_rhs_corners(int i, const PartContext<Real>&, const Real* dt, const Real* theta,
                                           const Real* mass_damping, const Real* stiffness_damping, const Real* rhs_bar,
                                           const int* cell_nodes, Real* ku_corner_bar) {
  const NewmarkCoefficients<Real> c = newmark_coefficients(dt[0], theta[0], mass_damping[0], stiffness_damping[0]);
  for (int k = 0; k < 8; ++k) add3(ku_corner_bar, 8 * i + k, c.b_k * load3(rhs_bar, cell_nodes[8 * i + k]));
}

// The node's cotangents and its shares of the coefficients' (a_m, b_k; double, 2 a node).
template <class Real>
SSC_HD inline void adj_newmark_rhs_node(int i, const PartContext<Real>&, const Real* dt, const Real* theta,
                                        const Real* mass_damping, const Real* stiffness_damping, const Real* mass,
                                        const Real* u_prev, const Real* v_prev, const Real* ku_corner,
                                        const int* node_cell_offset, const int* node_cell_entry, const Real* damping,
                                        const Real* rhs_bar, Real* mass_bar, Real* u_prev_bar, Real* v_prev_bar,
                                        Real* force_bar, Real* damping_bar, double* coefficient_bar_share) {
  const NewmarkCoefficients<Real> c = newmark_coefficients(dt[0], theta[0], mass_damping[0], stiffness_damping[0]);
  const Vec3<Real> kui = gather_corner_sum(ku_corner, node_cell_offset, node_cell_entry, i);
  Vec3<Real> ub = load3(u_prev_bar, i), vb = load3(v_prev_bar, i), fb = load3(force_bar, i);
  Vec3<Real> kb = zero3<Real>();  // the corners' share: adj_newmark_rhs_corners
  NewmarkCoefficientBars<Real> cb;
  const Vec3<Real> rb = load3(rhs_bar, i);
  adj_newmark_rhs(c, mass[i], load3(u_prev, i), load3(v_prev, i), kui, rb, mass_bar[i], ub, vb, kb, fb, cb);
  if (damping) {
    const Vec3<Real> cr = sym3_apply(damping, i, rb);  // C is symmetric
    ub += cr;
    vb += c.dt * cr;
    adj_sym3_apply(damping_bar, i, load3(u_prev, i) + c.dt * load3(v_prev, i), rb);
  }
  store3(u_prev_bar, i, ub);
  store3(v_prev_bar, i, vb);
  store3(force_bar, i, fb);
  coefficient_bar_share[2 * i] = double(cb.a_m);
  coefficient_bar_share[2 * i + 1] = double(cb.b_k);
}

// The time-step solve's start without a guess, component k of node i: u- + dt v-, plus
// theta dt (v- - v_before) where the velocity a step earlier is known (v_before != nullptr):
// the last step's acceleration carried on, as the scheme's u = u- + dt v- + theta dt (v - v-)
// would have it (88.9 -> 72.6 CG iterations a step on the paper's dragon, docs/benchmarks.md).
template <class Real>
SSC_HD inline Real newmark_start(Real dt, Real theta, const Real* u_prev, const Real* v_prev, const Real* v_before,
                                 int k) {
  const Real u = u_prev[k] + dt * v_prev[k];
  return v_before ? u + theta * dt * (v_prev[k] - v_before[k]) : u;
}

// How a time-step solve's x starts on the GPU (the value x_start of its setup, codegen's
// newmark_setup): as it is (the forward's initial guess, newmark_init), at 0, or continuing the
// adjoint solves' warm chain (runtime/solvers.cpp, newmark_adjoint): x holds the later step's
// solution and x_before the one before it, NaN where there is none yet, and the start is
// x + (x - x_before), x or 0.
enum NewmarkXStart : int { kKeepX = 0, kZeroX = 1, kWarmChainX = 2 };

// The solve then starts at the best point (ops/galerkin_start.h) of u- + the span of
// kStartDirections directions, which holds newmark_start: dt v-, dt (v- - v_before) (zero
// without v_before) and the three translations. Component k of direction j, before the
// caller zeroes it on fixed nodes. On the peer dragon 74.0 -> 62.8 CG iterations a step.
constexpr int kStartDirections = 5;
constexpr int kFirstStartTranslation = 2;  // K has the translations in its null space: no element apply
template <class Real>
SSC_HD inline Real newmark_start_direction(int j, Real dt, const Real* v_prev, const Real* v_before, int k) {
  if (j == 0) return dt * v_prev[k];
  if (j == 1) return v_before ? dt * (v_prev[k] - v_before[k]) : Real(0);
  return k % 3 == j - kFirstStartTranslation ? Real(1) : Real(0);
}

// ---- the velocity_update op ----

template <class Real>
SSC_HD inline void velocity_update_node(int i, const PartContext<Real>&, const Real* u, const Real* u_prev,
                                        const Real* v_prev, const Real* dt, const Real* theta, Real* v) {
  const NewmarkCoefficients<Real> c = newmark_coefficients(dt[0], theta[0], Real(0), Real(0));
  store3(v, i, newmark_velocity(c, load3(u, i), load3(u_prev, i), load3(v_prev, i)));
}

template <class Real>
SSC_HD inline void adj_velocity_update_node(int i, const PartContext<Real>&, const Real* dt, const Real* theta,
                                            const Real* v_bar, Real* u_bar, Real* u_prev_bar, Real* v_prev_bar) {
  const NewmarkCoefficients<Real> c = newmark_coefficients(dt[0], theta[0], Real(0), Real(0));
  Vec3<Real> ub = load3(u_bar, i), upb = load3(u_prev_bar, i), vpb = load3(v_prev_bar, i);
  adj_newmark_velocity(c, load3(v_bar, i), ub, upb, vpb);
  store3(u_bar, i, ub);
  store3(u_prev_bar, i, upb);
  store3(v_prev_bar, i, vpb);
}

// ---- the newmark_solve op's adjoint parts, run after the engine's adjoint solve
// A w = u_bar (runtime/solvers.cpp, codegen/solver_snippets.cpp), which leaves w in the op's
// scratch buffer: rhs_bar += w, and the parameters' share of -w^T A u ----

template <class Real>
SSC_HD inline void adj_newmark_solve_rhs(int i, const PartContext<Real>&, const Real* w, Real* rhs_bar) {
  for (int k = 0; k < 3; ++k) rhs_bar[3 * i + k] += w[3 * i + k];
}

// Cell i: the rotation's and the cell's Lame shares of -w^T A u, and the corners of K u (ku,
// for the nodes' part).
template <class Real>
SSC_HD inline void adj_newmark_solve_cell(int i, const PartContext<Real>& cx, const Real* dt, const Real* theta,
                                          const Real* mass_damping, const Real* stiffness_damping, const Real* rotation,
                                          const Real* cell_weights, const int* cell_nodes, const Real* lambda,
                                          const Real* mu, const Real* u, const Real* w, Real* rotation_bar, Real* ku,
                                          Real* lambda_bar, Real* mu_bar) {
  const NewmarkCoefficients<Real> c = newmark_coefficients(dt[0], theta[0], mass_damping[0], stiffness_damping[0]);
  Vec3<Real> pc[8], yb[8], pb[8], y[8];
  load_cell_corners(u, cell_nodes, i, pc);
  for (int k = 0; k < 8; ++k) {
    yb[k] = (-c.a_k) * load3(w, cell_nodes[8 * i + k]);
    pb[k] = zero3<Real>();
  }
  const Mat3<Real> R = load_mat3(rotation, i);
  Mat3<Real> R_bar = zero33<Real>();
  adj_corotated_apply(R, cell_weights + 8 * i, lambda[i], mu[i], cx.h, pc, yb, R_bar, lambda_bar[i], mu_bar[i], pb);
  add_mat3(rotation_bar, i, R_bar);
  corotated_apply(R, cell_weights + 8 * i, lambda[i], mu[i], cx.h, pc, y);
  for (int k = 0; k < 8; ++k) store3(ku, 8 * i + k, y[k]);
}

// Node i: the mass's and C's share of -w^T A u, and the coefficients' shares (a_m, a_k;
// double, 2 a node; 0 on fixed nodes, which the system leaves out).
template <class Real>
SSC_HD inline void adj_newmark_solve_node(int i, const PartContext<Real>&, const Real* dt, const Real* theta,
                                          const Real* mass_damping, const Real* stiffness_damping, const Real* mass,
                                          const Real* fixed, const Real* u, const Real* w, const Real* ku,
                                          const int* node_cell_offset, const int* node_cell_entry, Real* mass_bar,
                                          Real* damping_bar, double* coefficient_bar_share) {
  if (fixed[i] != Real(0)) {
    coefficient_bar_share[2 * i] = 0;
    coefficient_bar_share[2 * i + 1] = 0;
    return;
  }
  const NewmarkCoefficients<Real> c = newmark_coefficients(dt[0], theta[0], mass_damping[0], stiffness_damping[0]);
  const Vec3<Real> kui = gather_corner_sum(ku, node_cell_offset, node_cell_entry, i);
  Vec3<Real> ub = zero3<Real>(), kb = zero3<Real>();
  NewmarkCoefficientBars<Real> cb;
  const Vec3<Real> y_bar = Real(-1) * load3(w, i);
  adj_newmark_system_apply(c, mass[i], load3(u, i), kui, y_bar, mass_bar[i], ub, kb, cb);
  if (damping_bar) adj_sym3_apply(damping_bar, i, load3(u, i), y_bar);
  coefficient_bar_share[2 * i] = double(cb.a_m);
  coefficient_bar_share[2 * i + 1] = double(cb.a_k);
}

#ifdef SSC_OP_SPECS
inline OpSpec newmark_rhs_spec() {
  OpSpec s;
  s.name = "newmark_rhs";
  s.domain = Domain::Node;
  s.slots = {in("ku_corner", Access::Gather), in("mass"), in("u_prev"), in("v_prev"), in("force"),
             optional_in("damping"), constant_in("dt"), constant_in("theta"), in("mass_damping"),
             in("stiffness_damping"), out("rhs")};
  s.scratch = {{"red", Domain::Node, 2, ""}};
  s.forward = {part("newmark_rhs", Extent::Node, SSC_PART(newmark_rhs_node),
                    {"dt", "theta", "mass_damping", "stiffness_damping", "ku_corner^", "#node_cell_offset",
                     "#node_cell_entry", "mass", "u_prev", "v_prev", "force", "damping", "rhs"})};
  s.adjoint = {part("newmark_rhs_corners", Extent::Cell, SSC_ADJOINT_PART(adj_newmark_rhs_corners),
                    {"dt", "theta", "mass_damping", "stiffness_damping", "d_rhs^", "#cell_nodes", "d_ku_corner"}),
               part("newmark_rhs", Extent::Node, SSC_ADJOINT_PART(adj_newmark_rhs_node),
                    {"dt", "theta", "mass_damping", "stiffness_damping", "mass", "u_prev", "v_prev", "ku_corner^",
                     "#node_cell_offset", "#node_cell_entry", "damping", "d_rhs", "d_mass", "d_u_prev", "d_v_prev",
                     "d_force", "d_damping", "$red"}),
               reduction("newmark_rhs_reduce", {"$red"}, {"d_mass_damping", "d_stiffness_damping"})};
  return s;
}

// (a_m M + a_k R K R^T + C) u = rhs on the free nodes: the engine's Jacobi-PCG schedule
// "newmark_pcg" (runtime/solvers.cpp, codegen/solver_snippets.cpp); its adjoint solves the
// same system for the cotangent, w = A^-1 u_bar into the scratch buffer w, and the adjoint
// parts hand the parameters -w^T dA/dp u. An optional guess (not differentiated: the solution
// does not depend on it) starts the CG iterations instead of newmark_start's prediction, which
// the optional v_before (the velocity a step earlier) improves.
inline OpSpec newmark_solve_spec() {
  OpSpec s;
  s.name = "newmark_solve";
  s.domain = Domain::Node;
  s.solver = "newmark_pcg";
  s.slots = {in("rotation", Access::Opaque), in("lambda", Access::Opaque), in("mu", Access::Opaque),
             in("mass", Access::Opaque), in("rhs", Access::Opaque),
             constant_in("u_prev", Access::Opaque), constant_in("v_prev", Access::Opaque),
             constant_in("fixed", Access::Opaque), optional_in("damping", Access::Opaque),
             SlotSpec{"guess", false, Access::Opaque, true, false},
             SlotSpec{"v_before", false, Access::Opaque, true, false}, constant_in("dt"),
             constant_in("theta"), in("mass_damping"), in("stiffness_damping"), out("u"), out("cg_iterations")};
  s.slots.back().differentiable = false;
  s.scratch = {{"w", Domain::Node, 3, ""}, {"ku", Domain::Cell, 24, ""}, {"red", Domain::Node, 2, ""}};
  s.adjoint = {part("newmark_solve_rhs", Extent::Node, SSC_ADJOINT_PART(adj_newmark_solve_rhs), {"$w", "d_rhs"}),
               part("newmark_solve_cells", Extent::Cell, SSC_ADJOINT_PART(adj_newmark_solve_cell),
                    {"dt", "theta", "mass_damping", "stiffness_damping", "rotation", "#cell_weights", "#cell_nodes",
                     "lambda", "mu", "u^", "$w^", "d_rotation", "$ku", "d_lambda", "d_mu"}),
               part("newmark_solve_nodes", Extent::Node, SSC_ADJOINT_PART(adj_newmark_solve_node),
                    {"dt", "theta", "mass_damping", "stiffness_damping", "mass", "fixed", "u", "$w", "$ku^",
                     "#node_cell_offset", "#node_cell_entry", "d_mass", "d_damping", "$red"}),
               reduction("newmark_solve_reduce", {"$red"}, {"d_mass_damping", "d_stiffness_damping"})};
  return s;
}

inline OpSpec velocity_update_spec() {
  OpSpec s;
  s.name = "velocity_update";
  s.domain = Domain::Node;
  s.slots = {in("u"), in("u_prev"), in("v_prev"), constant_in("dt"), constant_in("theta"), out("v")};
  s.forward = {part("velocity_update", Extent::Node, SSC_PART(velocity_update_node),
                    {"u", "u_prev", "v_prev", "dt", "theta", "v"})};
  s.adjoint = {part("velocity_update", Extent::Node, SSC_ADJOINT_PART(adj_velocity_update_node),
                    {"dt", "theta", "d_v", "d_u", "d_u_prev", "d_v_prev"})};
  return s;
}
#endif

}  // namespace ops
}  // namespace ssc
