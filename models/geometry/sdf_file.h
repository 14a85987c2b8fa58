// The reference code's binary .sdf format: little endian, no magic number,
//   int32 r (voxels per world unit), int32 offset[3], int32 size[3],
//   float32 phi[size.x*size.y*size.z] (x fastest), in voxel units (distance * r),
// node (i,j,k) at world position (offset + (i,j,k)) / r. Loading converts to metres;
// every defect of the file is reported as an InputError that names it.
#pragma once
#include <Eigen/Core>
#include <string>

#include "models/geometry/sdf_grid.h"

namespace ssc {

constexpr int kMaxSdfFileNodesPerAxis = 1024;

// h = scale/r, origin = scale*offset/r + translation, phi = scale*phi_file/r.
SdfGrid load_sdf_file(const std::string& path, double scale = 1.0,
                      const Eigen::Vector3d& translation = Eigen::Vector3d::Zero());

// Needs 1/h and origin/h to be integers (up to rounding); writes path + ".tmp-<pid>" and
// renames it onto path, so readers never see a half-written file.
void save_sdf_file(const std::string& path, const SdfGrid& grid);

}  // namespace ssc
