// The GPU schedules of the solvers (see op_snippets.h): "newmark_pcg" and
// "band_laplacian" become setup kernels plus Jacobi-PCG, either as one persistent grid
// kernel per solve (Extent::Grid: the whole loop, grid barriers between its phases, no
// host checks) or as the per-iteration kernel sequence the runtime drives from the host
// (element apply, node gather, pcg_iterate), the fallback when the batch does not fit
// on the GPU at once. Both evaluate the interpreter's PCG (runtime/pcg.h) with
// fixed-order dot products.
#include <fmt/format.h>

#include "codegen/snippet_builder.h"

namespace ssc {
namespace {

using namespace snippet;

// The Jacobi-PCG kernels shared by every solve (vectors of length len per batch item).
// Solver state s_cg (double, 16 per batch item): 0 |b|, 1 r.z, 2 |r|, 3 p.q, 4 step,
// 5 beta, 6 active, 7 iterations, 8 relative residual, 9 converged.
//
// Both kernels run one block of SSC_ITEM threads per batch item (Extent::Item): every
// thread walks a fixed strided subset of the vector (k = i, i + SSC_ITEM, ...), its
// partial dot products are combined by gen::block_sum in a fixed tree (runtime order
// independent: bitwise reproducible, no atomics), and every thread gets the totals, so
// the scalar update, the axpys and the direction update run in the same launch. One CG
// iteration is then the operator's apply kernels plus pcg_iterate. When an item has
// stopped (state 6 == 0), pcg_iterate and the gated apply kernels return at once.
std::vector<Snippet> pcg_snippets(const Graph& g, int op) {
  auto B = [&](const char* label, Extent e) { return Builder(g, op, label, e); };
  auto state = [](Builder& b, bool write) -> Builder& {
    return b.scratch("cg", "cg", "double", Domain::Scalar, 16, write);
  };
  const char* check =
      "if ($cg[0] == 0.0) { $cg[6] = 0; $cg[9] = 1; $cg[8] = 0; }\n"
      "else {\n"
      "  $cg[8] = $cg[2] / $cg[0];\n"
      "  if ($cg[8] <= tol) { $cg[6] = 0; $cg[9] = 1; }\n"
      "  else if ($cg[7] >= double(max_it) || !isfinite($cg[2])) { $cg[6] = 0; $cg[9] = 0; }\n"
      "  else $cg[6] = 1;\n"
      "}\n";
  std::vector<Snippet> s;
  {
    Builder b = B("pcg_start", Extent::Item);
    b.vec("x", true, "len").vec("b", false, "len").vec("q", false, "len").vec("inv_diag", false, "len");
    b.vec("r", true, "len").vec("z", true, "len").vec("p", true, "len").value("len", "int");
    b.value("tol", "double").value("max_it", "int");
    state(b, true).stage("|b|, r = b - A x, z = M^-1 r, p = z, r.z, |r|, convergence test (block per item)", true);
    s.push_back(b.code(std::string(
        "double acc[3] = {0, 0, 0};\n"
        "for (int k = i; k < len; k += SSC_ITEM) {\n"
        "  const Real bk = v_b[k];\n"
        "  const Real rk = bk - v_q[k];\n"
        "  const Real zk = v_inv_diag[k] * rk;\n"
        "  v_r[k] = rk;\n"
        "  v_z[k] = zk;\n"
        "  v_p[k] = zk;\n"
        "  acc[0] += double(bk) * double(bk);\n"
        "  acc[1] += double(rk) * double(zk);\n"
        "  acc[2] += double(rk) * double(rk);\n"
        "}\n"
        "gen::block_sum<3>(acc);\n"
        "const double b_norm = sqrt(acc[0]);\n"
        "if (b_norm == 0.0)\n"
        "  for (int k = i; k < len; k += SSC_ITEM) v_x[k] = Real(0);\n"
        "if (i == 0) {\n"
        "  for (int k = 0; k < 16; ++k) $cg[k] = 0;\n"
        "  $cg[0] = b_norm;\n"
        "  $cg[1] = acc[1];\n"
        "  $cg[2] = sqrt(acc[2]);\n") + check + "}\n"));
  }
  {
    Builder b = B("pcg_iterate", Extent::Item);
    b.vec("x", true, "len").vec("r", true, "len").vec("z", true, "len").vec("p", true, "len");
    b.vec("q", false, "len").vec("inv_diag", false, "len").value("len", "int");
    b.value("tol", "double").value("max_it", "int");
    state(b, true).stage(
        "loop: p.q, step, x += step p, r -= step q, z = M^-1 r, r.z, |r|, beta, p = z + beta p, "
        "convergence test (block per item)", true);
    s.push_back(b.code(std::string(
        "if ($cg[6] == 0.0) return;  // stopped (uniform over the block)\n"
        "const double rz = $cg[1];\n"
        "double pq[1] = {0};\n"
        "for (int k = i; k < len; k += SSC_ITEM) pq[0] += double(v_p[k]) * double(v_q[k]);\n"
        "gen::block_sum<1>(pq);\n"
        "const Real step = Real(rz / pq[0]);\n"
        "double acc[2] = {0, 0};\n"
        "for (int k = i; k < len; k += SSC_ITEM) {\n"
        "  v_x[k] += step * v_p[k];\n"
        "  const Real rk = v_r[k] - step * v_q[k];\n"
        "  const Real zk = v_inv_diag[k] * rk;\n"
        "  v_r[k] = rk;\n"
        "  v_z[k] = zk;\n"
        "  acc[0] += double(rk) * double(zk);\n"
        "  acc[1] += double(rk) * double(rk);\n"
        "}\n"
        "gen::block_sum<2>(acc);\n"
        "const Real beta = Real(acc[0] / rz);\n"
        "for (int k = i; k < len; k += SSC_ITEM) v_p[k] = v_z[k] + beta * v_p[k];\n"
        "if (i == 0) {\n"
        "  $cg[3] = pq[0];\n"
        "  $cg[4] = double(step);\n"
        "  $cg[5] = double(beta);\n"
        "  $cg[1] = acc[0];\n"
        "  $cg[2] = sqrt(acc[1]);\n"
        "  $cg[7] += 1;\n") + check + "}\n"));
  }
  return s;
}

// ---- Persistent grid solves (Extent::Grid) ----
//
// One cooperative kernel runs a whole Jacobi-PCG solve for every batch item: gridDim.x
// blocks per item, the item's blocks meeting at grid barriers. The iteration is the
// Chronopoulos-Gear form of PCG (the same iterates as runtime/pcg.h in exact arithmetic,
// one reduction per iteration instead of two):
//   s = w + beta s,  p = u + beta p,  x += alpha p,  r -= alpha s,  u = M^-1 r,  w = A u,
//   gamma' = r.u,  delta = w.u,  beta = gamma' / gamma,
//   alpha = gamma' / (delta - beta gamma' / alpha).
// The apply A u needs u at neighbouring nodes before their owners have updated it, so
// every thread evaluates u there from the previous iteration's r, w, s (next_u below):
// the same expression, the same bits as the owner's. Each thread owns the same nodes in
// every phase. The final state goes to s_cg, to slot log_slot of s_cg_log (read by the
// host once per step) and the iteration count to v_iterations[0].

// The bindings every grid solve shares: solver vectors, values, state and grid scratch.
// The barrier counter is per kernel: its arrivals come in multiples of that kernel's
// block count (grid_sync).
Builder& grid_solve_params(Builder& b, const std::string& len, const std::string& kernel) {
  b.vec("x", true, len, true).vec("b", false, len).vec("inv_diag", false, len, true);
  b.vec("r", true, len, true).vec("w", true, len, true).vec("s", true, len, true);
  b.vec("z", true, len, true).vec("p", true, len).vec("iterations", true, "1");
  b.value("tol", "double").value("max_it", "int").value("log_slot", "int");
  b.scratch("cg", "cg", "double", Domain::Scalar, 16, true);
  b.scratch("cg_log", "cg_log", "double", Domain::Scalar, 16 * kMaxSolveLog, true);
  b.scratch("partial", "grid_partial", "double", Domain::Scalar, 2 * 4 * kMaxGridBlocks, true);
  return b.scratch("bar", "grid_barrier_" + kernel, "double", Domain::Scalar, 1, true);
}

std::string grid_prologue() {
  return fmt::format(
      "unsigned long long* bar = reinterpret_cast<unsigned long long*>($bar);\n"
      "// Consecutive grid_sums alternate between two partial-sum buffers: a block may write\n"
      "// the next sum's partials while another still reads this one's.\n"
      "double* const partial0 = $partial;\n"
      "double* const partial1 = $partial + {};\n"
      "int parity = 0;\n"
      "const int rank = gen::grid_rank(), threads = gen::grid_threads();\n"
      "auto times = [](Vec3<Real> a, Vec3<Real> b) {{ return make_vec3(a.x * b.x, a.y * b.y, a.z * b.z); }};\n"
      "Real step = Real(0), beta = Real(0);  // alpha and beta of the iteration under way\n",
      4 * kMaxGridBlocks);
}

// u_{k+1} at node m from the previous iteration's vectors in r, w, s.
std::string grid_next_u(const std::string& r, const std::string& w, const std::string& s) {
  return "auto next_u = [&](int m) {\n"
         "  const Vec3<Real> sm = load3(" + w + ", m) + beta * load3(" + s + ", m);\n"
         "  return times(load3(v_inv_diag, m), load3(" + r + ", m) - step * sm);\n"
         "};\n"
         "// The operand of an apply at node m: the start's x or u, or the loop's next u.\n"
         "constexpr int kX = 0, kU = 1, kNextU = 2;\n"
         "auto value = [&](int source, int m) {\n"
         "  return source == kX ? load3(v_x, m) : source == kU ? load3(v_z, m) : next_u(m);\n"
         "};\n";
}

// The start's first half over the thread's own nodes, given q = A x at node n:
// r = b - q, u = M^-1 r, s = p = 0 (the previous directions), |b|^2 into bb.
std::string grid_start_residual(const std::string& own, const std::string& q_of_x, const std::string& r,
                                const std::string& s) {
  return "double bb = 0;\n" + own + " {\n" + q_of_x +
         "  const Vec3<Real> bn = load3(v_b, n), rn = bn - q;\n"
         "  store3(" + r + ", n, rn);\n"
         "  store3(v_z, n, times(load3(v_inv_diag, n), rn));\n"
         "  store3(" + s + ", n, zero3<Real>());\n"
         "  store3(v_p, n, zero3<Real>());\n"
         "  for (int k = 0; k < 3; ++k) bb += double(bn[k]) * double(bn[k]);\n"
         "}\n"
         "gen::grid_sync(bar);\n";
}

// The start's second half, after u = M^-1 r is complete: w = A u at the thread's own
// nodes (`w_of_u` defines un and wn at node n), stored in w; gamma = r.u, delta = w.u and
// |r|^2 into acc, summed with the first half's |b|^2 (bb) in one grid_sum.
std::string grid_start_sums(const std::string& own, const std::string& w_of_u, const std::string& r,
                            const std::string& w) {
  return "double acc[3] = {0, 0, 0};\n" + own + " {\n" + w_of_u +
         "  const Vec3<Real> rn = load3(" + r + ", n);\n"
         "  store3(" + w + ", n, wn);\n"
         "  for (int k = 0; k < 3; ++k) {\n"
         "    acc[0] += double(rn[k]) * double(un[k]);\n"
         "    acc[1] += double(wn[k]) * double(un[k]);\n"
         "    acc[2] += double(rn[k]) * double(rn[k]);\n"
         "  }\n"
         "}\n"
         "{\n"
         "  double sums[4] = {acc[0], acc[1], acc[2], bb};\n"
         "  gen::grid_sum<4>(sums, parity ? partial1 : partial0, bar);\n"
         "  parity ^= 1;\n"
         "  for (int k = 0; k < 3; ++k) acc[k] = sums[k];\n"
         "  bb = sums[3];\n"
         "}\n";
}

// The own-node update of one iteration: s, p, x, r, u, and w = A u at node n from `w_of_u`
// (given u); the sums gamma, delta, |r|^2 into acc.
std::string grid_own_update(const std::string& r, const std::string& w, const std::string& s,
                            const std::string& r_out, const std::string& w_out, const std::string& s_out,
                            const std::string& w_of_u) {
  return "    const Vec3<Real> sn = load3(" + w + ", n) + beta * load3(" + s + ", n);\n"
         "    const Vec3<Real> pn = load3(v_z, n) + beta * load3(v_p, n);\n"
         "    const Vec3<Real> rn = load3(" + r + ", n) - step * sn;\n"
         "    const Vec3<Real> un = times(load3(v_inv_diag, n), rn);\n" + w_of_u +
         "    store3(v_x, n, load3(v_x, n) + step * pn);\n"
         "    store3(" + s_out + ", n, sn);\n"
         "    store3(v_p, n, pn);\n"
         "    store3(" + r_out + ", n, rn);\n"
         "    store3(v_z, n, un);\n"
         "    store3(" + w_out + ", n, wn);\n"
         "    for (int k = 0; k < 3; ++k) {\n"
         "      acc[0] += double(rn[k]) * double(un[k]);\n"
         "      acc[1] += double(wn[k]) * double(un[k]);\n"
         "      acc[2] += double(rn[k]) * double(rn[k]);\n"
         "    }\n";
}

// From the start's sums (acc = {gamma, delta, |r|^2}, bb): the convergence test of
// runtime/pcg.h, then the loop (`iteration` leaves the new sums in acc), then the state.
std::string grid_loop(const std::string& own, const std::string& iteration) {
  return "const double b_norm = sqrt(bb);\n"
         "double gamma = acc[0], alpha = acc[0] / acc[1], r_norm = sqrt(acc[2]), rel = 0;\n"
         "int its = 0;\n"
         "bool active = false, converged = false;\n"
         "auto test = [&]() {\n"
         "  rel = r_norm / b_norm;\n"
         "  active = false;\n"
         "  converged = false;\n"
         "  if (rel <= tol) converged = true;\n"
         "  else if (its < max_it && isfinite(r_norm)) active = true;\n"
         "};\n"
         "if (b_norm == 0.0) {\n"
         "  " + own + " store3(v_x, n, zero3<Real>());\n"
         "  converged = true;\n"
         "} else {\n"
         "  test();\n"
         "}\n"
         "step = Real(alpha);\n"
         "while (active) {\n"
         "  double acc[3] = {0, 0, 0};\n" + iteration +
         "  gen::grid_sum<3>(acc, parity ? partial1 : partial0, bar);\n"
         "  parity ^= 1;\n"
         "  const double gamma_next = acc[0];\n"
         "  const double beta_next = gamma_next / gamma;\n"
         "  alpha = gamma_next / (acc[1] - beta_next * gamma_next / alpha);\n"
         "  gamma = gamma_next;\n"
         "  step = Real(alpha);\n"
         "  beta = Real(beta_next);\n"
         "  r_norm = sqrt(acc[2]);\n"
         "  ++its;\n"
         "  test();\n"
         "}\n"
         "if (rank == 0) {\n"
         "  const double st[10] = {b_norm, gamma, r_norm, 0, alpha, double(beta), 0, double(its), rel,\n"
         "                         converged ? 1.0 : 0.0};\n"
         "  for (int k = 0; k < 16; ++k) {\n"
         "    $cg[k] = k < 10 ? st[k] : 0.0;\n"
         "    $cg_log[16 * log_slot + k] = $cg[k];\n"
         "  }\n"
         "  v_iterations[0] = Real(its);\n"
         "}\n";
}

// A node-local damping matrix C in the system (friction, ops/newmark.h), when the op's
// optional slot is bound: binds it and returns "C" (else ""); damping_of(...) is then the
// term " + C_n e" of the apply at node n for the value e.
std::string bind_damping(const Graph& g, int op, Builder& b) {
  if (!g.ops().at(op).bound("damping")) return "";
  b.t("damping");
  return "C";
}
std::string damping_of(const std::string& bound, const std::string& n, const std::string& e) {
  return bound.empty() ? "" : " + ops::sym3_apply($damping, " + n + ", " + e + ")";
}

// The time-step system (a_m M + a_k K) on the free nodes, identity on fixed ones: the
// element apply over cell corners (newmark_apply_cell), a grid barrier, the node gather
// (newmark_apply_node) with the own-node update; r, w, s are updated in place (the cell
// phase that reads them at other nodes is over when the node phase writes).
Snippet newmark_grid_loop(const Graph& g, int op) {
  Builder b(g, op, "newmark_pcg_grid", Extent::Grid);
  const std::string damping_term = bind_damping(g, op, b);
  b.t("rotation").t("lambda").t("mu").grid("cell_weights", "Real").grid("cell_nodes", "int");
  newmark_scalars(b).t("mass").t("fixed").grid("node_cell_offset", "int").grid("node_cell_entry", "int");
  b.scratch("corner", "corner", "Real", Domain::Cell, 24, true, true);
  grid_solve_params(b, "3 * n_node", "newmark");
  b.stage("whole PCG solve in one cooperative kernel: element apply, node gather and update (grid barriers)", true);
  const std::string own = "for (int n = rank; n < n_node; n += threads)";
  return b.code(std::string(kCoefficients) + grid_prologue() + grid_next_u("v_r", "v_w", "v_s") +
      "// The thread's first cell corner and node keep their incidence in registers for the\n"
      "// whole solve (one load chain less per phase); further ones (small grids) load it.\n"
      "const int corner_node = rank < 8 * n_cell ? g_cell_nodes[rank] : 0;\n"
      "int node_entry[8], node_entries = 0;\n"
      "if (rank < n_node) {\n"
      "  const int first = g_node_cell_offset[rank];\n"
      "  node_entries = g_node_cell_offset[rank + 1] - first;\n"
      "#pragma unroll\n"
      "  for (int k = 0; k < 8; ++k) node_entry[k] = k < node_entries ? g_node_cell_entry[first + k] : 0;\n"
      "}\n"
      "// Corners of R K R^T e per cell for the nodal values e = value(source, node)\n"
      "// (newmark_apply_cell's corotated_apply),"
      " eight lanes per cell: lane c rotates corner c, gets its edge\n"
      "// neighbours' rotated vectors and stress columns by warp shuffles, assembles corner c.\n"
      "auto cells = [&](int source) {\n"
      "  const int lanes = 8 * n_cell, lanes_warps = (lanes + 31) / 32 * 32;\n"
      "  for (int t = rank; t < lanes_warps; t += threads) {  // whole warps stay in the loop\n"
      "    const bool valid = t < lanes;\n"
      "    const int e = valid ? t >> 3 : 0, c = t & 7;\n"
      "    const int nd = !valid ? 0 : t == rank ? corner_node : g_cell_nodes[t];\n"
      "    const Mat3<Real> R = ops::load_mat3($rotation, e);\n"
      "    const Vec3<Real> q = mul_transposed(R, value(source, nd));\n"
      "    const Vec3<Real> qn[3] = {gen::shfl_xor3(q, 1), gen::shfl_xor3(q, 2), gen::shfl_xor3(q, 4)};\n"
      "    Vec3<Real> col[3];\n"
      "    ops::element_corner_columns(c, g_cell_weights[t], $lambda[0], $mu[0], h, q, qn, col);\n"
      "    const Vec3<Real> y = R * ops::element_corner_assemble(col, gen::shfl_xor3(col[0], 1),\n"
      "                                                          gen::shfl_xor3(col[1], 2), gen::shfl_xor3(col[2], 4));\n"
      "    if (valid) store3($corner, t, y);\n"
      "  }\n"
      "  gen::grid_sync(bar);\n"
      "};\n"
      "// A e at node n for the node value e (newmark_apply_node; the same sum order as\n"
      "// ops::gather_corner_sum).\n"
      "auto node_apply = [&](int n, Vec3<Real> e) {\n"
      "  Vec3<Real> kp = zero3<Real>();\n"
      "  if (n == rank && node_entries <= 8) {\n"
      "#pragma unroll\n"
      "    for (int k = 0; k < 8; ++k)\n"
      "      if (k < node_entries) kp += load3($corner, node_entry[k]);\n"
      "  } else {\n"
      "    kp = ops::gather_corner_sum($corner, g_node_cell_offset, g_node_cell_entry, n);\n"
      "  }\n"
      "  return $fixed[n] != Real(0) ? e : ops::newmark_system_apply(c, $mass[n], e, kp)" + damping_of(damping_term, "n", "e") + ";\n"
      "};\n"
      "cells(kX);\n" +
      grid_start_residual(own, "  const Vec3<Real> q = node_apply(n, load3(v_x, n));\n", "v_r", "v_s") +
      "cells(kU);\n" +
      grid_start_sums(own, "  const Vec3<Real> un = load3(v_z, n), wn = node_apply(n, un);\n", "v_r", "v_w") +
      grid_loop(own, "  cells(kNextU);\n  " + own + " {\n" +
                         grid_own_update("v_r", "v_w", "v_s", "v_r", "v_w", "v_s",
                                         "    const Vec3<Real> wn = node_apply(n, un);\n") +
                         "  }\n"));
}

// The band solves' first band node per thread: its degree and neighbours in registers.
std::string band_own_incidence() {
  return "// The thread's first band node keeps its degree and neighbours in registers.\n"
         "int own_nb[6];\n"
         "#pragma unroll\n"
         "for (int d = 0; d < 6; ++d) own_nb[d] = rank < n_band ? g_band_neighbors[6 * rank + d] : -1;\n"
         "const int own_degree = rank < n_band ? g_band_degree[rank] : 0;\n";
}

// The band Laplacian over the kernel's value(source, node) (extension_apply), then the
// solve's start on the vectors r, s, w.
std::string band_laplacian_and_start(const std::string& own, const std::string& r, const std::string& s,
                                     const std::string& w) {
  return "// L e at band node n for the nodal values e = value(source, node); e(n) into en\n"
         "// (extension_apply).\n"
         "auto laplacian = [&](int n, int source, Vec3<Real>& en) {\n"
         "  const bool mine = n == rank;\n"
         "  en = value(source, n);\n"
         "  Vec3<Real> s = Real(mine ? own_degree : g_band_degree[n]) * en;\n"
         "#pragma unroll\n"
         "  for (int d = 0; d < 6; ++d) {\n"
         "    const int nb = mine ? own_nb[d] : g_band_neighbors[6 * n + d];\n"
         "    if (nb >= 0) s -= value(source, nb);\n"
         "  }\n"
         "  return s;\n"
         "};\n" +
         grid_start_residual(own,
                             "  Vec3<Real> xn;\n"
                             "  const Vec3<Real> q = laplacian(n, kX, xn);\n",
                             r, s) +
         grid_start_sums(own, "  Vec3<Real> un;\n  const Vec3<Real> wn = laplacian(n, kU, un);\n", r, w);
}

// The band Laplacian L e(n) = deg(n) e(n) - sum of e over the band neighbours: one phase
// per iteration, each thread evaluating u at its node's neighbours (next_u), so r, w, s
// alternate between two buffers (neighbours read the previous iteration's while owners
// write the next).
Snippet extension_grid_loop(const Graph& g, int op) {
  Builder b(g, op, "extension_pcg_grid", Extent::Grid);
  b.grid("band_neighbors", "int").grid("band_degree", "int");
  b.vec("r2", true, "3 * n_band", true).vec("w2", true, "3 * n_band", true).vec("s2", true, "3 * n_band", true);
  grid_solve_params(b, "3 * n_band", "extension");
  b.stage("whole PCG solve in one cooperative kernel: band Laplacian and update (grid barriers)", true);
  const std::string own = "for (int n = rank; n < n_band; n += threads)";
  return b.code(grid_prologue() +
      "Real *r_now = v_r, *w_now = v_w, *s_now = v_s, *r_next = v_r2, *w_next = v_w2, *s_next = v_s2;\n" +
      grid_next_u("r_now", "w_now", "s_now") + band_own_incidence() +
      band_laplacian_and_start(own, "r_now", "s_now", "w_now") +
      grid_loop(own, "  " + own + " {\n"
                         "    Vec3<Real> u_own;\n"
                         "    const Vec3<Real> wn = laplacian(n, kNextU, u_own);\n" +
                         grid_own_update("r_now", "w_now", "s_now", "r_next", "w_next", "s_next", "") +
                         "  }\n"
                         "  Real* t = r_now; r_now = r_next; r_next = t;\n"
                         "  t = w_now; w_now = w_next; w_next = t;\n"
                         "  t = s_now; s_now = s_next; s_next = t;\n"));
}

// The same solve for throughput, when each thread owns several band nodes (large
// batches): two phases per iteration, the own-node update (s, p, x, r) and, after a grid
// barrier, w = L u with u = M^-1 r read at the neighbours, then the reduction. Neighbours
// read one stored vector instead of evaluating u from three, no vector is double
// buffered, and the Jacobi diagonal 1/deg comes from the degree: per node five vectors
// (x, r, w, s, p) instead of ten, so a batch's solver state stays in L2. Every value is
// the same expression as in extension_grid_loop, so both give the same bits.
Snippet extension_grid_two_phase(const Graph& g, int op) {
  Builder b(g, op, "extension_pcg_grid_two_phase", Extent::Grid);
  b.grid("band_neighbors", "int").grid("band_degree", "int");
  grid_solve_params(b, "3 * n_band", "extension_two_phase");
  b.stage("whole PCG solve in one cooperative kernel, two phases per iteration (grid barriers)", true);
  const std::string own = "for (int n = rank; n < n_band; n += threads)";
  return b.code(grid_prologue() + band_own_incidence() +
      "auto degree = [&](int m) { return m == rank ? own_degree : g_band_degree[m]; };\n"
      "// M^-1 = 1 / deg as a vector (extension_setup's inv_diag, the same bits).\n"
      "auto inv_diag = [&](int m) { const Real d = Real(1) / Real(degree(m)); return make_vec3(d, d, d); };\n"
      "constexpr int kX = 0, kU = 1;\n"
      "auto value = [&](int source, int m) {\n"
      "  return source == kX ? load3(v_x, m) : times(inv_diag(m), load3(v_r, m));\n"
      "};\n" +
      band_laplacian_and_start(own, "v_r", "v_s", "v_w") +
      grid_loop(own, "  " + own + " {\n"
                         "    const Vec3<Real> inv = inv_diag(n), rn_old = load3(v_r, n);\n"
                         "    const Vec3<Real> sn = load3(v_w, n) + beta * load3(v_s, n);\n"
                         "    const Vec3<Real> pn = times(inv, rn_old) + beta * load3(v_p, n);\n"
                         "    store3(v_x, n, load3(v_x, n) + step * pn);\n"
                         "    store3(v_s, n, sn);\n"
                         "    store3(v_p, n, pn);\n"
                         "    store3(v_r, n, rn_old - step * sn);\n"
                         "  }\n"
                         "  gen::grid_sync(bar);\n"
                         "  " + own + " {\n"
                         "    Vec3<Real> un;\n"
                         "    const Vec3<Real> wn = laplacian(n, kU, un);\n"
                         "    const Vec3<Real> rn = load3(v_r, n);\n"
                         "    store3(v_w, n, wn);\n"
                         "    for (int k = 0; k < 3; ++k) {\n"
                         "      acc[0] += double(rn[k]) * double(un[k]);\n"
                         "      acc[1] += double(wn[k]) * double(un[k]);\n"
                         "      acc[2] += double(rn[k]) * double(rn[k]);\n"
                         "    }\n"
                         "  }\n"));
}

// After the adjoint solve (w = A^-1 u_bar): rhs_bar += w, and the parameters' share of
// -w^T A u (rotation, Lame, mass, damping coefficients, C) by cells, nodes and a reduction.
void newmark_adjoint_parameters(const Graph& g, int op, std::vector<Snippet>& s) {
  const std::string n = "op" + std::to_string(op);
    s.push_back(Builder(g, op, "newmark_solve_rhs", Extent::Node)
                    .a("rhs").scratch("w", "w_" + n, "Real", Domain::Node, 3, false).barrier()
                    .code("for (int k = 0; k < 3; ++k) $d_rhs[3 * i + k] += $w[3 * i + k];\n"));
    Builder cell(g, op, "newmark_solve_cells", Extent::Cell);
    newmark_scalars(cell).t("rotation").t("lambda").t("mu").t("u", false, true).a("rotation");
    cell.grid("cell_weights", "Real").grid("cell_nodes", "int").scratch("w", "w_" + n, "Real", Domain::Node, 3, false, true);
    cell.scratch("ku", "ku_" + n, "Real", Domain::Cell, 24, true).scratch("red", "red_" + n, "Real", Domain::Cell, 2, true);
    s.push_back(cell.code(std::string(kCoefficients) +
                          "Vec3<Real> pc[8], yb[8], pb[8], y[8];\n"
                          "ops::load_cell_corners($u, g_cell_nodes, i, pc);\n"
                          "for (int k = 0; k < 8; ++k) { yb[k] = (-c.a_k) * load3($w, g_cell_nodes[8 * i + k]); pb[k] = zero3<Real>(); }\n"
                          "const Mat3<Real> R = ops::load_mat3($rotation, i);\n"
                          "Mat3<Real> R_bar = zero33<Real>();\n"
                          "Real l = Real(0), mm = Real(0);\n"
                          "ops::adj_corotated_apply(R, g_cell_weights + 8 * i, $lambda[0], $mu[0], h, pc, yb, R_bar, l, mm, pb);\n"
                          "ops::add_mat3($d_rotation, i, R_bar);\n"
                          "ops::corotated_apply(R, g_cell_weights + 8 * i, $lambda[0], $mu[0], h, pc, y);\n"
                          "for (int k = 0; k < 8; ++k) store3($ku, 8 * i + k, y[k]);\n"
                          "$red[2 * i] = l;\n"
                          "$red[2 * i + 1] = mm;\n"));
    Builder node(g, op, "newmark_solve_nodes", Extent::Node);
    const std::string damped = bind_damping(g, op, node);
    if (!damped.empty()) node.a("damping");
    newmark_scalars(node).t("mass").t("fixed").t("u").a("mass").grid("node_cell_offset", "int").grid("node_cell_entry", "int");
    node.scratch("w", "w_" + n, "Real", Domain::Node, 3, false).scratch("ku", "ku_" + n, "Real", Domain::Cell, 24, false, true);
    node.scratch("red2", "red2_" + n, "double", Domain::Node, 2, true);
    s.push_back(node.code(std::string(kCoefficients) +
                          "if ($fixed[i] != Real(0)) { $red2[2 * i] = 0; $red2[2 * i + 1] = 0; }\n"
                          "else {\n"
                          "  const Vec3<Real> kui = ops::gather_corner_sum($ku, g_node_cell_offset, g_node_cell_entry, i);\n"
                          "  Vec3<Real> ub = zero3<Real>(), kb = zero3<Real>();\n"
                          "  ops::NewmarkCoefficientBars<Real> cb;\n"
                          "  ops::adj_newmark_system_apply(c, $mass[i], load3($u, i), kui, Real(-1) * load3($w, i), $d_mass[i], ub, kb, cb);\n" +
                          (damped.empty() ? std::string()
                                          : std::string("  ops::adj_sym3_apply($d_damping, i, load3($u, i), Real(-1) * load3($w, i));\n")) +
                          "  $red2[2 * i] = double(cb.a_m);\n"
                          "  $red2[2 * i + 1] = double(cb.a_k);\n"
                          "}\n"));
    s.push_back(Builder(g, op, "newmark_solve_reduce", Extent::Item)
                    .a("lambda").a("mu").a("mass_damping").a("stiffness_damping")
                    .scratch("red", "red_" + n, "Real", Domain::Cell, 2, false)
                    .scratch("red2", "red2_" + n, "double", Domain::Node, 2, false).barrier()
                    .code("double v[4] = {0, 0, 0, 0};\n"
                          "for (int e = i; e < n_cell; e += SSC_ITEM) { v[0] += double($red[2 * e]); v[1] += double($red[2 * e + 1]); }\n"
                          "for (int k = i; k < n_node; k += SSC_ITEM) { v[2] += $red2[2 * k]; v[3] += $red2[2 * k + 1]; }\n"
                          "gen::block_sum<4>(v);\n"
                          "if (i == 0) {\n"
                          "  $d_lambda[0] += Real(v[0]);\n"
                          "  $d_mu[0] += Real(v[1]);\n"
                          "  $d_mass_damping[0] += Real(v[2]);\n"
                          "  $d_stiffness_damping[0] += Real(v[3]);\n"
                          "}\n"));
    }

std::vector<Snippet> newmark_solver(const Graph& g, int op, bool adjoint) {
  const std::string x3 = "3 * n_node";
  std::vector<Snippet> s;
  if (!adjoint) {
    Builder b(g, op, "newmark_init", Extent::Node);
    b.t("u", true).t("u_prev").t("v_prev").t("fixed").t("dt").stage("u = u- + dt v- (initial guess)");
    s.push_back(b.code(
        "for (int k = 0; k < 3; ++k)\n"
        "  $u[3 * i + k] = $fixed[i] != Real(0) ? Real(0) : $u_prev[3 * i + k] + $dt[0] * $v_prev[3 * i + k];\n"));
  }
  {
    Builder b(g, op, "newmark_diag", Extent::Len);
    b.t("rotation").t("lambda").t("mu").grid("cell_weights", "Real").value("len", "int");
    b.scratch("corner", "corner", "Real", Domain::Cell, 24, true).stage("Jacobi diagonal, one thread per cell corner", true);
    s.push_back(b.code(
        "const int cell = i >> 3;\n"
        "store3($corner, i, ops::corotated_diagonal_corner(ops::load_mat3($rotation, cell), g_cell_weights + 8 * cell, "
        "$lambda[0], $mu[0], h, i & 7));\n"));
  }
  {
    Builder b(g, op, "newmark_setup", Extent::Node);
    const std::string damped = bind_damping(g, op, b);
    newmark_scalars(b).t("mass").t("fixed").grid("node_cell_offset", "int").grid("node_cell_entry", "int");
    b.scratch("corner", "corner", "Real", Domain::Cell, 24, false, true);
    b.vec("rhs", false, x3).vec("x", true, x3).vec("b", true, x3).vec("inv_diag", true, x3).value("zero_x", "int");
    b.stage("node gather of the diagonal, masked right-hand side", true);
    s.push_back(b.code(std::string(kCoefficients) +
        "const Vec3<Real> kd = ops::gather_corner_sum($corner, g_node_cell_offset, g_node_cell_entry, i);\n"
        "Vec3<Real> d = ops::newmark_system_apply(c, $mass[i], make_vec3(Real(1), Real(1), Real(1)), kd);\n" +
        (damped.empty() ? std::string() : "d += make_vec3($damping[6 * i], $damping[6 * i + 1], $damping[6 * i + 2]);\n") +
        "const bool fixed = $fixed[i] != Real(0);\n"
        "for (int k = 0; k < 3; ++k) {\n"
        "  v_inv_diag[3 * i + k] = fixed ? Real(1) : Real(1) / d[k];\n"
        "  v_b[3 * i + k] = fixed ? Real(0) : v_rhs[3 * i + k];\n"
        "  if (fixed || zero_x) v_x[3 * i + k] = Real(0);\n"
        "}\n"));
  }
  {
    Builder b(g, op, "newmark_apply_cell", Extent::Cell);
    b.t("rotation").t("lambda").t("mu").grid("cell_weights", "Real").grid("cell_nodes", "int");
    b.vec("p", false, x3, true).scratch("corner", "corner", "Real", Domain::Cell, 24, true);
    b.value("gate", "int").scratch("cg", "cg", "double", Domain::Scalar, 16, false);
    b.stage("loop: element apply R K R^T p per cell corner", true);
    s.push_back(b.code(
        "if (gate != 0 && $cg[6] == 0.0) return;  // solve stopped for this item\n"
        "Vec3<Real> pc[8], y[8];\n"
        "ops::load_cell_corners(v_p, g_cell_nodes, i, pc);\n"
        "ops::corotated_apply(ops::load_mat3($rotation, i), g_cell_weights + 8 * i, $lambda[0], $mu[0], h, pc, y);\n"
        "for (int k = 0; k < 8; ++k) store3($corner, 8 * i + k, y[k]);\n"));
  }
  {
    Builder b(g, op, "newmark_apply_node", Extent::Node);
    const std::string damped = bind_damping(g, op, b);
    newmark_scalars(b).t("mass").t("fixed").grid("node_cell_offset", "int").grid("node_cell_entry", "int");
    b.scratch("corner", "corner", "Real", Domain::Cell, 24, false, true).vec("p", false, x3).vec("q", true, x3);
    b.value("gate", "int").scratch("cg", "cg", "double", Domain::Scalar, 16, false);
    b.stage("loop: node gather, q = (a_m M + a_k K) p", true);
    s.push_back(b.code("if (gate != 0 && $cg[6] == 0.0) return;  // solve stopped for this item\n" +
        std::string(kCoefficients) +
        "const Vec3<Real> kp = ops::gather_corner_sum($corner, g_node_cell_offset, g_node_cell_entry, i);\n"
        "store3(v_q, i, $fixed[i] != Real(0) ? load3(v_p, i) : ops::newmark_system_apply(c, $mass[i], load3(v_p, i), kp)" +
        damping_of(damped, "i", "load3(v_p, i)") + ");\n"));
  }
  for (Snippet& p : pcg_snippets(g, op)) s.push_back(p);
  s.push_back(newmark_grid_loop(g, op));
  if (adjoint) newmark_adjoint_parameters(g, op, s);
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
        "Vec3<Real> s = zero3<Real>();\n"
        "for (int d = 0; d < 6; ++d) {\n"
        "  const int nb = g_band_neighbors[6 * i + d];\n"
        "  if (nb <= -2) s += load3($u, -nb - 2);\n"
        "}\n"
        "store3(v_b, i, s);\n"
        "for (int k = 0; k < 3; ++k) {\n"
        "  $band_u[3 * i + k] = $band_guess[3 * i + k];\n"
        "  v_inv_diag[3 * i + k] = Real(1) / Real(g_band_degree[i]);\n"
        "}\n"));
  } else {
    Builder b(g, op, "extension_adj_setup", Extent::Band);
    b.a("band_u", false).grid("band_degree", "int").vec("x", true, x3).vec("b", true, x3).vec("inv_diag", true, x3);
    b.value("zero_x", "int").stage("rhs = band_u cotangent, x = 0 or the later step's solution, Jacobi diagonal");
    s.push_back(b.code(
        "for (int k = 0; k < 3; ++k) {\n"
        "  v_b[3 * i + k] = $d_band_u[3 * i + k];\n"
        "  if (zero_x) v_x[3 * i + k] = Real(0);\n"
        "  v_inv_diag[3 * i + k] = Real(1) / Real(g_band_degree[i]);\n"
        "}\n"));
  }
  {
    Builder b(g, op, "extension_apply", Extent::Band);
    b.grid("band_neighbors", "int").grid("band_degree", "int").vec("p", false, x3, true).vec("q", true, x3);
    b.value("gate", "int").scratch("cg", "cg", "double", Domain::Scalar, 16, false);
    b.stage("loop: band Laplacian q = L p", true);
    s.push_back(b.code(
        "if (gate != 0 && $cg[6] == 0.0) return;  // solve stopped for this item\n"
        "Vec3<Real> s = Real(g_band_degree[i]) * load3(v_p, i);\n"
        "for (int d = 0; d < 6; ++d) {\n"
        "  const int nb = g_band_neighbors[6 * i + d];\n"
        "  if (nb >= 0) s -= load3(v_p, nb);\n"
        "}\n"
        "store3(v_q, i, s);\n"));
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
                  .code("for (int k = g_node_band_offset[i]; k < g_node_band_offset[i + 1]; ++k)\n"
                        "  add3($d_u, i, load3($y, g_node_band_entry[k]));\n"));
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
