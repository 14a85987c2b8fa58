// The object's scan as registration uses it: points sampled evenly over its surface (area
// weighted, seeded) with their normals, in the scan's own frame times the scan scale, its
// volume centroid (the centre of mass of a uniform body) and extents, and whether it is closed.
#pragma once
#include <Eigen/Core>
#include <memory>
#include <vector>

#include "models/geometry/mesh.h"
#include "models/recording/nearest_points.h"

namespace ssc {

struct ScanModel {
  std::vector<Eigen::Vector3d> points, normals;  // scan frame, scaled
  Eigen::Vector3d centroid{0, 0, 0};             // of the enclosed volume (of the surface if it encloses none)
  double volume = 0;                             // m^3 (approximate for a scan with holes)
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();  // per unit density, about the centroid, scan frame (m^5)
  Eigen::Vector3d extents{0, 0, 0};              // along its principal axes, largest first
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  // principal axes (columns), largest spread first
  int open_edges = 0;                            // edges with other than two faces
  std::shared_ptr<NearestPoints> index;          // over points
};

ScanModel make_scan_model(const TriangleMesh& mesh, double scale, int samples = 4000, std::uint64_t seed = 7);

}  // namespace ssc
