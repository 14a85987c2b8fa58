// A signed distance field sampled on the nodes of a regular grid, in world units
// (metres), negative inside. Node (i,j,k) sits at origin + h*(i,j,k); the flat index is
// i + nx*(j + ny*k), x fastest (the reference code's order). This is the rest shape
// that every simulation grid is built from.
#pragma once
#include <Eigen/Core>
#include <vector>

namespace ssc {

struct SdfGrid {
  double cell_size = 0;                               // h, metres
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();   // world position of node (0,0,0)
  Eigen::Vector3i size = Eigen::Vector3i::Zero();     // nodes per axis
  std::vector<double> phi;                            // metres, negative inside

  long node_count() const { return long(size.x()) * size.y() * size.z(); }
  long index(int i, int j, int k) const { return i + long(size.x()) * (j + long(size.y()) * k); }
  Eigen::Vector3d node_position(int i, int j, int k) const {
    return origin + cell_size * Eigen::Vector3d(i, j, k);
  }
  Eigen::Vector3d node_position(long flat) const {  // of index(i, j, k)
    const long nx = size.x(), ny = size.y();
    return node_position(int(flat % nx), int((flat / nx) % ny), int(flat / (nx * ny)));
  }
  double at(int i, int j, int k) const { return phi[index(i, j, k)]; }
};

}  // namespace ssc
