// The interpreter's solver schedules (see solvers.h).
#include "runtime/solvers.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include "ops/corotation.h"
#include "ops/elasticity.h"
#include "ops/gather.h"
#include "ops/newmark.h"
#include "runtime/errors.h"
#include "runtime/band_factor.h"
#include "runtime/element_packs.h"
#include "runtime/galerkin_start.h"
#include "runtime/pcg.h"
#include "runtime/system_dump.h"

namespace ssc {
namespace {

// The slots of one op for batch item b: values and cotangents by name.
template <class Real>
struct Slots {
  Interpreter<Real>& in;
  const OpNode& op;
  int b;
  const Real* value(const char* slot) const {
    const SlotSpec* s = op.spec->slot(slot);
    return in.store().data(s->output ? op.output(slot) : op.input(slot), b);
  }
  Real* out(const char* slot) const { return in.store().data(op.output(slot), b); }
  Real* bar(const char* slot) const {
    const SlotSpec* s = op.spec->slot(slot);
    return in.adjoint().data(s->output ? op.output(slot) : op.input(slot), b);
  }
  Real scalar(const char* slot) const { return value(slot)[0]; }
  const Real* optional(const char* slot) const { return op.bound(slot) ? value(slot) : nullptr; }
};

// Whether a double solve applies the cells in float (SolverOptions::single_precision_cells, or
// SSC_CPU_SINGLE_APPLY=1; SSC_CPU_SCALAR_APPLY=1 keeps the scalar double apply).
bool single_precision_cells(const SolverOptions& o) {
  return (o.single_precision_cells || std::getenv("SSC_CPU_SINGLE_APPLY")) && !std::getenv("SSC_CPU_SCALAR_APPLY");
}

// The SPD time-step system with fixed nodes eliminated (identity rows and columns).
template <class Real>
struct NewmarkSystem {
  const StaticArrays& g;
  const Real* weights;
  const Real* rotation;
  const Real *lambda, *mu;  // per cell
  const Real* mass;
  const Real* fixed;
  const Real* damping;  // C, 6 per node, or nullptr
  ops::NewmarkCoefficients<Real> c;
  bool single = false;  // the cells' arithmetic in float (SolverOptions::single_precision_cells)

  bool is_fixed(int i) const { return fixed[i] != Real(0); }

  Vec3<Real> node_apply(int i, Vec3<Real> p, Vec3<Real> kp) const {
    const Vec3<Real> y = ops::newmark_system_apply(c, mass[i], p, kp);
    return damping ? y + ops::sym3_apply(damping, i, p) : y;
  }

  void cell_apply(const Real* p, Real* corner) const {
    if constexpr (std::is_same_v<Real, double>) {  // cells in SIMD packs (runtime/element_packs.h)
      static const bool scalar = std::getenv("SSC_CPU_SCALAR_APPLY") != nullptr;  // for comparisons
      if (!scalar) {
        stiffness_apply_cells(g.cell_count, g.h, rotation, weights, lambda, mu, p, g.cell_nodes.data(), corner);
        return;
      }
    }
    const ops::PartContext<Real> cx{Real(g.h), g.cell_count, g.node_count, 0, 0, 0};
#pragma omp parallel for schedule(static) if (g.cell_count >= kCellParallelThreshold)
    for (int e = 0; e < g.cell_count; ++e)
      ops::stiffness_apply_cell(e, cx, rotation, weights, lambda, mu, p, g.cell_nodes.data(), corner);
  }

  void apply(const Real* p, Real* q, std::vector<Real>& corner) const {
    cell_apply(p, corner.data());
#pragma omp parallel for schedule(static) if (g.node_count >= kParallelThreshold)
    for (int i = 0; i < g.node_count; ++i) {
      const Vec3<Real> kp = ops::gather_corner_sum(corner.data(), g.node_cell_offset.data(), g.node_cell_entry.data(), i);
      store3(q, i, is_fixed(i) ? load3(p, i) : node_apply(i, load3(p, i), kp));
    }
  }

  // The cells' data in single precision, for an apply whose element arithmetic runs in float;
  // p is scaled by 1 / scale on the way in (the operator is linear), so that a small adjoint
  // cotangent's entries do not underflow in float.
  struct SingleCells {
    std::vector<float> rotation, weights, lambda, mu, p, corner;
    Real scale = 1;
  };

  // scale: the size of the solve's first direction, max |M^-1 b|.
  SingleCells single_cells(const Real* b, const Real* inv_diag) const {
    const size_t cells = size_t(g.cell_count);
    SingleCells s;
    Real largest = 0;
    for (long k = 0; k < 3L * g.node_count; ++k) largest = std::max(largest, std::abs(b[k] * inv_diag[k]));
    if (largest > 0) s.scale = largest;
    s.rotation.assign(rotation, rotation + 9 * cells);
    s.weights.assign(weights, weights + 8 * cells);
    s.lambda.assign(lambda, lambda + cells);
    s.mu.assign(mu, mu + cells);
    s.p.resize(3 * size_t(g.node_count));
    s.corner.resize(24 * cells);
    return s;
  }

