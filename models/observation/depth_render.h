// Synthetic depth images: ray casting a triangle mesh from a DepthCamera. In ssc the mesh
// is the deformed surface of the simulated body (the marching-tetrahedra surface of the
// rest-pose SDF moved with the simulated node displacements), so the render is exact for
// the simulated surface and needs no advected SDF. A bounding volume hierarchy keeps it
// fast (a 640x480 image of a 100k-triangle mesh in well under a second).
//
// Noise follows decision 7 (docs/decisions.md): a Gaussian with standard deviation noise_std_m metres is added
// to the distance along the viewing ray, then converted to the z depth the camera stores.
// The noise of pixel (u, v) depends only on (seed, v, u): every image row has its own
// std::mt19937_64 seeded from a hash of (seed, row), so images are bitwise reproducible
// with any number of OpenMP threads.
#pragma once
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "models/observation/camera.h"
#include "models/observation/depth_png.h"

namespace ssc {

// Bounding volume hierarchy over a triangle mesh (median split on the longest centroid
// axis, up to 4 triangles per leaf). Nearest-hit queries, both triangle sides count.
class TriangleBvh {
 public:
  // Throws InputError for a triangle index outside the vertex list or a non-finite vertex.
  TriangleBvh(const std::vector<Eigen::Vector3d>& vertices, const std::vector<std::array<int, 3>>& triangles);

  // Nearest intersection with t > 0 of the ray origin + t * direction (direction need not be
  // unit; t is in its units). Returns false if the ray hits nothing.
  bool intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double* t) const;

 private:
  struct Node {
    Eigen::Vector3d lo, hi;
    int first = 0, count = 0;  // leaf: triangles order_[first, first + count)
    int left = -1, right = -1; // inner node: children
  };
  int build(int begin, int end, const std::vector<Eigen::Vector3d>& centroids);

  std::vector<std::array<Eigen::Vector3d, 3>> tris_;
  std::vector<int> order_;
  std::vector<Node> nodes_;
};

// Depth image of the mesh seen by `cam`: every pixel centre is ray cast, the nearest hit's
// ray distance gets Gaussian noise (std noise_std_m metres, none if 0) and is converted to
// z depth; pixels without hit or whose noisy depth lies outside [min_depth, max_depth] are
// 0. The same (camera, mesh, noise, seed) gives a bitwise identical image.
DepthImage render_depth(const DepthCamera& cam, const std::vector<Eigen::Vector3d>& vertices,
                        const std::vector<std::array<int, 3>>& triangles, double noise_std_m,
                        std::uint64_t seed);

// Same with a prebuilt BVH (for several cameras of one mesh).
DepthImage render_depth(const DepthCamera& cam, const TriangleBvh& bvh, double noise_std_m, std::uint64_t seed);

// A well-mixed seed for image (a, b) of a run with seed `seed`, e.g. mix_seed(seed, frame,
// camera), so that different images get independent noise.
std::uint64_t mix_seed(std::uint64_t seed, std::uint64_t a, std::uint64_t b = 0);

}  // namespace ssc
