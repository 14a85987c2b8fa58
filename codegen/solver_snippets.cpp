// The solver stages of the opaque ops (see op_snippets.h): NewmarkSolve and
// ExtensionSolve become setup kernels plus Jacobi-PCG, either as one persistent grid
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
    Builder b(g, op, "newmark_diag", Extent::Cell);
    b.t("rotation").t("lambda").t("mu").grid("cell_weights", "Real");
    b.scratch("corner", "corner", "Real", Domain::Cell, 24, true).stage("Jacobi diagonal, per cell corner", true);
    s.push_back(b.code(
        "Vec3<Real> d[8];\n"
        "ops::corotated_diagonal(gen::load_mat3($rotation, i), g_cell_weights + 8 * i, $lambda[0], $mu[0], h, d);\n"
        "for (int k = 0; k < 8; ++k) store3($corner, 8 * i + k, d[k]);\n"));
  }
  {
    Builder b(g, op, "newmark_setup", Extent::Node);
    newmark_scalars(b).t("mass").t("fixed").grid("node_cell_offset", "int").grid("node_cell_entry", "int");
    b.scratch("corner", "corner", "Real", Domain::Cell, 24, false, true);
    b.vec("rhs", false, x3).vec("x", true, x3).vec("b", true, x3).vec("inv_diag", true, x3).value("zero_x", "int");
    b.stage("node gather of the diagonal, masked right-hand side", true);
    s.push_back(b.code(std::string(kCoefficients) +
        "const Vec3<Real> kd = ops::gather_corner_sum($corner, g_node_cell_offset, g_node_cell_entry, i);\n"
        "const Vec3<Real> d = ops::newmark_system_apply(c, $mass[i], make_vec3(Real(1), Real(1), Real(1)), kd);\n"
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
        "ops::corotated_apply(gen::load_mat3($rotation, i), g_cell_weights + 8 * i, $lambda[0], $mu[0], h, pc, y);\n"
        "for (int k = 0; k < 8; ++k) store3($corner, 8 * i + k, y[k]);\n"));
  }
  {
    Builder b(g, op, "newmark_apply_node", Extent::Node);
    newmark_scalars(b).t("mass").t("fixed").grid("node_cell_offset", "int").grid("node_cell_entry", "int");
    b.scratch("corner", "corner", "Real", Domain::Cell, 24, false, true).vec("p", false, x3).vec("q", true, x3);
    b.value("gate", "int").scratch("cg", "cg", "double", Domain::Scalar, 16, false);
    b.stage("loop: node gather, q = (a_m M + a_k K) p", true);
    s.push_back(b.code("if (gate != 0 && $cg[6] == 0.0) return;  // solve stopped for this item\n" +
        std::string(kCoefficients) +
        "const Vec3<Real> kp = ops::gather_corner_sum($corner, g_node_cell_offset, g_node_cell_entry, i);\n"
        "store3(v_q, i, $fixed[i] != Real(0) ? load3(v_p, i) : ops::newmark_system_apply(c, $mass[i], load3(v_p, i), kp));\n"));
  }
  for (Snippet& p : pcg_snippets(g, op)) s.push_back(p);
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
  {
    // The whole PCG loop of the band Laplacian in one block per item: apply (neighbour
    // reads of p within the item's own vector, so a block barrier suffices) and the same
    // arithmetic as pcg_iterate, until the convergence test stops it; no host checks.
    Builder b(g, op, "extension_pcg_loop", Extent::Item);
    b.grid("band_neighbors", "int").grid("band_degree", "int");
    b.vec("x", true, x3).vec("r", true, x3).vec("z", true, x3).vec("p", true, x3, true).vec("q", true, x3);
    b.vec("inv_diag", false, x3).value("len", "int").value("tol", "double").value("max_it", "int");
    b.scratch("cg", "cg", "double", Domain::Scalar, 16, true);
    b.stage("loop: whole PCG loop, band Laplacian q = L p + the pcg_iterate update (block per item)", true);
    s.push_back(b.code(
        "const double b_norm = $cg[0];\n"
        "double rz = $cg[1], its = $cg[7];\n"
        "bool active = $cg[6] != 0.0;\n"
        "__syncthreads();  // every thread has read the state before thread 0 rewrites it\n"
        "while (active) {\n"
        "  for (int n = i; n < n_band; n += SSC_ITEM) {\n"
        "    Vec3<Real> s = Real(g_band_degree[n]) * load3(v_p, n);\n"
        "    for (int d = 0; d < 6; ++d) {\n"
        "      const int nb = g_band_neighbors[6 * n + d];\n"
        "      if (nb >= 0) s -= load3(v_p, nb);\n"
        "    }\n"
        "    store3(v_q, n, s);\n"
        "  }\n"
        "  __syncthreads();\n"
        "  double pq[1] = {0};\n"
        "  for (int k = i; k < len; k += SSC_ITEM) pq[0] += double(v_p[k]) * double(v_q[k]);\n"
        "  gen::block_sum<1>(pq);\n"
        "  const Real step = Real(rz / pq[0]);\n"
        "  double acc[2] = {0, 0};\n"
        "  for (int k = i; k < len; k += SSC_ITEM) {\n"
        "    v_x[k] += step * v_p[k];\n"
        "    const Real rk = v_r[k] - step * v_q[k];\n"
        "    const Real zk = v_inv_diag[k] * rk;\n"
        "    v_r[k] = rk;\n"
        "    v_z[k] = zk;\n"
        "    acc[0] += double(rk) * double(zk);\n"
        "    acc[1] += double(rk) * double(rk);\n"
        "  }\n"
        "  gen::block_sum<2>(acc);\n"
        "  const Real beta = Real(acc[0] / rz);\n"
        "  for (int k = i; k < len; k += SSC_ITEM) v_p[k] = v_z[k] + beta * v_p[k];\n"
        "  __syncthreads();  // p complete before the next apply reads neighbours\n"
        "  rz = acc[0];\n"
        "  its += 1;\n"
        "  const double r_norm = sqrt(acc[1]);\n"
        "  const double rel = r_norm / b_norm;\n"
        "  bool converged = false;\n"
        "  if (rel <= tol) { active = false; converged = true; }\n"
        "  else if (its >= double(max_it) || !isfinite(r_norm)) active = false;\n"
        "  if (i == 0) {\n"
        "    $cg[1] = rz; $cg[2] = r_norm; $cg[3] = pq[0]; $cg[4] = double(step); $cg[5] = double(beta);\n"
        "    $cg[6] = active ? 1 : 0; $cg[7] = its; $cg[8] = rel; $cg[9] = converged ? 1 : 0;\n"
        "  }\n"
        "}\n"));
  }
  return s;
}

}  // namespace

std::vector<Snippet> solver_snippets(const Graph& g, int op, bool adjoint) {
  const OpKind k = g.ops().at(op).kind;
  if (k == OpKind::NewmarkSolve) return newmark_solver(g, op, adjoint);
  if (k == OpKind::ExtensionSolve) return extension_solver(g, op, adjoint);
  throw std::logic_error("codegen: solver_snippets of a non-opaque op");
}

}  // namespace ssc
