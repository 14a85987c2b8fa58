// A rigid placement with uniform scale, as scenes write it: a position, Euler angles in
// degrees and a scale factor. The rotation is R = Rz * Ry * Rx, so a local vector is
// rotated about x first, then y, then z; a local point p lands at position + scale*R*p.
#pragma once
#include <Eigen/Core>

namespace ssc {

struct Transform {
  Eigen::Vector3d position{0, 0, 0};
  Eigen::Vector3d rotation_deg{0, 0, 0};
  double scale = 1.0;

  Eigen::Matrix3d rotation() const;
  Eigen::Vector3d apply(const Eigen::Vector3d& local) const;
  Eigen::Vector3d to_local(const Eigen::Vector3d& world) const;
};

}  // namespace ssc
