// The body's surface and its deformed positions for a displacement field of the active
// nodes. Used for the PLY frames and for rendering synthetic depth images.
//
// The surface is the zero level set of the trilinear rest SDF inside the active cells,
// extracted by marching tetrahedra on a grid refined `refinement` times per cell (the
// refined values are the trilinear interpolation of the cell's corners), so it follows
// the same trilinear field the sparse surface constraint measures. Each refined node
// moves with the trilinear deformation of its cell, so the deformed surface is the
// trilinear deformation of the rest surface, as the cost assumes.
#pragma once
#include <Eigen/Core>
#include <array>
#include <vector>

#include "models/grid/marching_tets.h"
#include "models/grid/sim_grid.h"

namespace ssc {

class DeformedSurface {
 public:
  explicit DeformedSurface(const SimGrid& grid, int refinement = 4);
  std::vector<Eigen::Vector3d> positions(const double* node_displacement) const;  // 3 per active node
  const std::vector<std::array<int, 3>>& triangles() const { return mesh_.triangles; }

 private:
  struct RefinedNode {
    int cell = -1;
    double a = 0, b = 0, c = 0;  // local coordinates in the cell
  };
  const SimGrid& grid_;
  SurfaceMesh mesh_;                       // on the refined grid
  std::vector<long> used_nodes_;           // refined nodes the mesh's vertices use
  std::vector<RefinedNode> used_location_; // their cells and local coordinates
  std::vector<std::array<int, 2>> vertex_nodes_;  // per vertex: indices into used_nodes_
};

}  // namespace ssc
