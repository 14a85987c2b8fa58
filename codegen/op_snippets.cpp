// Per-op CUDA fragments (see op_snippets.h). Each fragment mirrors one executor of
// runtime/interpreter.cpp (forward) or runtime/interpreter_adjoint.cpp (adjoint) so that
// generated kernels and the interpreter evaluate the same expressions in the same order.
#include "codegen/op_snippets.h"

#include <fmt/format.h>

#include <cctype>
#include <map>
#include <stdexcept>

namespace ssc {

const char* extent_name(Extent e) {
  switch (e) {
    case Extent::One: return "one";
    case Extent::Cell: return "cell";
    case Extent::Node: return "node";
    case Extent::Point: return "point";
    case Extent::Band: return "band";
    case Extent::Len: return "vec";
    case Extent::Item: return "item";
  }
  return "?";
}

Domain extent_domain(Extent e) {
  switch (e) {
    case Extent::Cell: return Domain::Cell;
    case Extent::Node: return Domain::Node;
    case Extent::Point: return Domain::Point;
    case Extent::Band: return Domain::Band;
    default: return Domain::Scalar;
  }
}

bool is_opaque(OpKind k) { return k == OpKind::NewmarkSolve || k == OpKind::ExtensionSolve; }

namespace {

std::string count_expr(Domain d) {
  switch (d) {
    case Domain::Scalar: return "1";
    case Domain::Cell: return "n_cell";
    case Domain::Node: return "n_node";
    case Domain::Point: return "n_point";
    case Domain::Band: return "n_band";
  }
  return "1";
}

// Builds the parameter list and the $name substitutions of one fragment.
class Builder {
 public:
  Builder(const Graph& g, int op, std::string label, Extent extent) : g_(g), op_(op) {
    s_.label = std::move(label);
    s_.op = op;
    s_.extent = extent;
  }
  // Forward value of an op slot (input or output): $slot.
  Builder& t(const std::string& slot, bool write = false, bool gather = false) {
    const int id = tensor_of(slot);
    add(KernelParam::Kind::Tensor, "t_" + g_.tensor(id).name, "Real", write, gather, id);
    subst_[slot] = "t_" + g_.tensor(id).name;
    return *this;
  }
  // Cotangent of an op slot: $d_slot.
  Builder& a(const std::string& slot, bool write = true, bool gather = false) {
    const int id = tensor_of(slot);
    add(KernelParam::Kind::Adjoint, "a_" + g_.tensor(id).name, "Real", write, gather, id);
    subst_["d_" + slot] = "a_" + g_.tensor(id).name;
    return *this;
  }
  Builder& grid(const std::string& name, const std::string& type, bool gather = false) {
    add(KernelParam::Kind::Grid, "g_" + name, type, false, gather, -1);
    return *this;
  }
  // Scratch buffer, per batch item count(domain) * components; $key names it.
  Builder& scratch(const std::string& key, const std::string& name, const std::string& type, Domain d, int comps,
                   bool write, bool gather = false, const std::string& stride = "") {
    KernelParam& p = add(KernelParam::Kind::Scratch, "s_" + name, type, write, gather, -1);
    p.domain = d;
    p.components = comps;
    p.stride = d == Domain::Scalar ? std::to_string(comps) : fmt::format("{} * {}", count_expr(d), comps);
    if (!stride.empty()) p.stride = stride;
    subst_[key] = "s_" + name;
    return *this;
  }
  // Solver vector bound per launch (length `stride` per batch item).
  Builder& vec(const std::string& name, bool write, const std::string& stride, bool gather = false) {
    KernelParam& p = add(KernelParam::Kind::Vector, "v_" + name, "Real", write, gather, -1);
    p.stride = stride;
    return *this;
  }
  Builder& value(const std::string& name, const std::string& type) {
    add(KernelParam::Kind::Value, name, type, false, false, -1);
    return *this;
  }
  Builder& stage(const std::string& s, bool shared = false) {
    s_.stage = s;
    s_.barrier = true;
    s_.shared = shared;
    return *this;
  }
  Builder& barrier() {
    s_.barrier = true;
    return *this;
  }
  Snippet code(const std::string& text) {
    s_.code = substitute(text);
    return s_;
  }

