// The lumped nodal quantities of the body: each active node's mass (density times the sum
// of its cut-cell corner volumes) and its force (gravity on that mass plus the gathered
// elastic corner forces and contact point forces, ops/gather.h).
#pragma once
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

}  // namespace ops
}  // namespace ssc
