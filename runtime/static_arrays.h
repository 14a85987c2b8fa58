// The body's fixed arrays that the engine's ops read: sizes of the iteration domains, the
// cell and node geometry, the incidence lists that make every element-to-node sum a
// deterministic gather, the contact points and the band's neighbour lists. The model's grid
// (models/grid/sim_grid.h) builds them; the engine (runtime/, codegen/) sees only this.
#pragma once
#include <string>
#include <vector>

namespace ssc {

// A point of the rest surface where ground contact is tested, anywhere in an active cell: it
// moves with the cell's trilinear interpolation of its 8 corners (ops/contact.h).
constexpr int kPointNodes = 8;
struct ContactPoint {
  int nodes[kPointNodes] = {};       // active node ids, the corners of its cell
  double weights[kPointNodes] = {};  // trilinear weights, summing to 1 (0 for a corner it does not touch)
  double area = 0;                   // surface area carried, m^2

  // Component k of the point's position from a nodal field (3 per node; rest positions, or
  // rest positions plus a displacement when `u` is given).
  double at(const std::vector<double>& node_rest, int k, const double* u = nullptr) const {
    double x = 0;
    for (int c = 0; c < kPointNodes; ++c)
      if (weights[c] != 0) x += weights[c] * (node_rest[3 * size_t(nodes[c]) + k] + (u ? u[3 * size_t(nodes[c]) + k] : 0));
    return x;
  }
};

struct StaticArrays {
  double h = 0;  // cell size, m
  int cell_count = 0, node_count = 0, band_count = 0;

  std::vector<int> cell_nodes;              // 8 per cell: active node id of each corner
  std::vector<double> cell_volume_weights;  // 8 per cell, m^3 (at least the floor)
  // The surface in each cell (ops/air_drag.h): per corner the integral of N_c over the rest
  // surface (8 per cell, m^2), and the outward unit normal (3 per cell, rest; 0 without surface).
  std::vector<double> cell_surface_weights;
  std::vector<double> cell_rest_normal;
  // The heterogeneous body (ops/stiffness_field.h): each cell's rest centroid minus the body's
  // rest centre of mass (3 per cell, m), the fraction of its inside part in each material region
  // (region_count per cell; the rest takes the body's modulus) and the region count (one entry).
  std::vector<double> cell_offset;
  std::vector<double> cell_region_share;
  std::vector<int> region_count{0};

  std::vector<double> node_rest;            // 3 per active node, world position
  std::vector<double> node_volume;          // per active node: sum of its corner weights, m^3
  std::vector<int> node_cell_offset;        // CSR over active nodes ...
  std::vector<int> node_cell_entry;         // ... entries cell * 8 + corner, ascending

  std::vector<ContactPoint> contact_points;
  std::vector<int> node_point_offset;       // CSR over active nodes ...
  std::vector<int> node_point_entry;        // ... entries point * kPointNodes + corner (nonzero weights only)

  std::vector<int> band_neighbors;          // 6 per band node: band id >= 0, -(active id) - 2, or -1
  std::vector<int> band_degree;             // active + band neighbours
};

// The arrays as the ops' parts name them ("#cell_nodes" in a spec reads cell_nodes), each
// either int or real; the contact points' fields as arrays of their own, and the node <-
// band incidence (in band, direction order) that the adjoint extension gathers.
struct NamedStaticArray {
  std::string name;
  bool is_int = false;
  std::vector<int> ints;
  std::vector<double> reals;
};
std::vector<NamedStaticArray> named_static_arrays(const StaticArrays& g);

}  // namespace ssc
