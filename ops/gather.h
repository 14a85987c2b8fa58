// Deterministic element-to-node transfers. Per-cell ops write one value per cell corner
// (8 x 3 Reals per cell); nodes then sum the corners that touch them through a fixed,
// ascending incidence list. No atomics, so the sum order (and the result) never changes.
#pragma once
#include "ops/part.h"
#include "ops/ssc_math.h"

namespace ssc {
namespace ops {

// Sum of per-corner vectors over the (cell, corner) entries of one node.
template <class Real>
SSC_HD inline Vec3<Real> gather_corner_sum(const Real* corner_values, const int* offset, const int* entry, int node) {
  Vec3<Real> s = zero3<Real>();
  for (int k = offset[node]; k < offset[node + 1]; ++k) s += load3(corner_values, entry[k]);
  return s;
}

// Sum of per-point vectors split to edge nodes: entry = point * 2 + side, side 0 takes
// (1 - t), side 1 takes t.
template <class Real>
SSC_HD inline Vec3<Real> gather_point_sum(const Real* point_values, const Real* point_t, const int* offset,
                                          const int* entry, int node) {
  Vec3<Real> s = zero3<Real>();
  for (int k = offset[node]; k < offset[node + 1]; ++k) {
    const int p = entry[k] >> 1;
    const Real w = (entry[k] & 1) ? point_t[p] : Real(1) - point_t[p];
    s += w * load3(point_values, p);
  }
  return s;
}

// The same sum for a node-local symmetric matrix (6 values a point: xx yy zz xy xz yz).
template <class Real>
SSC_HD inline void gather_point_sym3(const Real* point_values, const Real* point_t, const int* offset, const int* entry,
                                     int node, Real* s) {
  for (int j = 0; j < 6; ++j) s[j] = Real(0);
  for (int k = offset[node]; k < offset[node + 1]; ++k) {
    const int p = entry[k] >> 1;
    const Real w = (entry[k] & 1) ? point_t[p] : Real(1) - point_t[p];
    for (int j = 0; j < 6; ++j) s[j] += w * point_values[6 * p + j];
  }
}

// The 8 corner vectors of one cell from a nodal field.
template <class Real>
SSC_HD inline void load_cell_corners(const Real* nodal, const int* cell_nodes, int cell, Vec3<Real>* out) {
  for (int c = 0; c < 8; ++c) out[c] = load3(nodal, cell_nodes[8 * cell + c]);
}

// ---- the engine's gather parts (graph/op_spec.h): node i adds what its corners or its
// contact points hold (the adjoint of an element-to-node or point-to-node transfer) ----

template <class Real>
SSC_HD inline void add_corner_sum(int i, const PartContext<Real>&, const Real* corner_values, const int* node_cell_offset,
                                  const int* node_cell_entry, Real* node_values) {
  add3(node_values, i, gather_corner_sum(corner_values, node_cell_offset, node_cell_entry, i));
}

template <class Real>
SSC_HD inline void add_point_sum(int i, const PartContext<Real>&, const Real* point_values, const Real* point_t,
                                 const int* node_point_offset, const int* node_point_entry, Real* node_values) {
  add3(node_values, i, gather_point_sum(point_values, point_t, node_point_offset, node_point_entry, i));
}

}  // namespace ops
}  // namespace ssc
