// The lumped nodal quantities of the body: each active node's mass (density times the sum
// of its cut-cell corner volumes) and its force (gravity on that mass plus the gathered
// elastic corner forces and contact point forces, ops/gather.h).
#pragma once
#include "ops/gather.h"
#include "ops/part.h"
#include "ops/ssc_math.h"

namespace ssc {
namespace ops {

template <class Real>
SSC_HD inline Real node_mass(Real density, Real node_volume) {
  return density * node_volume;
}

// The corner forces first, then the contact points' (zero without contact).
template <class Real>
SSC_HD inline Vec3<Real> node_force(Real mass, Vec3<Real> gravity, Vec3<Real> corner_sum, Vec3<Real> point_sum) {
  return mass * gravity + corner_sum + point_sum;
}

// ---- adjoints (reverse mode); each accumulates (+=) into its bar arguments ----

template <class Real>
SSC_HD inline void adj_node_mass(Real node_volume, Real mass_bar, Real& density_bar) {
  density_bar += mass_bar * node_volume;
}

// corner_sum_bar and point_sum_bar both receive force_bar (the gathers' own adjoints then
// scatter it to the corners and points, ops/gather.h).
template <class Real>
SSC_HD inline void adj_node_force(Real mass, Vec3<Real> gravity, Vec3<Real> force_bar, Real& mass_bar,
                                  Vec3<Real>& gravity_bar, Vec3<Real>& sum_bar) {
  mass_bar += dot(force_bar, gravity);
  gravity_bar += mass * force_bar;
  sum_bar += force_bar;
}

// ---- the node_mass op ----

template <class Real>
SSC_HD inline void node_mass_node(int i, const PartContext<Real>&, const Real* density, const Real* node_volume, Real* mass) {
  mass[i] = node_mass(density[0], node_volume[i]);
}

// The node's share of the density's cotangent, in double (summed by a reduction part).
template <class Real>
SSC_HD inline void adj_node_mass_node(int i, const PartContext<Real>&, const Real* mass_bar, const Real* node_volume,
                                      double* density_bar_share) {
  double s = 0;
  adj_node_mass(double(node_volume[i]), double(mass_bar[i]), s);
  density_bar_share[i] = s;
}

// ---- the node_force op: gravity plus the gathered corner and (optional) contact point forces
// and (optional) node forces of other ops (air drag) ----

template <class Real>
SSC_HD inline void node_force_node(int i, const PartContext<Real>&, const Real* corner_force, const int* node_cell_offset,
                                   const int* node_cell_entry, const Real* point_force, const Real* point_weights,
                                   const int* node_point_offset, const int* node_point_entry, const Real* body_force,
                                   const Real* mass, const Real* gravity, Real* force) {
  const Vec3<Real> corners = gather_corner_sum(corner_force, node_cell_offset, node_cell_entry, i);
  Vec3<Real> points =
      point_force ? gather_point_sum(point_force, point_weights, node_point_offset, node_point_entry, i) : zero3<Real>();
  if (body_force) points += load3(body_force, i);
  store3(force, i, node_force(mass[i], load3(gravity, 0), corners, points));
}

template <class Real>
SSC_HD inline void adj_node_force_body(int i, const PartContext<Real>&, const Real* force_bar, Real* body_force_bar) {
  add3(body_force_bar, i, load3(force_bar, i));
}

// The corners' cotangents: each corner takes its node's force cotangent.
template <class Real>
SSC_HD inline void adj_node_force_corners(int i, const PartContext<Real>&, const Real* force_bar, const int* cell_nodes,
                                          Real* corner_force_bar) {
  for (int c = 0; c < 8; ++c) add3(corner_force_bar, 8 * i + c, load3(force_bar, cell_nodes[8 * i + c]));
}

// The contact points' cotangents: their corners' force cotangents, weighted.
template <class Real>
SSC_HD inline void adj_node_force_points(int i, const PartContext<Real>&, const Real* force_bar, const int* point_nodes,
                                         const Real* point_weights, Real* point_force_bar) {
  add3(point_force_bar, i, point_vec3(i, point_nodes, point_weights, force_bar));
}

// The mass's cotangent and the node's share of gravity's (double, summed by a reduction).
template <class Real>
SSC_HD inline void adj_node_force_node(int i, const PartContext<Real>&, const Real* mass, const Real* gravity,
                                       const Real* force_bar, Real* mass_bar, double* gravity_bar_share) {
  Vec3<Real> gravity_bar = zero3<Real>(), sum_bar = zero3<Real>();
  adj_node_force(mass[i], load3(gravity, 0), load3(force_bar, i), mass_bar[i], gravity_bar, sum_bar);
  for (int k = 0; k < 3; ++k) gravity_bar_share[3 * i + k] = double(gravity_bar[k]);
}

#ifdef SSC_OP_SPECS
inline OpSpec node_mass_spec() {
  OpSpec s;
  s.name = "node_mass";
  s.domain = Domain::Node;
  s.slots = {in("density"), out("mass")};
  s.scratch = {{"red", Domain::Node, 1, ""}};
  s.forward = {part("node_mass", Extent::Node, SSC_PART(node_mass_node), {"density", "#node_volume", "mass"})};
  s.adjoint = {part("node_mass", Extent::Node, SSC_ADJOINT_PART(adj_node_mass_node), {"d_mass", "#node_volume", "$red"}),
               reduction("node_mass_reduce", {"$red"}, {"d_density"})};
  return s;
}

inline OpSpec node_force_spec() {
  OpSpec s;
  s.name = "node_force";
  s.domain = Domain::Node;
  s.slots = {in("corner_force", Access::Gather), optional_in("point_force", Access::Gather), optional_in("body_force"),
             in("mass"), in("gravity"), out("force")};
  s.scratch = {{"red", Domain::Node, 3, ""}};
  s.forward = {part("node_force", Extent::Node, SSC_PART(node_force_node),
                    {"corner_force^", "#node_cell_offset", "#node_cell_entry", "point_force^", "#point_weights",
                     "#node_point_offset", "#node_point_entry", "body_force", "mass", "gravity", "force"})};
  s.adjoint = {
      part("node_force_corners", Extent::Cell, SSC_ADJOINT_PART(adj_node_force_corners),
           {"d_force^", "#cell_nodes", "d_corner_force"}),
      when_bound(part("node_force_points", Extent::Point, SSC_ADJOINT_PART(adj_node_force_points),
                      {"d_force^", "#point_nodes", "#point_weights", "d_point_force"}),
                 "point_force"),
      when_bound(part("node_force_body", Extent::Node, SSC_ADJOINT_PART(adj_node_force_body), {"d_force", "d_body_force"}),
                 "body_force"),
      part("node_force", Extent::Node, SSC_ADJOINT_PART(adj_node_force_node),
           {"mass", "gravity", "d_force", "d_mass", "$red"}),
      reduction("node_force_reduce", {"$red"}, {"d_gravity"})};
  return s;
}
#endif

}  // namespace ops
}  // namespace ssc
