// Triangle meshes read from .obj, .ply (ascii and binary) and .stl (ascii and binary).
// Polygons are fan-triangulated; everything but positions and faces (normals, texture
// coordinates, colours, extra PLY properties) is skipped. Defects (unreadable or empty
// file, bad numbers, indices out of range, no faces) are InputErrors naming the file and,
// where it has lines, the line.
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

namespace ssc {

struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> faces;  // 0-based vertex indices
};

// Dispatches on the extension (.obj, .ply, .stl; case-insensitive).
TriangleMesh load_mesh(const std::string& path);

}  // namespace ssc
