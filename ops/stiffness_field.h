// A heterogeneous body's Young's modulus per cell (the "heterogeneous_stiffness" extension):
//   E_cell = (s_0 E + sum_r s_r E_r) * exp(g . o_cell),
// s_r the fraction of the cell's inside part in material region r (static cell_region_share,
// region_count[0] per cell), s_0 = 1 - sum_r s_r the rest, at the body's youngs_modulus E, g the
// stiffness gradient (1/m) and o_cell the cell's rest centre minus the body's rest centre of mass
// (static cell_offset). The volume-weighted modulus is what integrating a modulus that jumps
// inside the cell over the cell gives where the strain is uniform in it; a cell wholly in one
// region takes that region's modulus exactly. A cut cell's centre is the centroid of its inside
// part, sum_c w_c x_c / sum_c w_c with the cut-cell corner weights. Without regions every cell
// takes youngs_modulus, without a gradient the factor is 1. The lame op (ops/elasticity.h) turns
// E_cell into the cell's Lame parameters.
#pragma once
#include "ops/gather.h"
#include "ops/part.h"
#include "ops/ssc_math.h"

namespace ssc {
namespace ops {

template <class Real>
SSC_HD inline Real stiffness_factor(const Real* stiffness_gradient, const Real* cell_offset, int i) {
  return stiffness_gradient ? exp(dot(load3(stiffness_gradient, 0), load3(cell_offset, i))) : Real(1);
}

// The cell's modulus before the gradient's factor: its regions' moduli weighted by their shares.
template <class Real>
SSC_HD inline Real mixed_youngs(const Real* youngs_modulus, const Real* region_youngs, const Real* cell_region_share,
                                const int* region_count, int i) {
  if (!region_youngs) return youngs_modulus[0];
  const int R = region_count[0];
  Real rest = Real(1), mixed = Real(0);
  for (int k = 0; k < R; ++k) {
    rest -= cell_region_share[R * i + k];
    mixed += cell_region_share[R * i + k] * region_youngs[k];
  }
  return rest * youngs_modulus[0] + mixed;
}

template <class Real>
SSC_HD inline void stiffness_field_cell(int i, const PartContext<Real>&, const Real* youngs_modulus,
                                        const Real* region_youngs, const Real* stiffness_gradient,
                                        const Real* cell_region_share, const int* region_count,
                                        const Real* cell_offset, Real* cell_youngs) {
  cell_youngs[i] = mixed_youngs(youngs_modulus, region_youngs, cell_region_share, region_count, i) *
                   stiffness_factor(stiffness_gradient, cell_offset, i);
}

// The cell's shares (double, summed by reduction parts) of the cotangents of youngs_modulus
// (1 a cell), region_youngs (region_count[0] a cell, the static count of the scene's regions)
// and the gradient (3 a cell).
template <class Real>
SSC_HD inline void adj_stiffness_field_cell(int i, const PartContext<Real>&, const Real* youngs_modulus,
                                            const Real* region_youngs, const Real* stiffness_gradient,
                                            const Real* cell_region_share, const int* region_count,
                                            const Real* cell_offset, const Real* cell_youngs_bar,
                                            double* youngs_bar_share, double* region_bar_share,
                                            double* gradient_bar_share) {
  const Real factor = stiffness_factor(stiffness_gradient, cell_offset, i);
  const Real E_bar = cell_youngs_bar[i];
  Real rest = Real(1);
  if (region_youngs) {
    const int R = region_count[0];
    for (int k = 0; k < R; ++k) {
      rest -= cell_region_share[R * i + k];
      region_bar_share[R * i + k] = double(E_bar * factor * cell_region_share[R * i + k]);
    }
  }
  youngs_bar_share[i] = double(E_bar * factor * rest);
  if (stiffness_gradient) {
    const Vec3<Real> o = load3(cell_offset, i);
    const Real s = E_bar * mixed_youngs(youngs_modulus, region_youngs, cell_region_share, region_count, i) * factor;
    for (int k = 0; k < 3; ++k) gradient_bar_share[3 * i + k] = double(s * o[k]);
  }
}

#ifdef SSC_OP_SPECS
inline OpSpec stiffness_field_spec() {
  OpSpec s;
  s.name = "stiffness_field";
  s.domain = Domain::Cell;
  s.slots = {in("youngs_modulus"), optional_in("region_youngs"), optional_in("stiffness_gradient"), out("cell_youngs")};
  s.scratch = {{"red", Domain::Cell, 1, ""},
               {"regionbar", Domain::Cell, 0, "region_youngs"},
               {"gradientbar", Domain::Cell, 3, ""}};
  s.forward = {part("stiffness_field", Extent::Cell, SSC_PART(stiffness_field_cell),
                    {"youngs_modulus", "region_youngs", "stiffness_gradient", "#cell_region_share",
                     "#region_count", "#cell_offset", "cell_youngs"})};
  s.adjoint = {part("stiffness_field", Extent::Cell, SSC_ADJOINT_PART(adj_stiffness_field_cell),
                    {"youngs_modulus", "region_youngs", "stiffness_gradient", "#cell_region_share",
                     "#region_count", "#cell_offset", "d_cell_youngs", "$red", "$regionbar", "$gradientbar"}),
               reduction("stiffness_field_reduce", {"$red"}, {"d_youngs_modulus"}),
               when_bound(reduction("stiffness_field_region_reduce", {"$regionbar"}, {"d_region_youngs"}),
                          "region_youngs"),
               when_bound(reduction("stiffness_field_gradient_reduce", {"$gradientbar"}, {"d_stiffness_gradient"}),
                          "stiffness_gradient")};
  return s;
}
#endif

}  // namespace ops
}  // namespace ssc
