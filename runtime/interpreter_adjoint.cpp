// Reverse-mode executors of the CPU interpreter: for each op kind, the adjoint of its
// forward executor (interpreter.cpp), built from the adj_ functions next to the op
// bodies in ops/. Element-to-node transfers go through per-corner buffers and fixed-order
// node gathers, scalar parameter gradients through fixed-order sums: deterministic.
#include <fmt/format.h>

#include "runtime/errors.h"
#include "ops/contact.h"
#include "ops/corotation.h"
#include "ops/elasticity.h"
#include "ops/gather.h"
#include "ops/newmark.h"
#include "ops/nodal.h"
#include "ops/polar.h"
#include "runtime/batch_loop.h"
#include "runtime/cpu_kernels.h"
#include "runtime/interpreter.h"

namespace ssc {

template <class Real>
void Interpreter<Real>::clear_adjoints(bool including_inputs) {
  if (including_inputs) extension_adjoint_guess_.assign(batch(), {});  // a new backward pass
  for (size_t t = 0; t < graph_.tensors().size(); ++t)
    if (including_inputs || graph_.tensor(int(t)).role != TensorInfo::Role::Input)
      std::fill(adjoint_.all(int(t)).begin(), adjoint_.all(int(t)).end(), Real(0));
}

template <class Real>
void Interpreter<Real>::run_adjoint() {
  for (auto it = graph_.ops().rbegin(); it != graph_.ops().rend(); ++it) execute_adjoint(*it);
}

template <class Real>
void Interpreter<Real>::run_op_adjoint(int op) {
  execute_adjoint(graph_.ops().at(op));
}

namespace {

// Sums per-cell partial values in cell order (deterministic).
template <class Real>
Real ordered_sum(const std::vector<Real>& v) {
  double s = 0;
  for (Real x : v) s += double(x);
  return Real(s);
}

}  // namespace

template <class Real>
void Interpreter<Real>::execute_adjoint(const OpNode& op) {
  for_each_batch_item(batch(), [&](int b) { execute_adjoint_item(op, b); });
}

template <class Real>
void Interpreter<Real>::execute_adjoint_item(const OpNode& op, int b) {
  const StaticArrays& g = grid_;
  const Real h = Real(g.h);
  const std::vector<Real>& weights = weights_;
  const size_t corner_size = 24 * size_t(g.cell_count);

  Binder<Real> a{store_, op, b};   // forward values
  Binder<Real> d{adjoint_, op, b};  // cotangents (in: accumulated into; out: seeds)
  switch (op.kind) {
    case OpKind::Lame: {
      ops::adj_lame_from_young(a.scalar("youngs_modulus"), a.scalar("poisson_ratio"), d.out("lambda")[0],
                               d.out("mu")[0], const_cast<Real*>(d.in("youngs_modulus"))[0],
                               const_cast<Real*>(d.in("poisson_ratio"))[0]);
      break;
    }
    case OpKind::NodeMass: {
      const Real* m_bar = d.out("mass");
      double s = 0;
      for (int i = 0; i < g.node_count; ++i) ops::adj_node_mass(g.node_volume[i], double(m_bar[i]), s);
      const_cast<Real*>(d.in("density"))[0] += Real(s);
      break;
    }
    case OpKind::Corotation: {
      const Real* u = a.in("u_prev");
      const Real* rot = a.out("rotation");
      const Real* status = a.out("polar_status");
      const Real* rot_bar = d.out("rotation");
      std::vector<Real> corner(corner_size, Real(0));
#pragma omp parallel for schedule(static) if (g.cell_count >= kCellParallelThreshold)
      for (int e = 0; e < g.cell_count; ++e)
        ops::adj_corotation_cell(e, u, g.cell_nodes.data(), h, rot, status, rot_bar, corner.data());
      gather_corners_to_nodes(g, corner.data(), const_cast<Real*>(d.in("u_prev")), true);
      break;
    }
    case OpKind::CorotationForce: {
      const Real* rot = a.in("rotation");
      const Real lambda = a.scalar("lambda"), mu = a.scalar("mu");
      const Real* f_bar = d.out("corner_force");
      Real* rot_bar = const_cast<Real*>(d.in("rotation"));
      std::vector<Real> lb(g.cell_count), mb(g.cell_count);
#pragma omp parallel for schedule(static) if (g.cell_count >= kCellParallelThreshold)
      for (int e = 0; e < g.cell_count; ++e) {
        Real l = Real(0), m = Real(0);
        ops::adj_corotation_force_cell(e, rot, weights.data(), lambda, mu, h, f_bar, rot_bar, l, m);
        lb[e] = l;
        mb[e] = m;
      }
      const_cast<Real*>(d.in("lambda"))[0] += ordered_sum(lb);
      const_cast<Real*>(d.in("mu"))[0] += ordered_sum(mb);
      break;
    }
    case OpKind::ContactForce: {
      const Real *u = a.in("u_prev"), *v = a.in("v_prev");
      ops::GroundPlane<Real> planes[ops::kMaxGroundPlanes];
      const int plane_count = load_ground_planes(store_, op, b, planes);
      const Real dt = a.scalar("dt"), theta = a.scalar("theta");
      const Real* f_bar = d.out("point_force");
      const int n = int(g.contact_points.size());
      std::vector<Real> x_bar(3 * size_t(n)), v_bar(3 * size_t(n)), plane_bar(4 * size_t(n) * plane_count);
#pragma omp parallel for schedule(static) if (n >= kParallelThreshold)
      for (int p = 0; p < n; ++p) {
        Vec3<Real> xb_ = zero3<Real>(), vb_ = zero3<Real>();
        Vec3<Real> nb[ops::kMaxGroundPlanes];
        Real hb[ops::kMaxGroundPlanes];
        for (int k = 0; k < plane_count; ++k) {
          nb[k] = zero3<Real>();
          hb[k] = Real(0);
        }
        ops::adj_contact_point_force(p, point_nodes_.data(), point_t_.data(), point_area_.data(), node_rest_.data(), u, v,
                                     planes, plane_count, dt, theta, load3(f_bar, p), xb_, vb_, nb, hb);
        store3(x_bar.data(), p, xb_);
        store3(v_bar.data(), p, vb_);
        for (int k = 0; k < plane_count; ++k) {
          Real* pb = plane_bar.data() + 4 * (size_t(p) * plane_count + k);
          pb[0] = nb[k].x, pb[1] = nb[k].y, pb[2] = nb[k].z, pb[3] = hb[k];
        }
      }
      Real* u_bar = const_cast<Real*>(d.in("u_prev"));
      Real* vv_bar = const_cast<Real*>(d.in("v_prev"));
#pragma omp parallel for schedule(static) if (g.node_count >= kParallelThreshold)
      for (int i = 0; i < g.node_count; ++i) {
        add3(u_bar, i, ops::gather_point_sum(x_bar.data(), point_t_.data(), g.node_point_offset.data(), g.node_point_entry.data(), i));
        add3(vv_bar, i, ops::gather_point_sum(v_bar.data(), point_t_.data(), g.node_point_offset.data(), g.node_point_entry.data(), i));
      }
      Real* planes_bar = const_cast<Real*>(d.in("ground_planes"));
      for (int k = 0; k < plane_count; ++k)
        for (int j = 0; j < 4; ++j) {
          double s = 0;
          for (int p = 0; p < n; ++p) s += double(plane_bar[4 * (size_t(p) * plane_count + k) + j]);
          planes_bar[6 * k + j] += Real(s);
        }
      break;
    }
    case OpKind::NodeForce: {
      const Real* f_bar = d.out("force");
      const Real* m = a.in("mass");
      const Vec3<Real> grav = load3(a.in("gravity"), 0);
      Real* corner_bar = const_cast<Real*>(d.in("corner_force"));
#pragma omp parallel for schedule(static) if (g.cell_count >= kCellParallelThreshold)
      for (int e = 0; e < g.cell_count; ++e)
        for (int c = 0; c < 8; ++c) add3(corner_bar, 8 * e + c, load3(f_bar, g.cell_nodes[8 * e + c]));
      if (a.has_input("point_force")) {
        Real* point_bar = const_cast<Real*>(d.in("point_force"));
        for (int p = 0; p < int(g.contact_points.size()); ++p) {
          const ContactPoint& cp = g.contact_points[p];
          const Real t = point_t_[p];
          add3(point_bar, p, (Real(1) - t) * load3(f_bar, cp.node_a) + t * load3(f_bar, cp.node_b));
        }
      }
      Real* m_bar = const_cast<Real*>(d.in("mass"));
      double gb[3] = {0, 0, 0};
      for (int i = 0; i < g.node_count; ++i) {
        Vec3<Real> grav_bar = zero3<Real>(), sum_bar = zero3<Real>();
        ops::adj_node_force(m[i], grav, load3(f_bar, i), m_bar[i], grav_bar, sum_bar);
        for (int k = 0; k < 3; ++k) gb[k] += double(grav_bar[k]);
      }
      Real* g_bar = const_cast<Real*>(d.in("gravity"));
      for (int k = 0; k < 3; ++k) g_bar[k] += Real(gb[k]);
      break;
    }
    case OpKind::StiffnessApply: {
      const Real* rot = a.in("rotation");
      const Real lambda = a.scalar("lambda"), mu = a.scalar("mu");
      const Real* u = a.in("u_prev");
      const Real* y_bar = d.out("ku_corner");
      Real* rot_bar = const_cast<Real*>(d.in("rotation"));
      std::vector<Real> corner(corner_size), lb(g.cell_count), mb(g.cell_count);
#pragma omp parallel for schedule(static) if (g.cell_count >= kCellParallelThreshold)
      for (int e = 0; e < g.cell_count; ++e) {
        Real l = Real(0), m = Real(0);
        ops::adj_stiffness_apply_cell(e, rot, weights.data(), lambda, mu, h, u, g.cell_nodes.data(), y_bar, rot_bar,
                                      corner.data(), l, m);
        lb[e] = l;
        mb[e] = m;
      }
      gather_corners_to_nodes(g, corner.data(), const_cast<Real*>(d.in("u_prev")), true);
      const_cast<Real*>(d.in("lambda"))[0] += ordered_sum(lb);
      const_cast<Real*>(d.in("mu"))[0] += ordered_sum(mb);
      break;
    }
    case OpKind::NewmarkRhs: {
      const auto c = ops::newmark_coefficients(a.scalar("dt"), a.scalar("theta"), a.scalar("mass_damping"),
                                               a.scalar("stiffness_damping"));
      const Real *m = a.in("mass"), *u = a.in("u_prev"), *v = a.in("v_prev"), *ku = a.in("ku_corner");
      const Real* r_bar = d.out("rhs");
      Real *m_bar = const_cast<Real*>(d.in("mass")), *u_bar = const_cast<Real*>(d.in("u_prev"));
      Real *v_bar = const_cast<Real*>(d.in("v_prev")), *f_bar = const_cast<Real*>(d.in("force"));
      std::vector<Real> ku_node_bar(3 * size_t(g.node_count));
      double alpha_bar = 0, beta_bar = 0;
      for (int i = 0; i < g.node_count; ++i) {
        const Vec3<Real> kui = ops::gather_corner_sum(ku, g.node_cell_offset.data(), g.node_cell_entry.data(), i);
        Vec3<Real> ub = load3(u_bar, i), vb = load3(v_bar, i), fb = load3(f_bar, i), kb = zero3<Real>();
        ops::NewmarkCoefficientBars<Real> cb;
        ops::adj_newmark_rhs(c, m[i], load3(u, i), load3(v, i), kui, load3(r_bar, i), m_bar[i], ub, vb, kb, fb, cb);
        store3(u_bar, i, ub);
        store3(v_bar, i, vb);
        store3(f_bar, i, fb);
        store3(ku_node_bar.data(), i, kb);
        alpha_bar += double(cb.a_m);
        beta_bar += double(cb.b_k);
      }
      // The corners' share of the node's (K u-) cotangent: the adjoint of the gather.
      Real* ku_bar = const_cast<Real*>(d.in("ku_corner"));
#pragma omp parallel for schedule(static) if (g.cell_count >= kCellParallelThreshold)
      for (int e = 0; e < g.cell_count; ++e)
        for (int k = 0; k < 8; ++k) add3(ku_bar, 8 * e + k, load3(ku_node_bar.data(), g.cell_nodes[8 * e + k]));
      const_cast<Real*>(d.in("mass_damping"))[0] += Real(alpha_bar);
      const_cast<Real*>(d.in("stiffness_damping"))[0] += Real(beta_bar);
      break;
    }
    case OpKind::NewmarkSolve: {
      const auto c = ops::newmark_coefficients(a.scalar("dt"), a.scalar("theta"), a.scalar("mass_damping"),
                                               a.scalar("stiffness_damping"));
      const Real* rot = a.in("rotation");
      const Real lambda = a.scalar("lambda"), mu = a.scalar("mu");
      const Real *m = a.in("mass"), *u = a.out("u"), *fixed = a.in("fixed");
      const Real* u_bar = d.out("u");
      const long n = 3L * g.node_count;
      // mu_adj = A^-1 u_bar (A symmetric), then rhs_bar += mu_adj and the parameters
      // receive -d(mu_adj^T A u)/d(parameter).
      std::vector<Real> w(n, Real(0));
      const NewmarkSystem<Real> system{g, weights, rot, lambda, mu, m, fixed, c};
      const PcgResult r = system.solve(u_bar, w.data(), options_.cg_tolerance, options_.cg_max_iterations);
      if (!r.converged)
        throw SimulationError(fmt::format("the adjoint time-step solve did not converge (batch item {}): relative "
                                          "residual {:.3g} after {} iterations",
                                          b, r.relative_residual, r.iterations));
      Real* rhs_bar = const_cast<Real*>(d.in("rhs"));
      for (long i = 0; i < n; ++i) rhs_bar[i] += w[i];
      std::vector<Real> corner(corner_size), lb(g.cell_count), mb(g.cell_count), ku(corner_size);
      Real* rot_bar = const_cast<Real*>(d.in("rotation"));
#pragma omp parallel for schedule(static) if (g.cell_count >= kCellParallelThreshold)
      for (int e = 0; e < g.cell_count; ++e) {
        Vec3<Real> pc[8], yb[8], pb[8], y[8];
        ops::load_cell_corners(u, g.cell_nodes.data(), e, pc);
        for (int k = 0; k < 8; ++k) {
          yb[k] = (-c.a_k) * load3(w.data(), g.cell_nodes[8 * e + k]);
          pb[k] = zero3<Real>();
        }
        const Mat3<Real> R = ops::load_mat3(rot, e);
        Mat3<Real> R_bar = zero33<Real>();
        Real l = Real(0), mm = Real(0);
        ops::adj_corotated_apply(R, weights.data() + 8 * e, lambda, mu, h, pc, yb, R_bar, l, mm, pb);
        ops::add_mat3(rot_bar, e, R_bar);
        ops::corotated_apply(R, weights.data() + 8 * e, lambda, mu, h, pc, y);
        for (int k = 0; k < 8; ++k) store3(ku.data(), 8 * e + k, y[k]);
        lb[e] = l;
        mb[e] = mm;
      }
      const_cast<Real*>(d.in("lambda"))[0] += ordered_sum(lb);
      const_cast<Real*>(d.in("mu"))[0] += ordered_sum(mb);
      Real* m_bar = const_cast<Real*>(d.in("mass"));
      double alpha_bar = 0, beta_bar = 0;
      for (int i = 0; i < g.node_count; ++i) {
        if (fixed[i] != Real(0)) continue;
        // The parameters' share of -mu_adj^T A u: the system's adjoint at y_bar = -mu_adj.
        const Vec3<Real> kui = ops::gather_corner_sum(ku.data(), g.node_cell_offset.data(), g.node_cell_entry.data(), i);
        Vec3<Real> ub = zero3<Real>(), kb = zero3<Real>();
        ops::NewmarkCoefficientBars<Real> cb;
        ops::adj_newmark_system_apply(c, m[i], load3(u, i), kui, Real(-1) * load3(w.data(), i), m_bar[i], ub, kb, cb);
        alpha_bar += double(cb.a_m);
        beta_bar += double(cb.a_k);
      }
      const_cast<Real*>(d.in("mass_damping"))[0] += Real(alpha_bar);
      const_cast<Real*>(d.in("stiffness_damping"))[0] += Real(beta_bar);
      break;
    }
    case OpKind::VelocityUpdate: {
      const auto c = ops::newmark_coefficients(a.scalar("dt"), a.scalar("theta"), Real(0), Real(0));
      const Real* v_bar = d.out("v");
      Real *u_bar = const_cast<Real*>(d.in("u")), *up_bar = const_cast<Real*>(d.in("u_prev"));
      Real* vp_bar = const_cast<Real*>(d.in("v_prev"));
      for (int i = 0; i < g.node_count; ++i) {
        Vec3<Real> ub = load3(u_bar, i), upb = load3(up_bar, i), vpb = load3(vp_bar, i);
        ops::adj_newmark_velocity(c, load3(v_bar, i), ub, upb, vpb);
        store3(u_bar, i, ub);
        store3(up_bar, i, upb);
        store3(vp_bar, i, vpb);
      }
      break;
    }
    case OpKind::ExtensionSolve: {
      const Real* x_bar = d.out("band_u");
      // Warm start from the previous (later) step's solution of this backward pass.
      std::vector<Real>& y = extension_adjoint_guess_[b];
      y.resize(3 * size_t(g.band_count), Real(0));
      const PcgResult r = solve_band_laplacian(g, x_bar, y.data(), options_.extension_tolerance, options_.extension_max_iterations);
      if (!r.converged)
        throw SimulationError(fmt::format("the adjoint extension solve did not converge (batch item {})", b));
      Real* u_bar = const_cast<Real*>(d.in("u"));
      for (int i = 0; i < g.band_count; ++i)
        for (int k = 0; k < 6; ++k) {
          const int nb = g.band_neighbors[6 * i + k];
          if (nb <= -2) add3(u_bar, -nb - 2, load3(y.data(), i));
        }
      break;
    }
  }
}

#define SSC_INSTANTIATE_ADJOINT(Real)                             \
  template void Interpreter<Real>::clear_adjoints(bool);          \
  template void Interpreter<Real>::run_adjoint();                 \
  template void Interpreter<Real>::run_op_adjoint(int);           \
  template void Interpreter<Real>::execute_adjoint(const OpNode&);    \
  template void Interpreter<Real>::execute_adjoint_item(const OpNode&, int);
SSC_INSTANTIATE_ADJOINT(double)
SSC_INSTANTIATE_ADJOINT(float)

}  // namespace ssc
