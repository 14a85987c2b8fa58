// The GPU schedules of the solvers (see op_snippets.h): "newmark_pcg" and
// "band_laplacian" become setup kernels plus Jacobi-PCG, either as one persistent grid
// kernel per solve (Extent::Grid: the whole loop, grid barriers between its phases, no
// host checks) or as the per-iteration kernel sequence the runtime drives from the host
// (element apply, node gather, pcg_iterate), the fallback when the batch does not fit
// on the GPU at once. Both evaluate the interpreter's PCG (runtime/pcg.h) with
// fixed-order dot products. The stages' device code is codegen/solver_kernels.cuh; each
// fragment here binds a stage's parameters and calls its function there.
#include <fmt/format.h>

#include "codegen/snippet_builder.h"
#include "ops/galerkin_start.h"
#include "ops/newmark.h"

namespace ssc {
namespace {

using namespace snippet;

// The residual reference of the step's adjoint time-step solves (gen::residual_scale):
// one double per batch item.
Builder& reference(Builder& b) { return b.scratch("reference", "solve_reference", "double", Domain::Scalar, 1, true); }

// The Jacobi-PCG kernels shared by every solve (vectors of length len per batch item),
// one block per item (gen::pcg_start, gen::pcg_iterate). Solver state s_cg: 16 doubles
// per batch item. When an item has stopped (state 6 == 0), pcg_iterate and the gated
// apply kernels return at once.
std::vector<Snippet> pcg_snippets(const Graph& g, int op) {
  auto B = [&](const char* label, Extent e) { return Builder(g, op, label, e); };
  auto state = [](Builder& b, bool write) -> Builder& {
    return b.scratch("cg", "cg", "double", Domain::Scalar, 16, write);
  };
  std::vector<Snippet> s;
  {
    Builder b = B("pcg_start", Extent::Item);
    b.vec("x", true, "len").vec("b", false, "len").vec("q", false, "len").vec("inv_diag", false, "len");
    b.vec("r", true, "len").vec("z", true, "len").vec("p", true, "len").value("len", "int");
    b.value("tol", "double").value("max_it", "int").value("reference_mode", "int");
    reference(b);
    state(b, true).stage("|b|, r = b - A x, z = M^-1 r, p = z, r.z, |r|, convergence test (block per item)", true);
    s.push_back(b.code("gen::pcg_start<Real>(i, len, tol, max_it, v_b, v_q, v_inv_diag, v_x, v_r, v_z, v_p, $cg,\n"
                       "                     $reference, reference_mode);\n"));
  }
  {
    Builder b = B("pcg_iterate", Extent::Item);
    b.vec("x", true, "len").vec("r", true, "len").vec("z", true, "len").vec("p", true, "len");
    b.vec("q", false, "len").vec("inv_diag", false, "len").value("len", "int");
    b.value("tol", "double").value("max_it", "int");
    state(b, true).stage(
        "loop: p.q, step, x += step p, r -= step q, z = M^-1 r, r.z, |r|, beta, p = z + beta p, "
        "convergence test (block per item)", true);
    s.push_back(b.code("gen::pcg_iterate<Real>(i, len, tol, max_it, v_q, v_inv_diag, v_x, v_r, v_z, v_p, $cg);\n"));
  }
  return s;
}

// The gated apply kernels of the host-driven loop return when the item's solve stopped.
const char* const kGate = "if (gen::pcg_stopped(gate, $cg)) return;  // solve stopped for this item\n";

// ---- Persistent grid solves (Extent::Grid, gen::GridPcg) ----
//
// One cooperative kernel runs a whole Jacobi-PCG solve for every batch item (the
// Chronopoulos-Gear form, see codegen/solver_kernels.cuh). The final state goes to s_cg,
// to slot log_slot of s_cg_log (read by the host once per step) and the iteration count
// to v_iterations[0].

// The bindings every grid solve shares: solver vectors, values, state and grid scratch.
// The barrier counter is per kernel: its arrivals come in multiples of that kernel's
// block count (grid_sync).
// With setup, the kernel writes b and inv_diag itself.
Builder& grid_solve_params(Builder& b, const std::string& len, const std::string& kernel, bool setup = false) {
  b.vec("x", true, len, true).vec("b", setup, len).vec("inv_diag", setup, len, true);
  b.vec("r", true, len, true).vec("w", true, len, true).vec("s", true, len, true);
  b.vec("z", true, len, true).vec("p", true, len).vec("iterations", true, "1");
  b.value("tol", "double").value("max_it", "int").value("log_slot", "int").value("reference_mode", "int");
  reference(b).scratch("cg", "cg", "double", Domain::Scalar, 16, true);
  b.scratch("cg_log", "cg_log", "double", Domain::Scalar, 16 * kMaxSolveLog, true);
  b.scratch("partial", "grid_partial", "double", Domain::Scalar, 2 * kMaxGridSum * kMaxGridBlocks, true);
  return b.scratch("bar", "grid_barrier_" + kernel, "double", Domain::Scalar, 1, true);
}

// The grid solve's state `pcg` over the bindings of grid_solve_params (the partial sums
// in two halves of kMaxGridSum * kMaxGridBlocks doubles).
std::string grid_state() {
  return fmt::format(
      "gen::GridPcg<Real> pcg(v_x, v_b, v_inv_diag, v_r, v_w, v_s, v_z, v_p, v_iterations, tol, max_it, log_slot,\n"
      "                       $cg, $cg_log, $reference, reference_mode, $partial, {}, $bar);\n",
      kMaxGridSum * kMaxGridBlocks);
}
static_assert(kMaxGridSum >= ops::kStartSums<ops::kStartDirections>, "the Galerkin start's sums fit the partials");

// The Galerkin start's directions (gen::StartDirections, ops/galerkin_start.h) of a forward
// solve without a guess: binds v_prev (and v_before) and returns the argument that passes
// them ("nullptr" for no such start), active where `active` (a C++ expression) holds.
std::string bind_start(const Graph& g, int op, bool adjoint, Builder& b, const std::string& active) {
  const OpNode& node = g.ops().at(op);
  if (adjoint || node.bound("guess")) return "nullptr";
  b.t("v_prev");
  const bool before = node.bound("v_before");
  if (before) b.t("v_before");
  return std::string("gen::StartDirections<Real>{c.dt, $v_prev, ") + (before ? "$v_before" : "nullptr") + ", " +
         active + "}";
}

// A node-local damping matrix C in the system (friction, ops/newmark.h), when the op's
// optional slot is bound: binds it and returns the argument that passes it ("$damping",
// else "nullptr").
std::string bind_damping(const Graph& g, int op, Builder& b) {
  if (!g.ops().at(op).bound("damping")) return "nullptr";
  b.t("damping");
  return "$damping";
}

// The time-step system (a_m M + a_k K) on the free nodes, identity on fixed ones: the whole
// PCG solve in one cooperative kernel in the form `form` (codegen/solver_kernels.cuh), its
// setup first (gen::newmark_grid_setup: the Jacobi diagonal and the masked right-hand side
// from rhs, as newmark_diag and newmark_setup of the host-driven sequence), then a forward
// solve's Galerkin start (as newmark_start; the value galerkin_start is 0 where the forward
// kernel runs an adjoint solve). The one-phase form alternates r, s and the corner forces
// with r2, s2 and corner2.
Snippet newmark_grid(const Graph& g, int op, bool adjoint, const std::string& form, const std::string& barrier,
                     bool one_phase, const std::string& stage) {
  Builder b(g, op, form, Extent::Grid);
  const std::string damping = bind_damping(g, op, b);
  const std::string start = bind_start(g, op, adjoint, b, "galerkin_start != 0");
  if (start != "nullptr") b.value("galerkin_start", "int");
  b.t("rotation").t("lambda").t("mu").grid("cell_weights", "Real").grid("cell_nodes", "int");
  newmark_scalars(b).t("mass").t("fixed").grid("node_cell_offset", "int").grid("node_cell_entry", "int");
  b.scratch("corner", "corner", "Real", Domain::Cell, 24, true, true);
  if (one_phase) {
    b.scratch("corner2", "corner2", "Real", Domain::Cell, 24, true, true);
    b.vec("r2", true, "3 * n_node", true).vec("s2", true, "3 * n_node", true);
  }
  b.vec("rhs", false, "3 * n_node").vec("x_before", true, "3 * n_node").value("x_start", "int");
  grid_solve_params(b, "3 * n_node", barrier, true);
  b.stage(stage, true);
  const std::string args = "c, n_cell, n_node, h, $rotation, g_cell_weights, g_cell_nodes, $lambda, $mu, $mass, $fixed, " +
                           damping + ", g_node_cell_offset, g_node_cell_entry";
  return b.code(std::string(kCoefficients) + grid_state() + "gen::newmark_grid_setup<Real>(pcg, " + args +
                ", v_rhs, x_start, v_x_before, v_b, v_inv_diag, $corner);\n" + "gen::" + form + "<Real>(pcg, " + args +
                (one_phase ? ", $corner, $corner2, v_r2, v_s2, " : ", $corner, ") + start + ");\n");
}

// The band Laplacian, one phase per iteration: r, w, s alternate with r2, w2, s2.
Snippet extension_grid_loop(const Graph& g, int op) {
  Builder b(g, op, "extension_pcg_grid", Extent::Grid);
  b.grid("band_neighbors", "int").grid("band_degree", "int");
  b.vec("r2", true, "3 * n_band", true).vec("w2", true, "3 * n_band", true).vec("s2", true, "3 * n_band", true);
  grid_solve_params(b, "3 * n_band", "extension");
  b.stage("whole PCG solve in one cooperative kernel: band Laplacian and update (grid barriers)", true);
  return b.code(grid_state() +
                "gen::extension_pcg_grid<Real>(pcg, n_band, g_band_neighbors, g_band_degree, v_r2, v_w2, v_s2);\n");
}

// The same solve for throughput, two phases per iteration (large batches).
Snippet extension_grid_two_phase(const Graph& g, int op) {
  Builder b(g, op, "extension_pcg_grid_two_phase", Extent::Grid);
  b.grid("band_neighbors", "int").grid("band_degree", "int");
  grid_solve_params(b, "3 * n_band", "extension_two_phase");
  b.stage("whole PCG solve in one cooperative kernel, two phases per iteration (grid barriers)", true);
  return b.code(grid_state() +
                "gen::extension_pcg_grid_two_phase<Real>(pcg, n_band, g_band_neighbors, g_band_degree);\n");
}

std::vector<Snippet> newmark_solver(const Graph& g, int op, bool adjoint) {
  const std::string x3 = "3 * n_node";
  std::vector<Snippet> s;
  if (!adjoint) {
    Builder b(g, op, "newmark_init", Extent::Node);
    b.t("u", true).t("u_prev").t("v_prev").t("fixed").t("dt").t("theta");
    b.stage("u = the guess or the prediction from u-, v- and v_before (initial guess)");
    const bool guess = g.ops().at(op).bound("guess"), before = g.ops().at(op).bound("v_before");
    if (guess) b.t("guess");
    if (before) b.t("v_before");
    s.push_back(b.code(std::string("gen::newmark_init<Real>(i, $dt, $theta, $u_prev, $v_prev, ") +
                       (before ? "$v_before" : "nullptr") + ", $fixed, " + (guess ? "$guess" : "nullptr") +
                       ", $u);\n"));
  }
  {
    Builder b(g, op, "newmark_diag", Extent::Len);
    b.t("rotation").t("lambda").t("mu").grid("cell_weights", "Real").value("len", "int");
    b.scratch("corner", "corner", "Real", Domain::Cell, 24, true).stage("Jacobi diagonal, one thread per cell corner", true);
    s.push_back(b.code("gen::newmark_diagonal_corner<Real>(i, h, $rotation, g_cell_weights, $lambda, $mu, $corner);\n"));
  }
  {
    Builder b(g, op, "newmark_setup", Extent::Node);
    const std::string damping = bind_damping(g, op, b);
    newmark_scalars(b).t("mass").t("fixed").grid("node_cell_offset", "int").grid("node_cell_entry", "int");
    b.scratch("corner", "corner", "Real", Domain::Cell, 24, false, true);
    b.vec("rhs", false, x3).vec("x", true, x3).vec("x_before", true, x3).vec("b", true, x3).vec("inv_diag", true, x3);
    b.value("x_start", "int");
    b.stage("node gather of the diagonal, masked right-hand side", true);
    s.push_back(b.code(std::string(kCoefficients) + "gen::newmark_setup<Real>(i, c, $mass, $fixed, " + damping +
                       ", $corner, g_node_cell_offset, g_node_cell_entry, v_rhs,\n"
                       "                         x_start, v_x, v_x_before, v_b, v_inv_diag);\n"));
  }
  if (!adjoint && !g.ops().at(op).bound("guess")) {
    Builder b(g, op, "newmark_start", Extent::Item);
    const std::string damping = bind_damping(g, op, b);
    const std::string start = bind_start(g, op, adjoint, b, "true");
    b.t("rotation").t("lambda").t("mu").grid("cell_weights", "Real").grid("cell_nodes", "int");
    newmark_scalars(b).t("mass").t("fixed").vec("b", false, x3).vec("x", true, x3);
    b.stage("x = the best point of the start's span (ops/galerkin_start.h, block per item)", true);
    s.push_back(b.code(std::string(kCoefficients) + "gen::newmark_start_item<Real>(i, c, " + start +
                       ", n_cell, n_node, h, $rotation, g_cell_weights,\n"
                       "                             g_cell_nodes, $lambda, $mu, $mass, $fixed, " +
                       damping + ", v_b, v_x);\n"));
  }
  {
    Builder b(g, op, "newmark_apply_cell", Extent::Cell);
    b.t("rotation").t("lambda").t("mu").grid("cell_weights", "Real").grid("cell_nodes", "int");
    b.vec("p", false, x3, true).scratch("corner", "corner", "Real", Domain::Cell, 24, true);
    b.value("gate", "int").scratch("cg", "cg", "double", Domain::Scalar, 16, false);
    b.stage("loop: element apply R K R^T p per cell corner", true);
    s.push_back(b.code(std::string(kGate) +
                       "gen::newmark_apply_cell<Real>(i, h, $rotation, g_cell_weights, g_cell_nodes, $lambda, $mu, v_p, "
                       "$corner);\n"));
  }
  {
    Builder b(g, op, "newmark_apply_node", Extent::Node);
    const std::string damping = bind_damping(g, op, b);
    newmark_scalars(b).t("mass").t("fixed").grid("node_cell_offset", "int").grid("node_cell_entry", "int");
    b.scratch("corner", "corner", "Real", Domain::Cell, 24, false, true).vec("p", false, x3).vec("q", true, x3);
    b.value("gate", "int").scratch("cg", "cg", "double", Domain::Scalar, 16, false);
    b.stage("loop: node gather, q = (a_m M + a_k K) p", true);
    s.push_back(b.code(std::string(kGate) + kCoefficients + "gen::newmark_apply_node<Real>(i, c, $mass, $fixed, " +
                       damping + ", $corner, g_node_cell_offset, g_node_cell_entry,\n"
                                 "                              v_p, v_q);\n"));
  }
  for (Snippet& p : pcg_snippets(g, op)) s.push_back(p);
  s.push_back(newmark_grid(g, op, adjoint, "newmark_pcg_grid", "newmark", false,
                           "whole PCG solve in one cooperative kernel: its setup, then per iteration node update "
                           "storing u, element apply of u (grid barriers)"));
  s.push_back(newmark_grid(g, op, adjoint, "newmark_pcg_grid_one_phase", "newmark_one_phase", true,
                           "whole PCG solve in one cooperative kernel: its setup, then one phase per iteration "
                           "(node gathers at the corners)"));
  return s;
}

std::vector<Snippet> extension_solver(const Graph& g, int op, bool adjoint) {
  const std::string x3 = "3 * n_band";
  std::vector<Snippet> s;
  if (!adjoint) {
    Builder b(g, op, "extension_setup", Extent::Band);
    b.t("u", false, true).t("band_guess").t("band_u", true).grid("band_neighbors", "int").grid("band_degree", "int");
    b.vec("b", true, x3).vec("inv_diag", true, x3).stage("rhs from active neighbours, x = guess, Jacobi diagonal");
    s.push_back(b.code(
        "gen::extension_setup<Real>(i, $u, $band_guess, g_band_neighbors, g_band_degree, $band_u, v_b, v_inv_diag);\n"));
  } else {
    Builder b(g, op, "extension_adj_setup", Extent::Band);
    b.a("band_u", false).grid("band_degree", "int").vec("x", true, x3).vec("b", true, x3).vec("inv_diag", true, x3);
    b.value("zero_x", "int").stage("rhs = band_u cotangent, x = 0 or the later step's solution, Jacobi diagonal");
    s.push_back(b.code("gen::extension_adj_setup<Real>(i, $d_band_u, g_band_degree, zero_x, v_x, v_b, v_inv_diag);\n"));
  }
  if (!adjoint) {
    Builder b(g, op, "extension_dense", Extent::Len);
    b.t("u", false, true).t("band_u", true).grid("band_operator", "Real").grid("band_sources", "int");
    b.value("n_source", "int").value("len", "int");
    b.stage("band_u = G u, the extension as one product, slices of the sources per warp (runtime/band_operator.h)");
    s.push_back(b.code("gen::extension_dense<Real>(n_band, n_source, g_band_operator, g_band_sources, $u, $band_u);\n"));
  } else {
    Builder b(g, op, "extension_dense_adjoint", Extent::Len);
    b.a("u").a("band_u", false).grid("band_operator", "Real").grid("band_sources", "int").value("len", "int");
    b.stage("u_bar += G^T band_u_bar, a warp per source (runtime/band_operator.h)");
    s.push_back(b.code(
        "gen::extension_dense_adjoint<Real>(i, n_band, g_band_operator, g_band_sources, $d_band_u, $d_u);\n"));
  }
  {
    Builder b(g, op, "extension_apply", Extent::Band);
    b.grid("band_neighbors", "int").grid("band_degree", "int").vec("p", false, x3, true).vec("q", true, x3);
    b.value("gate", "int").scratch("cg", "cg", "double", Domain::Scalar, 16, false);
    b.stage("loop: band Laplacian q = L p", true);
    s.push_back(b.code(std::string(kGate) + "gen::extension_apply<Real>(i, g_band_neighbors, g_band_degree, v_p, v_q);\n"));
  }
  for (Snippet& p : pcg_snippets(g, op)) s.push_back(p);
  s.push_back(extension_grid_loop(g, op));
  s.push_back(extension_grid_two_phase(g, op));
  if (adjoint) {
    // y = L^-1 band_u_bar goes to the active neighbours' u cotangent.
    const std::string n = "op" + std::to_string(op);
    s.push_back(Builder(g, op, "extension_solve_nodes", Extent::Node)
                    .a("u").grid("node_band_offset", "int").grid("node_band_entry", "int")
                    .scratch("y", "y_" + n, "Real", Domain::Band, 3, false, true).barrier()
                    .code("gen::extension_solve_node<Real>(i, g_node_band_offset, g_node_band_entry, $y, $d_u);\n"));
  }
  return s;
}

}  // namespace

std::vector<Snippet> solver_snippets(const Graph& g, int op, bool adjoint) {
  const std::string& solver = g.ops().at(op).spec->solver;
  if (solver == "newmark_pcg") return newmark_solver(g, op, adjoint);
  if (solver == "band_laplacian") return extension_solver(g, op, adjoint);
  throw std::logic_error("codegen: no GPU schedule for solver '" + solver + "' (op " + g.ops().at(op).name() + ")");
}

}  // namespace ssc
