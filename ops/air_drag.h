// Quadratic air drag on the body's surface (the "air_drag" extension), treated implicitly.
//
// A surface element with outward unit normal n moving with velocity v into the air (w = v.n
// > 0) meets the pressure rho_a w^2 against its normal: force per area
//   q = -rho_a |v.n| (v.n) n  for v.n > 0, else 0
// (Newtonian impact drag: the air in front of each element is brought to its normal speed;
// the leeward side sees no suction). Unlike Rayleigh mass damping (-alpha m v on every node,
// in proportion to mass and linear in v) it acts on the surface only, grows with v^2, and
// depends on orientation. A body of mass m falling with the velocity -V e reaches
//   V_terminal = sqrt(m g / (rho_a A_eff)),  A_eff = integral over the front of |n.e|^3 dA
// (a sphere of radius r: A_eff = pi r^2 / 2; a face of area A normal to e: A).
// Discretisation: the cut cells' surface weights s_c = integral over the cell's zero level
// set of N_c (the consistent nodal shares of its area) with the cell's normal n = R n0 (n0
// the rest SDF gradient, R the cell's rotation), at each corner's node velocity v:
//   f_c = -rho_a s_c w^2 n,  C_c = -df_c/dv = 2 rho_a s_c w n n^T   (w = v.n > 0).
// The node sums of f_c and C_c (symmetric positive semi-definite) enter the theta-scheme as
// the friction op's do (ops/newmark.h): f at v-, C in the system.
#pragma once
#include "ops/corotation.h"
#include "ops/gather.h"
#include "ops/newmark.h"
#include "ops/part.h"
#include "ops/ssc_math.h"

