// Deformed surface meshes of a simulated body (see deformed_surface.h).
#include "models/sim/deformed_surface.h"

namespace ssc {

DeformedSurface::DeformedSurface(const SimGrid& grid) : grid_(grid), mesh_(extract_surface(grid.sdf, grid.cell_origin)) {}

std::vector<Eigen::Vector3d> DeformedSurface::positions(const double* u) const {
  std::vector<Eigen::Vector3d> out(mesh_.vertices.size());
  auto node_position = [&](long grid_index) {
    const int a = grid_.grid_kind[grid_index];  // surface vertices lie on edges of active cells
    return Eigen::Vector3d(grid_.node_rest[3 * a] + u[3 * a], grid_.node_rest[3 * a + 1] + u[3 * a + 1],
                           grid_.node_rest[3 * a + 2] + u[3 * a + 2]);
  };
  for (size_t i = 0; i < mesh_.vertices.size(); ++i) {
    const SurfaceVertex& v = mesh_.vertices[i];
    out[i] = (1 - v.t) * node_position(v.node_a) + v.t * node_position(v.node_b);
  }
  return out;
}

}  // namespace ssc
