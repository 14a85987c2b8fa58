// Turns a triangle mesh into a signed distance field on a grid placed around it.
// Distance: exact unsigned distance to the closest triangle, found with a bounding volume
// hierarchy. Sign: the generalized winding number w (Jacobson et al. 2013), inside where
// w > 0.5, which stays correct for scans with holes; it is evaluated with the same tree
// and the far-field expansion of Barill et al. 2018 (clusters far from the query point
// are replaced by their dipole and second-order terms, near triangles use the exact solid
// angle of Van Oosterom and Strackee). A mesh too open to define an inside is refused.
#pragma once
#include <string>

#include "models/geometry/mesh.h"
#include "models/geometry/sdf_grid.h"
#include "models/geometry/transform.h"

namespace ssc {

// `source_name` (usually the mesh's file) is what error messages call the mesh.
SdfGrid mesh_to_sdf(const TriangleMesh& mesh, const Transform& transform, double cell_size,
                    int border_cells, const std::string& source_name);

// Generalized winding number of the (world-space) mesh at each query point, evaluated
// exactly (sum of all solid angles) or with the hierarchical approximation. Exposed for
// tests and diagnostics.
std::vector<double> winding_numbers(const TriangleMesh& mesh,
                                    const std::vector<Eigen::Vector3d>& points, bool exact);

}  // namespace ssc
