// The body's surface (marching tetrahedra of the rest SDF over the active cells) and its
// deformed positions for a displacement field of the active nodes. Used for the PLY
// frames and for rendering synthetic depth images.
#pragma once
#include <Eigen/Core>
#include <array>
#include <vector>

#include "models/grid/marching_tets.h"
#include "models/grid/sim_grid.h"

namespace ssc {

class DeformedSurface {
 public:
  explicit DeformedSurface(const SimGrid& grid);
  std::vector<Eigen::Vector3d> positions(const double* node_displacement) const;  // 3 per active node
  const std::vector<std::array<int, 3>>& triangles() const { return mesh_.triangles; }

 private:
  const SimGrid& grid_;
  SurfaceMesh mesh_;
};

}  // namespace ssc
