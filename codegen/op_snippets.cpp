// Per-op CUDA fragments (see op_snippets.h). Each fragment mirrors one executor of
// runtime/interpreter.cpp (forward) or runtime/interpreter_adjoint.cpp (adjoint) so that
// generated kernels and the interpreter evaluate the same expressions in the same order.
#include "codegen/op_snippets.h"

#include <fmt/format.h>

#include <stdexcept>

#include "codegen/snippet_builder.h"

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
    case Extent::Grid: return "grid";
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

using namespace snippet;

// The contact planes of the item (forward and adjoint of ContactForce share them).
const char* const kContactPlanes =
    "ops::GroundPlane<Real> planes[ops::kMaxGroundPlanes];\n"
    "const int plane_count = gen::load_planes($ground_planes, n_plane, planes);\n";

std::string opname(int op) { return "op" + std::to_string(op); }

}  // namespace


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
          .code("$mass[i] = ops::node_mass($density[0], g_node_volume[i]);\n");
    case OpKind::Corotation:
      return Builder(g, op, "corotation", Extent::Cell)
          .t("u_prev", false, true).t("rotation", true).t("polar_status", true).grid("cell_nodes", "int")
          .code("ops::corotation_cell(i, $u_prev, g_cell_nodes, h, $rotation, $polar_status);\n");
    case OpKind::CorotationForce:
      return Builder(g, op, "corotation_force", Extent::Cell)
          .t("rotation").t("lambda").t("mu").t("corner_force", true).grid("cell_weights", "Real")
          .code("ops::corotation_force_cell(i, $rotation, g_cell_weights, $lambda[0], $mu[0], h, $corner_force);\n");
    case OpKind::ContactForce:
      return Builder(g, op, "contact_force", Extent::Point)
          .t("u_prev", false, true).t("v_prev", false, true).t("ground_planes").t("dt").t("theta").t("point_force", true)
          .grid("point_nodes", "int").grid("point_t", "Real").grid("point_area", "Real").grid("node_rest", "Real", true)
          .code(std::string(kContactPlanes) +
                "store3($point_force, i, ops::contact_point_force(i, g_point_nodes, g_point_t, g_point_area, g_node_rest, "
                "$u_prev, $v_prev, planes, plane_count, $dt[0], $theta[0]));\n");
    case OpKind::NodeForce: {
      Builder b(g, op, "node_force", Extent::Node);
      b.t("corner_force", false, true).t("mass").t("gravity").t("force", true);
      b.grid("node_cell_offset", "int").grid("node_cell_entry", "int");
      std::string code =
          "const Vec3<Real> corners = ops::gather_corner_sum($corner_force, g_node_cell_offset, g_node_cell_entry, i);\n";
      if (has_slot(o, "point_force")) {
        b.t("point_force", false, true).grid("point_t", "Real").grid("node_point_offset", "int").grid("node_point_entry", "int");
        code += "const Vec3<Real> points = ops::gather_point_sum($point_force, g_point_t, g_node_point_offset, g_node_point_entry, i);\n";
      } else {
        code += "const Vec3<Real> points = zero3<Real>();\n";
      }
      return b.code(code + "store3($force, i, ops::node_force($mass[i], load3($gravity, 0), corners, points));\n");
    }
    case OpKind::StiffnessApply:
      return Builder(g, op, "stiffness_apply", Extent::Cell)
          .t("rotation").t("lambda").t("mu").t("u_prev", false, true).t("ku_corner", true)
          .grid("cell_weights", "Real").grid("cell_nodes", "int")
          .code("ops::stiffness_apply_cell(i, $rotation, g_cell_weights, $lambda[0], $mu[0], h, $u_prev, g_cell_nodes, "
                "$ku_corner);\n");
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
                      .code("double density_bar = 0;\n"
                            "ops::adj_node_mass(double(g_node_volume[i]), double($d_mass[i]), density_bar);\n"
                            "$red[i] = density_bar;\n"));
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
                      .code("ops::adj_corotation_cell(i, $u_prev, g_cell_nodes, h, $rotation, $polar_status, $d_rotation, "
                            "$corner);\n"));
      s.push_back(corner_gather("corotation_gather", "u_prev"));
      break;
    case OpKind::CorotationForce:
      s.push_back(Builder(g, op, "corotation_force", Extent::Cell)
                      .t("rotation").t("lambda").t("mu").a("corner_force", false).a("rotation").grid("cell_weights", "Real")
                      .scratch("red", "red_" + n, "Real", Domain::Cell, 2, true)
                      .code("Real l = Real(0), m = Real(0);\n"
                            "ops::adj_corotation_force_cell(i, $rotation, g_cell_weights, $lambda[0], $mu[0], h, $d_corner_force, "
                            "$d_rotation, l, m);\n"
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
                      .code(std::string(kContactPlanes) +
                            "Vec3<Real> xb_ = zero3<Real>(), vb_ = zero3<Real>();\n"
                            "Vec3<Real> nbar[ops::kMaxGroundPlanes];\n"
                            "Real hbar[ops::kMaxGroundPlanes];\n"
                            "for (int k = 0; k < plane_count; ++k) { nbar[k] = zero3<Real>(); hbar[k] = Real(0); }\n"
                            "ops::adj_contact_point_force(i, g_point_nodes, g_point_t, g_point_area, g_node_rest, $u_prev, "
                            "$v_prev, planes, plane_count, $dt[0], $theta[0], load3($d_point_force, i), xb_, vb_, nbar, hbar);\n"
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
                      .code("Vec3<Real> gravity_bar = zero3<Real>(), sum_bar = zero3<Real>();\n"
                            "ops::adj_node_force($mass[i], load3($gravity, 0), load3($d_force, i), $d_mass[i], gravity_bar, sum_bar);\n"
                            "for (int k = 0; k < 3; ++k) $red[3 * i + k] = double(gravity_bar[k]);\n"));
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
                      .code("Real l = Real(0), m = Real(0);\n"
                            "ops::adj_stiffness_apply_cell(i, $rotation, g_cell_weights, $lambda[0], $mu[0], h, $u_prev, "
                            "g_cell_nodes, $d_ku_corner, $d_rotation, $corner, l, m);\n"
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
                            "const Vec3<Real> kui = ops::gather_corner_sum($ku_corner, g_node_cell_offset, g_node_cell_entry, i);\n"
                            "Vec3<Real> ub = load3($d_u_prev, i), vb = load3($d_v_prev, i), fb = load3($d_force, i);\n"
                            "Vec3<Real> kb = zero3<Real>();  // the corners' share: newmark_rhs_corners\n"
                            "ops::NewmarkCoefficientBars<Real> cb;\n"
                            "ops::adj_newmark_rhs(c, $mass[i], load3($u_prev, i), load3($v_prev, i), kui, load3($d_rhs, i), "
                            "$d_mass[i], ub, vb, kb, fb, cb);\n"
                            "store3($d_u_prev, i, ub);\n"
                            "store3($d_v_prev, i, vb);\n"
                            "store3($d_force, i, fb);\n"
                            "$red[2 * i] = double(cb.a_m);\n"
                            "$red[2 * i + 1] = double(cb.b_k);\n"));
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
      newmark_scalars(node).t("mass").t("fixed").t("u").a("mass").grid("node_cell_offset", "int").grid("node_cell_entry", "int");
      node.scratch("w", "w_" + n, "Real", Domain::Node, 3, false).scratch("ku", "ku_" + n, "Real", Domain::Cell, 24, false, true);
      node.scratch("red2", "red2_" + n, "double", Domain::Node, 2, true);
      s.push_back(node.code(std::string(kCoefficients) +
                            "if ($fixed[i] != Real(0)) { $red2[2 * i] = 0; $red2[2 * i + 1] = 0; }\n"
                            "else {\n"
                            "  const Vec3<Real> kui = ops::gather_corner_sum($ku, g_node_cell_offset, g_node_cell_entry, i);\n"
                            "  Vec3<Real> ub = zero3<Real>(), kb = zero3<Real>();\n"
                            "  ops::NewmarkCoefficientBars<Real> cb;\n"
                            "  ops::adj_newmark_system_apply(c, $mass[i], load3($u, i), kui, Real(-1) * load3($w, i), $d_mass[i], ub, kb, cb);\n"
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
      break;
    }
    case OpKind::VelocityUpdate:
      s.push_back(Builder(g, op, "velocity_update", Extent::Node)
                      .t("dt").t("theta").a("v", false).a("u").a("u_prev").a("v_prev")
                      .code("const ops::NewmarkCoefficients<Real> c = ops::newmark_coefficients($dt[0], $theta[0], Real(0), Real(0));\n"
                            "Vec3<Real> ub = load3($d_u, i), upb = load3($d_u_prev, i), vpb = load3($d_v_prev, i);\n"
                            "ops::adj_newmark_velocity(c, load3($d_v, i), ub, upb, vpb);\n"
                            "store3($d_u, i, ub);\n"
                            "store3($d_u_prev, i, upb);\n"
                            "store3($d_v_prev, i, vpb);\n"));
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
