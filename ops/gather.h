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

// A contact point moves with the trilinear interpolation of its cell's 8 corners: point p's
// corner nodes and weights are point_nodes / point_weights[kPointNodes * p + c].
constexpr int kPointNodes = 8;

// Sum of per-point vectors spread to their corner nodes: entry = point * kPointNodes + corner,
// taking that corner's weight.
template <class Real>
SSC_HD inline Vec3<Real> gather_point_sum(const Real* point_values, const Real* point_weights, const int* offset,
                                          const int* entry, int node) {
  Vec3<Real> s = zero3<Real>();
  for (int k = offset[node]; k < offset[node + 1]; ++k)
    s += point_weights[entry[k]] * load3(point_values, entry[k] / kPointNodes);
  return s;
}

// The same sum for a node-local symmetric matrix (6 values a point: xx yy zz xy xz yz).
template <class Real>
SSC_HD inline void gather_point_sym3(const Real* point_values, const Real* point_weights, const int* offset,
                                     const int* entry, int node, Real* s) {
  for (int j = 0; j < 6; ++j) s[j] = Real(0);
  for (int k = offset[node]; k < offset[node + 1]; ++k) {
    const int p = entry[k] / kPointNodes;
    const Real w = point_weights[entry[k]];
    for (int j = 0; j < 6; ++j) s[j] += w * point_values[6 * p + j];
  }
}

// A nodal vector at contact point i: the weighted sum over its corners (the adjoint of
// gather_point_sum).
template <class Real>
SSC_HD inline Vec3<Real> point_vec3(int i, const int* point_nodes, const Real* point_weights, const Real* nodal) {
  Vec3<Real> s = zero3<Real>();
  for (int c = kPointNodes * i; c < kPointNodes * (i + 1); ++c)
    if (point_weights[c] != Real(0)) s += point_weights[c] * load3(nodal, point_nodes[c]);
  return s;
}

// The same for a node-local symmetric matrix (the adjoint of gather_point_sym3).
template <class Real>
SSC_HD inline void point_sym3(int i, const int* point_nodes, const Real* point_weights, const Real* nodal, Real* s) {
  for (int j = 0; j < 6; ++j) s[j] = Real(0);
  for (int c = kPointNodes * i; c < kPointNodes * (i + 1); ++c) {
    const Real w = point_weights[c];
    if (w == Real(0)) continue;
    for (int j = 0; j < 6; ++j) s[j] += w * nodal[6 * point_nodes[c] + j];
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
SSC_HD inline void add_point_sum(int i, const PartContext<Real>&, const Real* point_values, const Real* point_weights,
                                 const int* node_point_offset, const int* node_point_entry, Real* node_values) {
  add3(node_values, i, gather_point_sum(point_values, point_weights, node_point_offset, node_point_entry, i));
}

}  // namespace ops
}  // namespace ssc