 private:
  int tensor_of(const std::string& slot) const {
    const OpNode& o = g_.ops().at(op_);
    for (const OpArg& x : o.inputs)
      if (x.slot == slot) return x.tensor;
    for (const OpArg& x : o.outputs)
      if (x.slot == slot) return x.tensor;
    throw std::logic_error(fmt::format("codegen: op {} ({}) has no slot '{}'", op_, op_kind_name(o.kind), slot));
  }
  KernelParam& add(KernelParam::Kind kind, const std::string& name, const std::string& type, bool write, bool gather,
                   int tensor) {
    for (KernelParam& p : s_.params)
      if (p.name == name) {
        p.write |= write;
        p.gather |= gather;
        return p;
      }
    KernelParam p;
    p.kind = kind;
    p.name = name;
    p.type = type;
    p.write = write;
    p.gather = gather;
    p.tensor = tensor;
    if (tensor >= 0) {
      const TensorInfo& t = g_.tensor(tensor);
      p.domain = t.domain;
      p.components = t.components;
      p.stride = t.domain == Domain::Scalar ? std::to_string(t.components)
                                            : fmt::format("{} * {}", count_expr(t.domain), t.components);
    }
    s_.params.push_back(p);
    return s_.params.back();
  }
  std::string substitute(const std::string& text) const {
    std::string out;
    for (size_t k = 0; k < text.size(); ++k) {
      if (text[k] != '$') {
        out += text[k];
        continue;
      }
      size_t e = k + 1;
      while (e < text.size() && (std::isalnum(static_cast<unsigned char>(text[e])) || text[e] == '_')) ++e;
      const std::string key = text.substr(k + 1, e - k - 1);
      auto it = subst_.find(key);
      if (it == subst_.end()) throw std::logic_error("codegen: fragment " + s_.label + " uses unbound $" + key);
      out += it->second;
      k = e - 1;
    }
    return out;
  }

