// Surface extraction from an SDF grid by marching tetrahedra.
//
// Every listed cell is split into the 6 tetrahedra of kCellTetrahedra (shared diagonal from
// corner 0 to corner 7), the same split that integrate_cut_cell uses with subdivisions = 1,
// so the extracted area equals the sum of its surface integrals. The split is conforming
// across neighbouring cells, hence the mesh is closed wherever all cut cells are listed.
// Nodes are classified inside by phi <= 0 (as in cut_cell.h); a vertex sits where the linear
// interpolation of phi along a tetrahedron edge (a grid edge, a face diagonal or the cell
// diagonal) crosses zero, and is stored as (node_a, node_b, t), so that a deformed surface
// is obtained by lerping displaced node positions. Vertices are shared per grid edge.
//
// Triangles are oriented with their normal towards increasing phi (outward). Orientation is
// derived combinatorially from the positively oriented tetrahedra, not from the geometry, so
// it stays consistent for zero-area triangles. Such triangles (a vertex exactly on a node,
// phi == 0 there) are kept: they keep the mesh combinatorially closed (every edge shared by
// exactly two triangles); consumers that normalise normals must guard against zero area.
#pragma once
#include "models/geometry/sdf_grid.h"

#include <Eigen/Core>
#include <array>
#include <vector>

namespace ssc {

struct SurfaceVertex {
  long node_a = 0, node_b = 0;  // flat SdfGrid node indices, node_a < node_b
  double t = 0;                 // position (1 - t) * x_a + t * x_b, t in [0, 1]
};

struct SurfaceMesh {
  std::vector<SurfaceVertex> vertices;
  std::vector<std::array<int, 3>> triangles;  // indices into vertices, outward normals
};

// cells: flat index of each cell's lower corner node (i,j,k); the cell spans i..i+1 etc.
// Cells without a sign change produce nothing. Throws InputError for a cell outside the
// grid (i, j or k at the last node layer or beyond) or a non-finite phi at a used node.
SurfaceMesh extract_surface(const SdfGrid& sdf, const std::vector<long>& cells);

// Vertex positions: lerp of the rest node positions plus the node displacement
// (3 doubles per grid node in flat node order, nullptr for the rest shape).
std::vector<Eigen::Vector3d> surface_positions(const SurfaceMesh& mesh, const SdfGrid& rest,
                                               const double* node_displacement);

}  // namespace ssc
