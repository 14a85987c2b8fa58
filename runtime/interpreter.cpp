// Executors of the CPU interpreter: one function per op kind binds the op's tensors and
// loops the op body of ops/ over its domain (see interpreter.h).
#include "runtime/interpreter.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

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
#include "runtime/pcg.h"

namespace ssc {

DomainSizes domain_sizes(const StaticArrays& grid) {
  DomainSizes s;
  s.cell = grid.cell_count;
  s.node = grid.node_count;
  s.point = int(grid.contact_points.size());
  s.band = grid.band_count;
  return s;
}

template <class Real>
static std::vector<Real> real_copy(const std::vector<double>& v) {
  return std::vector<Real>(v.begin(), v.end());
}

template <class Real>
Interpreter<Real>::Interpreter(const Graph& graph, const StaticArrays& grid, int batch, const SolverOptions& options)
    : graph_(graph),
      grid_(grid),
      options_(options),
      store_(graph, domain_sizes(grid), batch),
      adjoint_(graph, domain_sizes(grid), batch) {
  graph_.validate();
  for (const ContactPoint& p : grid.contact_points) {
    point_t_.push_back(Real(p.t));
    point_area_.push_back(Real(p.area));
    point_nodes_.push_back(p.node_a);
    point_nodes_.push_back(p.node_b);
  }
  weights_ = real_copy<Real>(grid.cell_volume_weights);
  node_rest_ = real_copy<Real>(grid.node_rest);
  extension_adjoint_guess_.assign(batch, {});
}

template <class Real>
void Interpreter<Real>::run() {
  const int B = batch();
  report_.cg_iterations.assign(B, 0);
  report_.cg_residual.assign(B, 0.0);
  report_.extension_iterations.assign(B, 0);
  report_.degenerate_cells.assign(B, 0);
  for (const OpNode& op : graph_.ops()) execute(op);
}

template <class Real>
void Interpreter<Real>::run_op(int op) {
  const int B = batch();
  if (int(report_.cg_iterations.size()) != B) {
    report_.cg_iterations.assign(B, 0);
    report_.cg_residual.assign(B, 0.0);
    report_.extension_iterations.assign(B, 0);
    report_.degenerate_cells.assign(B, 0);
  }
  execute(graph_.ops().at(op));
}


template <class Real>
void Interpreter<Real>::execute(const OpNode& op) {
  for_each_batch_item(batch(), [&](int b) { execute_item(op, b); });
}

template <class Real>
void Interpreter<Real>::execute_item(const OpNode& op, int b) {
  const StaticArrays& g = grid_;
  const Real h = Real(g.h);
  const std::vector<Real>& weights = weights_;

  Binder<Real> a{store_, op, b};
  switch (op.kind) {
    case OpKind::Lame: {
      Real lambda, mu;
      ops::lame_from_young(a.scalar("youngs_modulus"), a.scalar("poisson_ratio"), lambda, mu);
      a.out("lambda")[0] = lambda;
      a.out("mu")[0] = mu;
      break;
    }
    case OpKind::NodeMass: {
      const Real rho = a.scalar("density");
      Real* m = a.out("mass");
      for (int i = 0; i < g.node_count; ++i) m[i] = ops::node_mass(rho, Real(g.node_volume[i]));
      break;
    }
    case OpKind::Corotation: {
      const Real* u = a.in("u_prev");
      Real* rot = a.out("rotation");
      Real* status = a.out("polar_status");
      int degenerate = 0;
#pragma omp parallel for schedule(static) reduction(+ : degenerate) if (g.cell_count >= kCellParallelThreshold)
      for (int e = 0; e < g.cell_count; ++e)
        degenerate += ops::corotation_cell(e, u, g.cell_nodes.data(), h, rot, status) == ops::kPolarDegenerate;
      report_.degenerate_cells[b] = degenerate;
      break;
    }
    case OpKind::CorotationForce: {
      const Real* rot = a.in("rotation");
      const Real lambda = a.scalar("lambda"), mu = a.scalar("mu");
      Real* f = a.out("corner_force");
#pragma omp parallel for schedule(static) if (g.cell_count >= kCellParallelThreshold)
      for (int e = 0; e < g.cell_count; ++e) ops::corotation_force_cell(e, rot, weights.data(), lambda, mu, h, f);
      break;
    }
    case OpKind::ContactForce: {
      const Real* u = a.in("u_prev");
      const Real* v = a.in("v_prev");
      ops::GroundPlane<Real> planes[ops::kMaxGroundPlanes];
      const int plane_count = load_ground_planes(store_, op, b, planes);
      const Real dt = a.scalar("dt"), theta = a.scalar("theta");
      Real* f = a.out("point_force");
      const int n = int(g.contact_points.size());
#pragma omp parallel for schedule(static) if (n >= kParallelThreshold)
      for (int p = 0; p < n; ++p)
        store3(f, p, ops::contact_point_force(p, point_nodes_.data(), point_t_.data(), point_area_.data(), node_rest_.data(),
                                              u, v, planes, plane_count, dt, theta));
      break;
    }
    case OpKind::NodeForce: {
      const Real* corner = a.in("corner_force");
      const Real* point = a.has_input("point_force") ? a.in("point_force") : nullptr;
      const Real* m = a.in("mass");
      const Vec3<Real> grav = load3(a.in("gravity"), 0);
      Real* f = a.out("force");
#pragma omp parallel for schedule(static) if (g.node_count >= kParallelThreshold)
      for (int i = 0; i < g.node_count; ++i) {
        const Vec3<Real> corners = ops::gather_corner_sum(corner, g.node_cell_offset.data(), g.node_cell_entry.data(), i);
        const Vec3<Real> points =
            point ? ops::gather_point_sum(point, point_t_.data(), g.node_point_offset.data(), g.node_point_entry.data(), i)
                  : zero3<Real>();
        store3(f, i, ops::node_force(m[i], grav, corners, points));
      }
      break;
    }
    case OpKind::StiffnessApply:
      stiffness_apply_cells(g, a.in("rotation"), weights.data(), a.scalar("lambda"), a.scalar("mu"), a.in("u_prev"),
                            a.out("ku_corner"));
      break;
    case OpKind::NewmarkRhs: {
      const auto c = ops::newmark_coefficients(a.scalar("dt"), a.scalar("theta"), a.scalar("mass_damping"),
                                               a.scalar("stiffness_damping"));
      const Real* ku = a.in("ku_corner");
      const Real *m = a.in("mass"), *u = a.in("u_prev"), *v = a.in("v_prev"), *f = a.in("force");
      Real* rhs = a.out("rhs");
#pragma omp parallel for schedule(static) if (g.node_count >= kParallelThreshold)
      for (int i = 0; i < g.node_count; ++i) {
        const Vec3<Real> kui = ops::gather_corner_sum(ku, g.node_cell_offset.data(), g.node_cell_entry.data(), i);
        store3(rhs, i, ops::newmark_rhs(c, m[i], load3(u, i), load3(v, i), kui, load3(f, i)));
      }
      break;
    }
    case OpKind::NewmarkSolve: {
      const auto c = ops::newmark_coefficients(a.scalar("dt"), a.scalar("theta"), a.scalar("mass_damping"),
                                               a.scalar("stiffness_damping"));
      const Real *u_prev = a.in("u_prev"), *v_prev = a.in("v_prev"), *fixed = a.in("fixed");
      Real* u = a.out("u");
      for (int i = 0; i < 3 * g.node_count; ++i) u[i] = fixed[i / 3] != Real(0) ? Real(0) : u_prev[i] + c.dt * v_prev[i];
      const NewmarkSystem<Real> system{g, weights, a.in("rotation"), a.scalar("lambda"), a.scalar("mu"), a.in("mass"), fixed, c};
      const PcgResult r = system.solve(a.in("rhs"), u, options_.cg_tolerance, options_.cg_max_iterations);
      report_.cg_iterations[b] = r.iterations;
      report_.cg_residual[b] = r.relative_residual;
      a.out("cg_iterations")[0] = Real(r.iterations);
      if (!r.converged)
        throw SimulationError(fmt::format(
            "the time-step solve did not converge (batch item {}): relative residual {:.3g} after {} CG "
            "iterations (tolerance {:.3g}); the simulation is probably unstable: lower time.dt, or raise "
            "solver.max_iterations",
            b, r.relative_residual, r.iterations, options_.cg_tolerance));
      break;
    }
    case OpKind::VelocityUpdate: {
      const auto c = ops::newmark_coefficients(a.scalar("dt"), a.scalar("theta"), Real(0), Real(0));
      const Real *u = a.in("u"), *u_prev = a.in("u_prev"), *v_prev = a.in("v_prev");
      Real* v = a.out("v");
      for (int i = 0; i < g.node_count; ++i)
        store3(v, i, ops::newmark_velocity(c, load3(u, i), load3(u_prev, i), load3(v_prev, i)));
      break;
    }
    case OpKind::ExtensionSolve: {
      const Real* u = a.in("u");
      Real* x = a.out("band_u");
      std::vector<Real> rhs(3 * size_t(g.band_count));
      for (int i = 0; i < g.band_count; ++i) {
        Vec3<Real> s = zero3<Real>();
        for (int d = 0; d < 6; ++d) {
          const int nb = g.band_neighbors[6 * i + d];
          if (nb <= -2) s += load3(u, -nb - 2);
        }
        store3(rhs.data(), i, s);
      }
      std::copy_n(a.in("band_guess"), rhs.size(), x);
      const PcgResult r = solve_band_laplacian(g, rhs.data(), x, options_.extension_tolerance, options_.extension_max_iterations);
      report_.extension_iterations[b] = r.iterations;
      if (!r.converged)
        throw SimulationError(fmt::format("the displacement extension did not converge (batch item {}): relative "
                                          "residual {:.3g} after {} iterations",
                                          b, r.relative_residual, r.iterations));
      break;
    }
  }
}

template class Interpreter<double>;
template class Interpreter<float>;

}  // namespace ssc
