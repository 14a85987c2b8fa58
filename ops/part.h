// What every part of an op (graph/op_spec.h) receives besides its arguments: the cell size
// and the extents of the iteration domains of the batch item it runs for. A part is
//   template <class Real> SSC_HD void name(int i, const PartContext<Real>& cx, args...)
// and is called alike by the interpreter (runtime/) and the generated kernels (codegen/).
#pragma once
#include "ops/ssc_math.h"

namespace ssc {
namespace ops {

template <class Real>
struct PartContext {
  Real h;  // cell size, m
  int n_cell, n_node, n_point, n_band, n_plane;
};

}  // namespace ops
}  // namespace ssc