  const Graph& g_;
  int op_;
  Snippet s_;
  std::map<std::string, std::string> subst_;
};

bool has_slot(const OpNode& o, const char* slot) {
  for (const OpArg& a : o.inputs)
    if (a.slot == slot) return true;
  return false;
}

const char* kCoefficients =
    "const ops::NewmarkCoefficients<Real> c = ops::newmark_coefficients($dt[0], $theta[0], $mass_damping[0], "
    "$stiffness_damping[0]);\n";

Builder& newmark_scalars(Builder& b) { return b.t("dt").t("theta").t("mass_damping").t("stiffness_damping"); }

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

std::string opname(int op) { return "op" + std::to_string(op); }

}  // namespace

std::vector<Snippet> solver_snippets(const Graph& g, int op, bool adjoint) {
  const OpKind k = g.ops().at(op).kind;
  if (k == OpKind::NewmarkSolve) return newmark_solver(g, op, adjoint);
  if (k == OpKind::ExtensionSolve) return extension_solver(g, op, adjoint);
  throw std::logic_error("codegen: solver_snippets of a non-opaque op");
}

Snippet forward_snippet(const Graph& g, int op) {
  const OpNode& o = g.ops().at(op);
  switch (o.kind) {
    case OpKind::Lame:
      return Builder(g, op, "lame", Extent::One)
          .t("youngs_modulus").t("poisson_ratio").t("lambda", true).t("mu", true)
          .code("Real lambda_, mu_;\n"
                "ops::lame_from_young($youngs_modulus[0], $poisson_ratio[0], lambda_, mu_);\n"
                "$lambda[0] = lambda_;\n"
                "$mu[0] = mu_;\n");
    case OpKind::NodeMass:
      return Builder(g, op, "node_mass", Extent::Node)
          .t("density").t("mass", true).grid("node_volume", "Real")
          .code("$mass[i] = $density[0] * g_node_volume[i];\n");
    case OpKind::Corotation:
      return Builder(g, op, "corotation", Extent::Cell)
          .t("u_prev", false, true).t("rotation", true).t("polar_status", true).grid("cell_nodes", "int")
          .code("Vec3<Real> uc[8];\n"
                "ops::load_cell_corners($u_prev, g_cell_nodes, i, uc);\n"
                "Mat3<Real> R;\n"
                "const int status = ops::polar_rotation(ops::cell_deformation_gradient(uc, h), R);\n"
                "gen::store_mat3($rotation, i, R);\n"
                "$polar_status[i] = Real(status);\n");
    case OpKind::CorotationForce:
      return Builder(g, op, "corotation_force", Extent::Cell)
          .t("rotation").t("lambda").t("mu").t("corner_force", true).grid("cell_weights", "Real")
          .code("Vec3<Real> fc[8];\n"
                "ops::corotation_offset_force(gen::load_mat3($rotation, i), g_cell_weights + 8 * i, $lambda[0], $mu[0], h, fc);\n"
                "for (int c = 0; c < 8; ++c) store3($corner_force, 8 * i + c, fc[c]);\n");
    case OpKind::ContactForce:
      return Builder(g, op, "contact_force", Extent::Point)
          .t("u_prev", false, true).t("v_prev", false, true).t("ground_planes").t("dt").t("theta").t("point_force", true)
          .grid("point_nodes", "int").grid("point_t", "Real").grid("point_area", "Real").grid("node_rest", "Real", true)
          .code("ops::GroundPlane<Real> planes[ops::kMaxGroundPlanes];\n"
                "const int plane_count = gen::load_planes($ground_planes, n_plane, planes);\n"
                "const int na = g_point_nodes[2 * i], nb = g_point_nodes[2 * i + 1];\n"
                "const Real t = g_point_t[i];\n"
                "const Vec3<Real> xa = load3(g_node_rest, na), xb = load3(g_node_rest, nb);\n"
                "const Vec3<Real> x = (Real(1) - t) * (xa + load3($u_prev, na)) + t * (xb + load3($u_prev, nb));\n"
                "const Vec3<Real> vel = (Real(1) - t) * load3($v_prev, na) + t * load3($v_prev, nb);\n"
                "store3($point_force, i, ops::contact_force(x, vel, g_point_area[i], planes, plane_count, $dt[0], $theta[0]));\n");
    case OpKind::NodeForce: {
      Builder b(g, op, "node_force", Extent::Node);
      b.t("corner_force", false, true).t("mass").t("gravity").t("force", true);
      b.grid("node_cell_offset", "int").grid("node_cell_entry", "int");
      std::string code =
          "Vec3<Real> s = $mass[i] * load3($gravity, 0) + ops::gather_corner_sum($corner_force, g_node_cell_offset, g_node_cell_entry, i);\n";
      if (has_slot(o, "point_force")) {
        b.t("point_force", false, true).grid("point_t", "Real").grid("node_point_offset", "int").grid("node_point_entry", "int");
        code += "s += ops::gather_point_sum($point_force, g_point_t, g_node_point_offset, g_node_point_entry, i);\n";
      }
      return b.code(code + "store3($force, i, s);\n");
    }
    case OpKind::StiffnessApply:
      return Builder(g, op, "stiffness_apply", Extent::Cell)
          .t("rotation").t("lambda").t("mu").t("u_prev", false, true).t("ku_corner", true)
          .grid("cell_weights", "Real").grid("cell_nodes", "int")
          .code("Vec3<Real> pc[8], y[8];\n"
                "ops::load_cell_corners($u_prev, g_cell_nodes, i, pc);\n"
                "ops::corotated_apply(gen::load_mat3($rotation, i), g_cell_weights + 8 * i, $lambda[0], $mu[0], h, pc, y);\n"
                "for (int c = 0; c < 8; ++c) store3($ku_corner, 8 * i + c, y[c]);\n");
    case OpKind::NewmarkRhs: {
      Builder b(g, op, "newmark_rhs", Extent::Node);
      newmark_scalars(b).t("ku_corner", false, true).t("mass").t("u_prev").t("v_prev").t("force").t("rhs", true);
      b.grid("node_cell_offset", "int").grid("node_cell_entry", "int");
      return b.code(std::string(kCoefficients) +
                    "const Vec3<Real> kui = ops::gather_corner_sum($ku_corner, g_node_cell_offset, g_node_cell_entry, i);\n"
                    "store3($rhs, i, ops::newmark_rhs(c, $mass[i], load3($u_prev, i), load3($v_prev, i), kui, load3($force, i)));\n");
    }
    case OpKind::VelocityUpdate:
      return Builder(g, op, "velocity_update", Extent::Node)
          .t("u").t("u_prev").t("v_prev").t("dt").t("theta").t("v", true)
          .code("const ops::NewmarkCoefficients<Real> c = ops::newmark_coefficients($dt[0], $theta[0], Real(0), Real(0));\n"
                "store3($v, i, ops::newmark_velocity(c, load3($u, i), load3($u_prev, i), load3($v_prev, i)));\n");
    case OpKind::NewmarkSolve:
    case OpKind::ExtensionSolve:
      break;
  }
  throw std::logic_error(fmt::format("codegen: op {} ({}) is opaque and has no forward fragment", op, op_kind_name(o.kind)));
}

std::vector<Snippet> adjoint_snippets(const Graph& g, int op) {
  const OpNode& o = g.ops().at(op);
  const std::string n = opname(op);
  std::vector<Snippet> s;
  auto corner_gather = [&](const char* label, const char* slot) {
    Builder b(g, op, label, Extent::Node);
    b.a(slot).scratch("corner", "corner_" + n, "Real", Domain::Cell, 24, false, true);
    b.grid("node_cell_offset", "int").grid("node_cell_entry", "int");
    return b.code(fmt::format("add3($d_{}, i, ops::gather_corner_sum($corner, g_node_cell_offset, g_node_cell_entry, i));\n", slot));
  };
  auto lame_reduce = [&](const char* label) {
    Builder b(g, op, label, Extent::Item);
    b.a("lambda").a("mu").scratch("red", "red_" + n, "Real", Domain::Cell, 2, false).barrier();
    return b.code(
        "double lm[2] = {0, 0};\n"
        "for (int e = i; e < n_cell; e += SSC_ITEM) { lm[0] += double($red[2 * e]); lm[1] += double($red[2 * e + 1]); }\n"
        "gen::block_sum<2>(lm);\n"
        "if (i == 0) { $d_lambda[0] += Real(lm[0]); $d_mu[0] += Real(lm[1]); }\n");
  };
  switch (o.kind) {
    case OpKind::Lame:
      s.push_back(Builder(g, op, "lame", Extent::One)
                      .t("youngs_modulus").t("poisson_ratio").a("lambda", false).a("mu", false)
                      .a("youngs_modulus").a("poisson_ratio")
                      .code("ops::adj_lame_from_young($youngs_modulus[0], $poisson_ratio[0], $d_lambda[0], $d_mu[0], "
                            "$d_youngs_modulus[0], $d_poisson_ratio[0]);\n"));
      break;
    case OpKind::NodeMass:
      s.push_back(Builder(g, op, "node_mass", Extent::Node)
                      .a("mass", false).grid("node_volume", "Real").scratch("red", "red_" + n, "double", Domain::Node, 1, true)
                      .code("$red[i] = double($d_mass[i]) * double(g_node_volume[i]);\n"));
      s.push_back(Builder(g, op, "node_mass_reduce", Extent::Item)
                      .a("density").scratch("red", "red_" + n, "double", Domain::Node, 1, false).barrier()
                      .code("double sum[1] = {0};\n"
                            "for (int k = i; k < n_node; k += SSC_ITEM) sum[0] += $red[k];\n"
                            "gen::block_sum<1>(sum);\n"
                            "if (i == 0) $d_density[0] += Real(sum[0]);\n"));
      break;
    case OpKind::Corotation:
      s.push_back(Builder(g, op, "corotation", Extent::Cell)
                      .t("u_prev", false, true).t("rotation").t("polar_status").a("rotation", false).grid("cell_nodes", "int")
                      .scratch("corner", "corner_" + n, "Real", Domain::Cell, 24, true)
                      .code("Vec3<Real> uc[8], ub[8];\n"
                            "ops::load_cell_corners($u_prev, g_cell_nodes, i, uc);\n"
                            "for (int c = 0; c < 8; ++c) ub[c] = zero3<Real>();\n"
                            "Mat3<Real> F_bar = zero33<Real>();\n"
                            "ops::adj_polar_rotation(ops::cell_deformation_gradient(uc, h), gen::load_mat3($rotation, i), "
                            "int($polar_status[i]), gen::load_mat3($d_rotation, i), F_bar);\n"
                            "ops::adj_cell_deformation_gradient(F_bar, h, ub);\n"
                            "for (int c = 0; c < 8; ++c) store3($corner, 8 * i + c, ub[c]);\n"));
      s.push_back(corner_gather("corotation_gather", "u_prev"));
      break;
    case OpKind::CorotationForce:
      s.push_back(Builder(g, op, "corotation_force", Extent::Cell)
                      .t("rotation").t("lambda").t("mu").a("corner_force", false).a("rotation").grid("cell_weights", "Real")
                      .scratch("red", "red_" + n, "Real", Domain::Cell, 2, true)
                      .code("Vec3<Real> fb[8];\n"
                            "for (int c = 0; c < 8; ++c) fb[c] = load3($d_corner_force, 8 * i + c);\n"
                            "Mat3<Real> R_bar = zero33<Real>();\n"
                            "Real l = Real(0), m = Real(0);\n"
                            "ops::adj_corotation_offset_force(gen::load_mat3($rotation, i), g_cell_weights + 8 * i, $lambda[0], "
                            "$mu[0], h, fb, R_bar, l, m);\n"
                            "gen::add_mat3($d_rotation, i, R_bar);\n"
                            "$red[2 * i] = l;\n"
                            "$red[2 * i + 1] = m;\n"));
      s.push_back(lame_reduce("corotation_force_reduce"));
      break;
    case OpKind::ContactForce:
      s.push_back(Builder(g, op, "contact_force", Extent::Point)
                      .t("u_prev", false, true).t("v_prev", false, true).t("ground_planes").t("dt").t("theta")
                      .a("point_force", false)
                      .grid("point_nodes", "int").grid("point_t", "Real").grid("point_area", "Real").grid("node_rest", "Real", true)
                      .scratch("xbar", "xbar_" + n, "Real", Domain::Point, 3, true)
                      .scratch("vbar", "vbar_" + n, "Real", Domain::Point, 3, true)
                      .scratch("pbar", "planebar_" + n, "Real", Domain::Point, kMaxPlaneBars, true)
                      .code("ops::GroundPlane<Real> planes[ops::kMaxGroundPlanes];\n"
                            "const int plane_count = gen::load_planes($ground_planes, n_plane, planes);\n"
                            "const int na = g_point_nodes[2 * i], nb = g_point_nodes[2 * i + 1];\n"
                            "const Real t = g_point_t[i];\n"
                            "const Vec3<Real> xa = load3(g_node_rest, na), xb = load3(g_node_rest, nb);\n"
                            "const Vec3<Real> x = (Real(1) - t) * (xa + load3($u_prev, na)) + t * (xb + load3($u_prev, nb));\n"
                            "const Vec3<Real> vel = (Real(1) - t) * load3($v_prev, na) + t * load3($v_prev, nb);\n"
                            "Vec3<Real> xb_ = zero3<Real>(), vb_ = zero3<Real>();\n"
                            "Vec3<Real> nbar[ops::kMaxGroundPlanes];\n"
                            "Real hbar[ops::kMaxGroundPlanes];\n"
                            "for (int k = 0; k < plane_count; ++k) { nbar[k] = zero3<Real>(); hbar[k] = Real(0); }\n"
                            "ops::adj_contact_force(x, vel, g_point_area[i], planes, plane_count, $dt[0], $theta[0], "
                            "load3($d_point_force, i), xb_, vb_, nbar, hbar);\n"
                            "store3($xbar, i, xb_);\n"
                            "store3($vbar, i, vb_);\n"
                            "for (int k = 0; k < plane_count; ++k) {\n"
                            "  Real* pb = $pbar + 32 * i + 4 * k;\n"
                            "  pb[0] = nbar[k].x; pb[1] = nbar[k].y; pb[2] = nbar[k].z; pb[3] = hbar[k];\n"
                            "}\n"));
      s.push_back(Builder(g, op, "contact_force_gather", Extent::Node)
                      .a("u_prev").a("v_prev").grid("point_t", "Real").grid("node_point_offset", "int").grid("node_point_entry", "int")
                      .scratch("xbar", "xbar_" + n, "Real", Domain::Point, 3, false, true)
                      .scratch("vbar", "vbar_" + n, "Real", Domain::Point, 3, false, true)
                      .code("add3($d_u_prev, i, ops::gather_point_sum($xbar, g_point_t, g_node_point_offset, g_node_point_entry, i));\n"
                            "add3($d_v_prev, i, ops::gather_point_sum($vbar, g_point_t, g_node_point_offset, g_node_point_entry, i));\n"));
      s.push_back(Builder(g, op, "contact_force_reduce", Extent::Item)
                      .a("ground_planes").scratch("pbar", "planebar_" + n, "Real", Domain::Point, kMaxPlaneBars, false).barrier()
                      .code("for (int k = 0; k < n_plane; ++k) {\n"
                            "  double sum[4] = {0, 0, 0, 0};\n"
                            "  for (int p = i; p < n_point; p += SSC_ITEM)\n"
                            "    for (int j = 0; j < 4; ++j) sum[j] += double($pbar[32 * p + 4 * k + j]);\n"
                            "  gen::block_sum<4>(sum);\n"
                            "  if (i == 0)\n"
                            "    for (int j = 0; j < 4; ++j) $d_ground_planes[6 * k + j] += Real(sum[j]);\n"
                            "}\n"));
      break;
    case OpKind::NodeForce: {
      s.push_back(Builder(g, op, "node_force_corners", Extent::Cell)
                      .a("force", false, true).a("corner_force").grid("cell_nodes", "int")
                      .code("for (int c = 0; c < 8; ++c) add3($d_corner_force, 8 * i + c, load3($d_force, g_cell_nodes[8 * i + c]));\n"));
      if (has_slot(o, "point_force"))
        s.push_back(Builder(g, op, "node_force_points", Extent::Point)
                        .a("force", false, true).a("point_force").grid("point_nodes", "int").grid("point_t", "Real")
                        .code("const Real t = g_point_t[i];\n"
                              "add3($d_point_force, i, (Real(1) - t) * load3($d_force, g_point_nodes[2 * i]) + "
                              "t * load3($d_force, g_point_nodes[2 * i + 1]));\n"));
      s.push_back(Builder(g, op, "node_force", Extent::Node)
                      .a("force", false).t("mass").t("gravity").a("mass")
                      .scratch("red", "red_" + n, "double", Domain::Node, 3, true)
                      .code("const Vec3<Real> fb = load3($d_force, i);\n"
                            "$d_mass[i] += dot(fb, load3($gravity, 0));\n"
                            "for (int k = 0; k < 3; ++k) $red[3 * i + k] = double($mass[i]) * double(fb[k]);\n"));
      s.push_back(Builder(g, op, "node_force_reduce", Extent::Item)
                      .a("gravity").scratch("red", "red_" + n, "double", Domain::Node, 3, false).barrier()
                      .code("double gb[3] = {0, 0, 0};\n"
                            "for (int k = i; k < n_node; k += SSC_ITEM)\n"
                            "  for (int j = 0; j < 3; ++j) gb[j] += $red[3 * k + j];\n"
                            "gen::block_sum<3>(gb);\n"
                            "if (i == 0)\n"
                            "  for (int j = 0; j < 3; ++j) $d_gravity[j] += Real(gb[j]);\n"));
      break;
    }
    case OpKind::StiffnessApply:
      s.push_back(Builder(g, op, "stiffness_apply", Extent::Cell)
                      .t("rotation").t("lambda").t("mu").t("u_prev", false, true).a("ku_corner", false).a("rotation")
                      .grid("cell_weights", "Real").grid("cell_nodes", "int")
                      .scratch("corner", "corner_" + n, "Real", Domain::Cell, 24, true)
                      .scratch("red", "red_" + n, "Real", Domain::Cell, 2, true)
                      .code("Vec3<Real> pc[8], yb[8], pb[8];\n"
                            "ops::load_cell_corners($u_prev, g_cell_nodes, i, pc);\n"
                            "for (int c = 0; c < 8; ++c) { yb[c] = load3($d_ku_corner, 8 * i + c); pb[c] = zero3<Real>(); }\n"
                            "Mat3<Real> R_bar = zero33<Real>();\n"
                            "Real l = Real(0), m = Real(0);\n"
                            "ops::adj_corotated_apply(gen::load_mat3($rotation, i), g_cell_weights + 8 * i, $lambda[0], $mu[0], h, "
                            "pc, yb, R_bar, l, m, pb);\n"
                            "gen::add_mat3($d_rotation, i, R_bar);\n"
                            "for (int c = 0; c < 8; ++c) store3($corner, 8 * i + c, pb[c]);\n"
                            "$red[2 * i] = l;\n"
                            "$red[2 * i + 1] = m;\n"));
      s.push_back(corner_gather("stiffness_apply_gather", "u_prev"));
      s.push_back(lame_reduce("stiffness_apply_reduce"));
      break;
    case OpKind::NewmarkRhs: {
      Builder cell(g, op, "newmark_rhs_corners", Extent::Cell);
      newmark_scalars(cell).a("rhs", false, true).a("ku_corner").grid("cell_nodes", "int");
      s.push_back(cell.code(std::string(kCoefficients) +
                            "for (int k = 0; k < 8; ++k) add3($d_ku_corner, 8 * i + k, c.b_k * load3($d_rhs, g_cell_nodes[8 * i + k]));\n"));
      Builder node(g, op, "newmark_rhs", Extent::Node);
      newmark_scalars(node).t("mass").t("u_prev").t("v_prev").t("ku_corner", false, true).a("rhs", false);
      node.a("mass").a("u_prev").a("v_prev").a("force").grid("node_cell_offset", "int").grid("node_cell_entry", "int");
      node.scratch("red", "red_" + n, "double", Domain::Node, 2, true);
      s.push_back(node.code(std::string(kCoefficients) +
                            "const Vec3<Real> rb = load3($d_rhs, i), ui = load3($u_prev, i), vi = load3($v_prev, i);\n"
                            "const Vec3<Real> kui = ops::gather_corner_sum($ku_corner, g_node_cell_offset, g_node_cell_entry, i);\n"
                            "$d_mass[i] += dot(rb, c.a_m * ui + c.inv_theta * vi);\n"
                            "add3($d_u_prev, i, (c.a_m * $mass[i]) * rb);\n"
                            "add3($d_v_prev, i, ($mass[i] * c.inv_theta) * rb);\n"
                            "add3($d_force, i, c.dt * rb);\n"
                            "$red[2 * i] = double($mass[i]) * double(dot(rb, ui));\n"
                            "$red[2 * i + 1] = double(dot(rb, kui));\n"));
      s.push_back(Builder(g, op, "newmark_rhs_reduce", Extent::Item)
                      .a("mass_damping").a("stiffness_damping").scratch("red", "red_" + n, "double", Domain::Node, 2, false).barrier()
                      .code("double ab[2] = {0, 0};\n"
                            "for (int k = i; k < n_node; k += SSC_ITEM) { ab[0] += $red[2 * k]; ab[1] += $red[2 * k + 1]; }\n"
                            "gen::block_sum<2>(ab);\n"
                            "if (i == 0) { $d_mass_damping[0] += Real(ab[0]); $d_stiffness_damping[0] += Real(ab[1]); }\n"));
      break;
    }
    case OpKind::NewmarkSolve: {
      for (Snippet& x : solver_snippets(g, op, true)) s.push_back(x);
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
                            "const Mat3<Real> R = gen::load_mat3($rotation, i);\n"
                            "Mat3<Real> R_bar = zero33<Real>();\n"
                            "Real l = Real(0), mm = Real(0);\n"
                            "ops::adj_corotated_apply(R, g_cell_weights + 8 * i, $lambda[0], $mu[0], h, pc, yb, R_bar, l, mm, pb);\n"
                            "gen::add_mat3($d_rotation, i, R_bar);\n"
                            "ops::corotated_apply(R, g_cell_weights + 8 * i, $lambda[0], $mu[0], h, pc, y);\n"
                            "for (int k = 0; k < 8; ++k) store3($ku, 8 * i + k, y[k]);\n"
                            "$red[2 * i] = l;\n"
                            "$red[2 * i + 1] = mm;\n"));
      Builder node(g, op, "newmark_solve_nodes", Extent::Node);
      newmark_scalars(node).t("mass").t("fixed").t("u").a("mass").grid("node_cell_offset", "int").grid("node_cell_entry", "int");
      node.scratch("w", "w_" + n, "Real", Domain::Node, 3, false).scratch("ku", "ku_" + n, "Real", Domain::Cell, 24, false, true);
      node.scratch("red2", "red2_" + n, "double", Domain::Node, 2, true);
      s.push_back(node.code(std::string(kCoefficients) +
                            "if ($fixed[i] != Real(0)) { $red2[2 * i] = 0; $red2[2 * i + 1] = 0; }\n"
                            "else {\n"
                            "  const Vec3<Real> wi = load3($w, i), ui = load3($u, i);\n"
                            "  const Vec3<Real> kui = ops::gather_corner_sum($ku, g_node_cell_offset, g_node_cell_entry, i);\n"
                            "  $d_mass[i] -= c.a_m * dot(wi, ui);\n"
                            "  $red2[2 * i] = -(double($mass[i]) * double(dot(wi, ui)));\n"
                            "  $red2[2 * i + 1] = -double(dot(wi, kui));\n"
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
      break;
    }
    case OpKind::VelocityUpdate:
      s.push_back(Builder(g, op, "velocity_update", Extent::Node)
                      .t("dt").t("theta").a("v", false).a("u").a("u_prev").a("v_prev")
                      .code("const Real s = Real(1) / ($theta[0] * $dt[0]), q = (Real(1) - $theta[0]) / $theta[0];\n"
                            "for (int k = 0; k < 3; ++k) {\n"
                            "  const int j = 3 * i + k;\n"
                            "  $d_u[j] += s * $d_v[j];\n"
                            "  $d_u_prev[j] -= s * $d_v[j];\n"
                            "  $d_v_prev[j] -= q * $d_v[j];\n"
                            "}\n"));
      break;
    case OpKind::ExtensionSolve:
      for (Snippet& x : solver_snippets(g, op, true)) s.push_back(x);
      s.push_back(Builder(g, op, "extension_solve_nodes", Extent::Node)
                      .a("u").grid("node_band_offset", "int").grid("node_band_entry", "int")
                      .scratch("y", "y_" + n, "Real", Domain::Band, 3, false, true).barrier()
                      .code("for (int k = g_node_band_offset[i]; k < g_node_band_offset[i + 1]; ++k)\n"
                            "  add3($d_u, i, load3($y, g_node_band_entry[k]));\n"));
      break;
  }
  return s;
}

}  // namespace ssc
