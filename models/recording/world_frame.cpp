#include "models/recording/world_frame.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace ssc {

Eigen::Matrix4d camera_to_world_from_up(const Eigen::Vector3d& up_camera, const Eigen::Vector3d& origin_camera) {
  const Eigen::Vector3d ey = up_camera.normalized();
  Eigen::Vector3d ex = Eigen::Vector3d::UnitX() - ey * ey.x();
  if (ex.norm() < 1e-6) ex = Eigen::Vector3d::UnitZ() - ey * ey.z();  // the camera looks straight down its x
  ex.normalize();
  const Eigen::Vector3d ez = ex.cross(ey);
  Eigen::Matrix3d r;  // rows: the world axes in camera coordinates
  r.row(0) = ex.transpose();
  r.row(1) = ey.transpose();
  r.row(2) = ez.transpose();
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = r;
  m.topRightCorner<3, 1>() = -r * origin_camera;
  return m;
}

Eigen::Vector3d euler_xyz_degrees(const Eigen::Matrix3d& r) {
  const double ry = std::asin(std::clamp(-r(2, 0), -1.0, 1.0));
  double rx, rz;
  if (std::abs(r(2, 0)) < 1 - 1e-9) {
    rx = std::atan2(r(2, 1), r(2, 2));
    rz = std::atan2(r(1, 0), r(0, 0));
  } else {  // gimbal lock: put the whole turn into x
    rz = 0;
    rx = std::atan2(-r(1, 2), r(1, 1));
  }
  return Eigen::Vector3d(rx, ry, rz) * 180 / M_PI;
}

}  // namespace ssc
