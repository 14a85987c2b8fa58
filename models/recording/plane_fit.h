// The large planes of a static scene (table, floor, walls, a ramp) in a point cloud: sequential
// RANSAC (the largest plane first, its inliers removed, then the next), each plane refined by
// least squares over its inliers. Every point carries its own inlier band (the sensor noise
// grows with depth), so a far wall and a near table are judged alike. Seeded: the same points
// give the same planes.
#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace ssc {

struct Plane {
  Eigen::Vector3d normal{0, 0, 1};  // unit
  double offset = 0;                // the plane is normal . p = offset
  double distance(const Eigen::Vector3d& p) const { return normal.dot(p) - offset; }
};

struct DetectedPlane {
  Plane plane;
  std::vector<int> inliers;  // indices into the points
  double rms = 0;            // m, of the inliers' distances
};

struct PlaneSearch {
  int max_planes = 6;
  double min_fraction = 0.04;  // of all points: smaller planes are not looked for
  int min_points = 150;
  int iterations = 400;        // RANSAC samples per plane
  std::uint64_t seed = 1;
};

// The least-squares plane through the points `indices` (the normal is the direction of least
// variance); `orient_towards` picks the normal's sign (the side it lies on, e.g. the camera).
Plane fit_plane(const std::vector<Eigen::Vector3d>& points, const std::vector<int>& indices,
                const Eigen::Vector3d& orient_towards);

// Planes in decreasing order of inliers; `band[i]` is point i's inlier distance. Normals point
// towards `orient_towards`.
std::vector<DetectedPlane> find_planes(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& band,
                                       const Eigen::Vector3d& orient_towards, const PlaneSearch& search = {});

}  // namespace ssc