  // A as apply() has it, R K R^T p in float (eight cells at a time, runtime/element_packs.h),
  // the corner sums and the rest in double.
  void apply_single(const Real* p, Real* q, SingleCells& s) const {
    const Real inverse = Real(1) / s.scale;
    for (size_t k = 0; k < s.p.size(); ++k) s.p[k] = float(p[k] * inverse);
    stiffness_apply_cells(g.cell_count, float(g.h), s.rotation.data(), s.weights.data(), s.lambda.data(),
                          s.mu.data(), s.p.data(), g.cell_nodes.data(), s.corner.data());
    const int* offset = g.node_cell_offset.data();
    const int* entry = g.node_cell_entry.data();
#pragma omp parallel for schedule(static) if (g.node_count >= kParallelThreshold)
    for (int i = 0; i < g.node_count; ++i) {
      const Vec3<float> kp = ops::gather_corner_sum(s.corner.data(), offset, entry, i);
      const Vec3<Real> k = make_vec3(Real(kp.x), Real(kp.y), Real(kp.z));
      store3(q, i, is_fixed(i) ? load3(p, i) : node_apply(i, load3(p, i), s.scale * k));
    }
  }

  // Solves A x = rhs (fixed entries of rhs ignored, x starts from its content) to a
  // residual of tolerance * max(|rhs|, reference) (runtime/pcg.h).
  PcgResult solve(const Real* rhs, Real* x, double tolerance, int max_iterations, double reference = 0) const {
    const Real h = Real(g.h);
    const long n = 3L * g.node_count;
    std::vector<Real> corner(24 * size_t(g.cell_count)), inv_diag(n), b(n);
#pragma omp parallel for schedule(static) if (g.cell_count >= kCellParallelThreshold)
    for (int e = 0; e < g.cell_count; ++e) {
      Vec3<Real> d[8];
      ops::corotated_diagonal(ops::load_mat3(rotation, e), weights + 8 * e, lambda[e], mu[e], h, d);
      for (int k = 0; k < 8; ++k) store3(corner.data(), 8 * e + k, d[k]);
    }
    for (int i = 0; i < g.node_count; ++i) {
      const Vec3<Real> kd = ops::gather_corner_sum(corner.data(), g.node_cell_offset.data(), g.node_cell_entry.data(), i);
      Vec3<Real> d = ops::newmark_system_apply(c, mass[i], make_vec3(Real(1), Real(1), Real(1)), kd);
      if (damping) d += make_vec3(damping[6 * i], damping[6 * i + 1], damping[6 * i + 2]);
      for (int k = 0; k < 3; ++k) {
        inv_diag[3 * i + k] = is_fixed(i) ? Real(1) : Real(1) / d[k];
        b[3 * i + k] = is_fixed(i) ? Real(0) : rhs[3 * i + k];
        if (is_fixed(i)) x[3 * i + k] = Real(0);
      }
    }
    auto op = [&](const Real* p, Real* q) { apply(p, q, corner); };
    if constexpr (std::is_same_v<Real, double>) {
      if (single) {
        SingleCells s = single_cells(b.data(), inv_diag.data());
        auto op_single = [&](const Real* p, Real* q) { apply_single(p, q, s); };
        return jacobi_pcg_reliable<Real>(n, op_single, op, inv_diag.data(), b.data(), x, tolerance, max_iterations,
                                         reference);
      }
    }
    return jacobi_pcg<Real>(n, op, inv_diag.data(), b.data(), x, tolerance, max_iterations, reference);
  }
};

template <class Real>
NewmarkSystem<Real> newmark_system(Interpreter<Real>& in, const Slots<Real>& a) {
  const auto c = ops::newmark_coefficients(a.scalar("dt"), a.scalar("theta"), a.scalar("mass_damping"),
                                           a.scalar("stiffness_damping"));
  return NewmarkSystem<Real>{in.grid(),          in.static_real("cell_weights"), a.value("rotation"),
                             a.value("lambda"),  a.value("mu"),                  a.value("mass"),
                             a.value("fixed"),   a.optional("damping"),          c,
                             single_precision_cells(in.options())};
}

template <class Real>
void newmark_forward(Interpreter<Real>& in, const OpNode& op, int b) {
  const Slots<Real> a{in, op, b};
  const StaticArrays& g = in.grid();
  const NewmarkSystem<Real> system = newmark_system(in, a);
  const Real *u_prev = a.value("u_prev"), *v_prev = a.value("v_prev"), *fixed = a.value("fixed");
  Real* u = a.out("u");
  const Real* guess = a.optional("guess");  // a nonlinear iteration's iterate
  const Real* v_before = a.optional("v_before");
  for (int i = 0; i < 3 * g.node_count; ++i)
    u[i] = fixed[i / 3] != Real(0) ? Real(0)
           : guess                 ? guess[i]
                                   : ops::newmark_start(system.c.dt, system.c.theta, u_prev, v_prev, v_before, i);
  static const bool no_start = std::getenv("SSC_NO_GALERKIN_START") != nullptr;  // for comparisons
  if (!guess && !no_start) {  // the best point of u- + the span of ops::newmark_start_direction
    const long n = 3L * g.node_count;
    std::array<std::vector<Real>, ops::kStartDirections> d;
    for (int j = 0; j < ops::kStartDirections; ++j) {
      d[j].resize(n);
      for (long i = 0; i < n; ++i)
        d[j][i] = fixed[i / 3] != Real(0) ? Real(0)
                                          : ops::newmark_start_direction(j, system.c.dt, v_prev, v_before, int(i));
    }
    std::vector<Real> corner(24 * size_t(g.cell_count));
    auto apply = [&](const Real* p, Real* q) { system.apply(p, q, corner); };
    bool any_fixed = false;
    for (int i = 0; i < g.node_count; ++i) any_fixed = any_fixed || system.is_fixed(i);
    // Zeroed on fixed nodes, the translations are no longer in K's null space.
    auto product = [&](int j, Real* q) {
      if (j < ops::kFirstStartTranslation || any_fixed) return apply(d[j].data(), q);
      for (int i = 0; i < g.node_count; ++i) store3(q, i, system.node_apply(i, load3(d[j].data(), i), zero3<Real>()));
    };
    galerkin_start<ops::kStartDirections, Real>(n, apply, product, a.value("rhs"), d, u);
  }
  const SolverOptions& o = in.options();
  if (b == 0)
    dump_system_if_asked(g, a.value("rhs"), u, [&](int node) { return system.is_fixed(node); },
                         [&](const Real* p, Real* q, std::vector<Real>& corner) { system.apply(p, q, corner); });
  const PcgResult r = system.solve(a.value("rhs"), u, o.cg_tolerance, o.cg_max_iterations);
  in.mutable_report().cg_iterations[b] = r.iterations;
  in.mutable_report().cg_residual[b] = r.relative_residual;
  a.out("cg_iterations")[0] = Real(r.iterations);
  if (!r.converged)
    throw SimulationError(fmt::format(
        "the time-step solve did not converge (batch item {}): relative residual {:.3g} after {} CG "
        "iterations (tolerance {:.3g}); the simulation is probably unstable: lower time.dt, or raise "
        "solver.max_iterations",
        b, r.relative_residual, r.iterations, o.cg_tolerance),
                          {b});
}

// w = A^-1 u_bar (A symmetric) into the op's scratch buffer w; the op's adjoint parts
// (ops/newmark.h) then add w to rhs_bar and hand the parameters -w^T (dA/dp) u.
// A step of several nonlinear iterations has several solves, run last iteration first:
// - The residual is relative to the largest u_bar of the step's solves so far
//   (Interpreter::adjoint_solves). Once the iterations have converged the earlier ones get
//   cotangents many orders smaller than the last one's (1e-8 to 1e-50 of it), and solving
//   those to their own relative tolerance would cost as much as the last solve for nothing
//   the gradient can hold; every solve of the step so reaches the same absolute accuracy.
// - The step's first solve starts from its solutions at the two later steps of the backward
//   pass, extrapolated: w + (w - w_before) (the cotangents change smoothly from step to step;
//   with one later solution, that one); the others from 0, which is already within tolerance
//   when their cotangent is that small. The GPU does the same (gen::newmark_setup).
template <class Real>
void newmark_adjoint(Interpreter<Real>& in, const OpNode& op, int b) {
  const Slots<Real> a{in, op, b};
  const NewmarkSystem<Real> system = newmark_system(in, a);
  const int o = int(&op - in.graph().ops().data());
  const size_t n = 3 * size_t(in.grid().node_count);
  Real* w = in.scratch_real(o, "w", b);
  typename Interpreter<Real>::AdjointSolves& solves = in.adjoint_solves(b);
  typename Interpreter<Real>::AdjointWarmStart* warm = solves.count == 0 ? in.newmark_adjoint_warm_start(b) : nullptr;
  const bool later = warm && warm->later.size() == n, before = later && warm->before.size() == n;
  for (size_t i = 0; i < n; ++i)
    w[i] = before  ? warm->later[i] + (warm->later[i] - warm->before[i])
           : later ? warm->later[i]
                   : Real(0);
  const SolverOptions& opt = in.options();
  const PcgResult r = system.solve(a.bar("u"), w, opt.cg_tolerance, opt.cg_max_iterations, solves.reference);
  solves.reference = std::max(solves.reference, r.rhs_norm);
  ++solves.count;
  if (warm) {
    if (later)
      warm->before.swap(warm->later);
    else
      warm->before.clear();
    warm->later.assign(w, w + n);
  }
  in.mutable_report().adjoint_cg_iterations[b] += r.iterations;
  if (!r.converged)
    throw SimulationError(fmt::format("the adjoint time-step solve did not converge (batch item {}): relative "
                                      "residual {:.3g} after {} iterations",
                                      b, r.relative_residual, r.iterations),
                          {b});
}

// Solves the band Laplacian L x = rhs (3 components; x starts from its content).
template <class Real>
PcgResult solve_band_laplacian(const StaticArrays& g, const Real* rhs, Real* x, double tolerance, int max_iterations) {
  const long n = 3L * g.band_count;
  std::vector<Real> inv_diag(n);
  for (int i = 0; i < g.band_count; ++i)
    for (int k = 0; k < 3; ++k) inv_diag[3 * i + k] = Real(1) / Real(g.band_degree[i]);
  auto apply = [&](const Real* p, Real* q) {
#pragma omp parallel for schedule(static) if (g.band_count >= kParallelThreshold)
    for (int i = 0; i < g.band_count; ++i) {
      Vec3<Real> s = Real(g.band_degree[i]) * load3(p, i);
      for (int d = 0; d < 6; ++d) {
        const int nb = g.band_neighbors[6 * i + d];
        if (nb >= 0) s -= load3(p, nb);
      }
      store3(q, i, s);
    }
  };
  return jacobi_pcg<Real>(n, apply, inv_diag.data(), rhs, x, tolerance, max_iterations);
}

template <class Real>
void extension_forward(Interpreter<Real>& in, const OpNode& op, int b) {
  const Slots<Real> a{in, op, b};
  const StaticArrays& g = in.grid();
  const Real* u = a.value("u");
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
  if (const BandLaplacianFactor* factor = in.band_laplacian_factor()) {
    factor->solve(rhs.data(), x);
    in.mutable_report().extension_iterations[b] = 0;  // solved directly
    return;
  }
  std::copy_n(a.value("band_guess"), rhs.size(), x);
  const SolverOptions& o = in.options();
  const PcgResult r = solve_band_laplacian(g, rhs.data(), x, o.extension_tolerance, o.extension_max_iterations);
  in.mutable_report().extension_iterations[b] = r.iterations;
  if (!r.converged)
    throw SimulationError(fmt::format("the displacement extension did not converge (batch item {}): relative "
                                      "residual {:.3g} after {} iterations",
                                      b, r.relative_residual, r.iterations),
                          {b});
}

template <class Real>
void extension_adjoint(Interpreter<Real>& in, const OpNode& op, int b) {
  const Slots<Real> a{in, op, b};
  const StaticArrays& g = in.grid();
  // Warm start from the previous (later) step's solution of this backward pass.
  std::vector<Real>& y = in.extension_adjoint_guess(b);
  y.resize(3 * size_t(g.band_count), Real(0));
  if (const BandLaplacianFactor* factor = in.band_laplacian_factor()) {  // L is symmetric: the same factor
    factor->solve(a.bar("band_u"), y.data());
  } else {
    const SolverOptions& o = in.options();
    const PcgResult r = solve_band_laplacian(g, a.bar("band_u"), y.data(), o.extension_tolerance, o.extension_max_iterations);
    if (!r.converged)
      throw SimulationError(fmt::format("the adjoint extension solve did not converge (batch item {})", b), {b});
  }
  Real* u_bar = a.bar("u");
  for (int i = 0; i < g.band_count; ++i)
    for (int k = 0; k < 6; ++k) {
      const int nb = g.band_neighbors[6 * i + k];
      if (nb <= -2) add3(u_bar, -nb - 2, load3(y.data(), i));
    }
}

}  // namespace

template <class Real>
const SolverSchedule<Real>& solver_schedule(const std::string& name) {
  static const SolverSchedule<Real> newmark{&newmark_forward<Real>, &newmark_adjoint<Real>};
  static const SolverSchedule<Real> band{&extension_forward<Real>, &extension_adjoint<Real>};
  if (name == "newmark_pcg") return newmark;
  if (name == "band_laplacian") return band;
  throw std::logic_error("no solver schedule '" + name + "' (known: newmark_pcg, band_laplacian)");
}

template const SolverSchedule<double>& solver_schedule<double>(const std::string&);
template const SolverSchedule<float>& solver_schedule<float>(const std::string&);

}  // namespace ssc
