// Static scenery for synthetic recordings, as triangles the depth renderer (depth_render.h)
// casts rays against together with the simulated body: rectangles (a floor, a wall, a table
// top) and boxes (a table, clutter). A scene is one triangle list; append() adds a mesh (the
// body's deformed surface) to it for a frame.
#pragma once
#include <Eigen/Core>
#include <array>
#include <vector>

namespace ssc {

struct TriangleSoup {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<int, 3>> triangles;

  // The rectangle corner, corner + edge_a, corner + edge_a + edge_b, corner + edge_b.
  void add_rectangle(const Eigen::Vector3d& corner, const Eigen::Vector3d& edge_a, const Eigen::Vector3d& edge_b);
  // A box centred at `centre` with half extents along the columns of `rotation`.
  void add_box(const Eigen::Vector3d& centre, const Eigen::Vector3d& half_extents,
               const Eigen::Matrix3d& rotation = Eigen::Matrix3d::Identity());
  void append(const std::vector<Eigen::Vector3d>& vertices, const std::vector<std::array<int, 3>>& triangles);
};

}  // namespace ssc
