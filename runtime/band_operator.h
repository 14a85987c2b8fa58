// The displacement extension as one dense product, the GPU's direct "how" of the
// "band_laplacian" schedule. band_u = L^-1 B u, where B sums u over each band node's
// active neighbours, is linear in u at the active nodes that touch the band (the
// sources) with one matrix G = L^-1 B for every step, batch item, parameter value and
// component. G is formed once per grid from the band factor (runtime/band_factor.h), one
// column per source, and kept for the process (a diagnosis builds many simulations on
// one grid). The GPU then extends by band_u = G u and back-propagates by
// u_bar += G^T band_u_bar (codegen/solver_kernels.cuh): no iteration, the same result as
// the CPU's factor to rounding. Grids whose G would exceed kDenseExtensionBytes keep the PCG.
#pragma once
#include <cstddef>
#include <memory>
#include <vector>

#include "runtime/static_arrays.h"

namespace ssc {

constexpr size_t kDenseExtensionBytes = size_t(384) << 20;  // G in double

struct BandExtensionOperator {
  int band_count = 0;
  std::vector<int> sources;     // active node ids with a band neighbour, ascending
  std::vector<double> columns;  // G: one column of band_count values per source
};

// G for grid g, built on first use and cached by the band's incidence; nullptr where the
// grid has no band, G would exceed kDenseExtensionBytes or the factorisation failed.
std::shared_ptr<const BandExtensionOperator> band_extension_operator(const StaticArrays& g);

}  // namespace ssc