namespace ssc {
namespace ops {

// Adds the drag of one corner (surface weight s, normal n, node velocity v) to f and C
// (6 values: xx yy zz xy xz yz).
template <class Real>
SSC_HD inline void corner_drag(Real rho, Real s, Vec3<Real> n, Vec3<Real> v, Vec3<Real>& f, Real* C) {
  const Real w = dot(v, n);
  if (!(w > Real(0)) || s == Real(0)) return;
  f += (-rho * s * w * w) * n;
  add_sym3_outer(C, Real(2) * rho * s * w, n);
}

// Adjoint of corner_drag for the cotangents f_bar and C_bar (of the 6 stored values); with
// nGn = sum_k C_bar[k] (n n^T)[k] and G the symmetric matrix of C_bar (off-diagonals halved):
//   w_bar = -2 rho s w f_bar.n + 2 rho s nGn,  n_bar = -rho s w^2 f_bar + 4 rho s w G n + w_bar v,
//   v_bar = w_bar n,  rho_bar = -s w^2 f_bar.n + 2 s w nGn.
template <class Real>
SSC_HD inline void adj_corner_drag(Real rho, Real s, Vec3<Real> n, Vec3<Real> v, Vec3<Real> f_bar, const Real* C_bar,
                                   Vec3<Real>& n_bar, Vec3<Real>& v_bar, Real& rho_bar) {
  const Real w = dot(v, n);
  if (!(w > Real(0)) || s == Real(0)) return;
  const Vec3<Real> Gn = sym3_cotangent_apply(C_bar, n);
  const Real nGn = dot(n, Gn), fn = dot(f_bar, n);
  const Real w_bar = Real(-2) * rho * s * w * fn + Real(2) * rho * s * nGn;
  n_bar += (-rho * s * w * w) * f_bar + (Real(4) * rho * s * w) * Gn + w_bar * v;
  v_bar += w_bar * n;
  rho_bar += -s * w * w * fn + Real(2) * s * w * nGn;
}

// The current normal of cell e.
template <class Real>
SSC_HD inline Vec3<Real> cell_normal(const Real* rotation, const Real* cell_rest_normal, int e) {
  return load_mat3(rotation, e) * load3(cell_rest_normal, e);
}

// ---- the air_drag op ----

// Node i: the drag of its cell corners, added to the damping matrix given (friction's) if any.
template <class Real>
SSC_HD inline void air_drag_node(int i, const PartContext<Real>&, const Real* air_drag, const Real* v_prev,
                                 const Real* rotation, const Real* cell_rest_normal, const Real* cell_surface_weights,
                                 const int* node_cell_offset, const int* node_cell_entry, const Real* damping_in,
                                 Real* drag_force, Real* damping) {
  Vec3<Real> f = zero3<Real>();
  Real C[6];
  for (int j = 0; j < 6; ++j) C[j] = damping_in ? damping_in[6 * i + j] : Real(0);
  const Vec3<Real> v = load3(v_prev, i);
  for (int k = node_cell_offset[i]; k < node_cell_offset[i + 1]; ++k) {
    const int entry = node_cell_entry[k];
    corner_drag(air_drag[0], cell_surface_weights[entry], cell_normal(rotation, cell_rest_normal, entry >> 3), v, f, C);
  }
  store3(drag_force, i, f);
  for (int j = 0; j < 6; ++j) damping[6 * i + j] = C[j];
}

// Cell e: the rotation's cotangent from its corners, each corner's share of its node's
// velocity cotangent (corner_bar, 8 a cell; gathered by the next part) and the cell's share
// of air_drag's (double, summed by a reduction).
template <class Real>
SSC_HD inline void adj_air_drag_cell(int e, const PartContext<Real>&, const Real* air_drag, const Real* v_prev,
                                     const Real* rotation, const Real* cell_rest_normal, const Real* cell_surface_weights,
                                     const int* cell_nodes, const Real* drag_force_bar, const Real* damping_bar,
                                     Real* rotation_bar, Real* corner_bar, double* air_drag_bar_share) {
  const Vec3<Real> n0 = load3(cell_rest_normal, e);
  const Vec3<Real> n = cell_normal(rotation, cell_rest_normal, e);
  Vec3<Real> n_bar = zero3<Real>();
  Real rho_bar = Real(0);
  for (int c = 0; c < 8; ++c) {
    const int node = cell_nodes[8 * e + c];
    Vec3<Real> v_bar = zero3<Real>();
    adj_corner_drag(air_drag[0], cell_surface_weights[8 * e + c], n, load3(v_prev, node), load3(drag_force_bar, node),
                    damping_bar + 6 * node, n_bar, v_bar, rho_bar);
    store3(corner_bar, 8 * e + c, v_bar);
  }
  add_mat3(rotation_bar, e, outer(n_bar, n0));
  air_drag_bar_share[e] = double(rho_bar);
}

// The damping given passes its cotangent through.
template <class Real>
SSC_HD inline void adj_air_drag_damping_node(int i, const PartContext<Real>&, const Real* damping_bar,
                                             Real* damping_in_bar) {
  for (int j = 0; j < 6; ++j) damping_in_bar[6 * i + j] += damping_bar[6 * i + j];
}

#ifdef SSC_OP_SPECS
inline OpSpec air_drag_spec() {
  OpSpec s;
  s.name = "air_drag";
  s.domain = Domain::Node;
  s.slots = {in("air_drag"), in("v_prev"), in("rotation", Access::Gather), optional_in("damping_in"),
             out("drag_force"), out("damping")};
  s.scratch = {{"corner", Domain::Cell, 24, ""}, {"red", Domain::Cell, 1, ""}};
  s.forward = {part("air_drag", Extent::Node, SSC_PART(air_drag_node),
                    {"air_drag", "v_prev", "rotation^", "#cell_rest_normal", "#cell_surface_weights",
                     "#node_cell_offset", "#node_cell_entry", "damping_in", "drag_force", "damping"})};
  s.adjoint = {part("air_drag", Extent::Cell, SSC_ADJOINT_PART(adj_air_drag_cell),
                    {"air_drag", "v_prev^", "rotation", "#cell_rest_normal", "#cell_surface_weights", "#cell_nodes",
                     "d_drag_force^", "d_damping^", "d_rotation", "$corner", "$red"}),
               part("air_drag_gather", Extent::Node, SSC_ADJOINT_PART(add_corner_sum),
                    {"$corner^", "#node_cell_offset", "#node_cell_entry", "d_v_prev"}),
               when_bound(part("air_drag_damping", Extent::Node, SSC_ADJOINT_PART(adj_air_drag_damping_node),
                               {"d_damping", "d_damping_in"}),
                          "damping_in"),
               reduction("air_drag_reduce", {"$red"}, {"d_air_drag"})};
  return s;
}
#endif

}  // namespace ops
}  // namespace ssc
