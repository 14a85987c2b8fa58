#include "models/geometry/transform.h"

#include <Eigen/Geometry>
#include <cmath>

namespace ssc {

namespace {
double radians(double degrees) { return degrees * M_PI / 180.0; }
}  // namespace

Eigen::Matrix3d Transform::rotation() const {
  using Eigen::AngleAxisd;
  using Eigen::Vector3d;
  const AngleAxisd rx(radians(rotation_deg.x()), Vector3d::UnitX());
  const AngleAxisd ry(radians(rotation_deg.y()), Vector3d::UnitY());
  const AngleAxisd rz(radians(rotation_deg.z()), Vector3d::UnitZ());
  return (rz * ry * rx).toRotationMatrix();
}

Eigen::Vector3d Transform::apply(const Eigen::Vector3d& local) const {
  return position + scale * (rotation() * local);
}

Eigen::Vector3d Transform::to_local(const Eigen::Vector3d& world) const {
  return rotation().transpose() * (world - position) / scale;
}

}  // namespace ssc
