// Triangle meshes to binary little-endian PLY (float x,y,z per vertex; per face a uchar count
// of 3 and int indices), readable by MeshLab, Blender and Open3D. The file is written
// atomically: to "<path>.tmp-<pid>" first, then renamed over path, so a reader never sees a
// half-written mesh. The byte order is fixed (little endian) whatever the host's.
#pragma once
#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

namespace ssc {

// Throws std::invalid_argument for a triangle index outside [0, vertices.size()) (nothing is
// written) and std::runtime_error naming the path and the errno text when writing or renaming
// fails (the temporary file is removed).
void write_ply(const std::string& path, const std::vector<Eigen::Vector3d>& vertices,
               const std::vector<std::array<int, 3>>& triangles);

}  // namespace ssc
