// Pinhole depth camera maths (see camera.h for the convention). Everything here is a
// few lines of linear algebra on the 4x4 camera_to_world pose; validation is strict
// because a wrong pose silently puts every observed point in the wrong place.
#include "models/observation/camera.h"

#include <Eigen/Dense>
#include <cmath>
#include <fmt/format.h>

#include "runtime/errors.h"

namespace ssc {

namespace {

constexpr double kPi = 3.14159265358979323846;
// Orthonormality tolerance of the pose rotation: loose enough for calibration files that
// store a handful of digits, tight enough to catch a scaled or sheared matrix.
constexpr double kRigidTolerance = 1e-4;

Eigen::Matrix3d rotation(const DepthCamera& cam) { return cam.camera_to_world.topLeftCorner<3, 3>(); }

bool finite(double x) { return std::isfinite(x); }

void require(bool ok, const std::string& where, const std::string& what) {
  if (!ok) throw InputError(fmt::format("{}: {}", where, what));
}

void validate_intrinsics(const DepthCamera& c, const std::string& where) {
  require(c.width > 0 && c.height > 0, where,
          fmt::format("image size {}x{} must be positive; set width and height to the depth "
                      "image size in pixels", c.width, c.height));
  require(finite(c.fx) && finite(c.fy) && c.fx > 0 && c.fy > 0, where,
          fmt::format("focal lengths fx={} fy={} must be positive and finite (pixels)", c.fx, c.fy));
  require(finite(c.cx) && finite(c.cy), where,
          fmt::format("principal point cx={} cy={} must be finite (pixels)", c.cx, c.cy));
}

void validate_pose(const DepthCamera& c, const std::string& where) {
  require(c.camera_to_world.allFinite(), where, "camera_to_world contains a non-finite number");
  const Eigen::RowVector4d last = c.camera_to_world.row(3);
  require((last - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() <= 1e-12, where, "camera_to_world must have the last row 0 0 0 1 (a rigid 4x4 pose, row-major)");
  const Eigen::Matrix3d r = rotation(c);
  const double err = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  require(err <= kRigidTolerance, where,
          fmt::format("the rotation part of camera_to_world is not orthonormal (|R^T R - I| = {:.3g}); "
                      "give a rigid pose without scale or shear (row-major, camera to world)", err));
  require(r.determinant() > 0, where,
          "the rotation part of camera_to_world is a reflection (determinant < 0); the camera "
          "frame must be right-handed: x right, y down, z forward");
}

void validate_depth_range(const DepthCamera& c, const std::string& where) {
  require(finite(c.min_depth) && finite(c.max_depth) && c.min_depth > 0 && c.min_depth < c.max_depth,
          where,
          fmt::format("depth range min_depth={} max_depth={} is invalid; need 0 < min_depth < "
                      "max_depth (metres)", c.min_depth, c.max_depth));
}

}  // namespace

DepthCamera make_look_at_camera(const std::string& name, int width, int height, double fov_y_deg,
                                const Eigen::Vector3d& eye_world, const Eigen::Vector3d& target,
                                const Eigen::Vector3d& up) {
  const std::string where = fmt::format("camera '{}'", name);
  require(fov_y_deg > 0 && fov_y_deg < 180, where,
          fmt::format("vertical field of view {} degrees must lie in (0, 180)", fov_y_deg));
  const Eigen::Vector3d forward = target - eye_world;
  require(forward.norm() > 0, where, "eye and target coincide; place the camera away from its target");
  const Eigen::Vector3d z = forward.normalized();
  const Eigen::Vector3d right = z.cross(up);
  require(right.norm() > 1e-9 * up.norm() && up.norm() > 0, where,
          "the up vector is zero or parallel to the viewing direction; choose another up vector");
  const Eigen::Vector3d x = right.normalized();
  const Eigen::Vector3d y = z.cross(x);  // image down

  DepthCamera cam;
  cam.name = name;
  cam.width = width;
  cam.height = height;
  cam.fy = 0.5 * height / std::tan(0.5 * fov_y_deg * kPi / 180.0);
  cam.fx = cam.fy;
  cam.cx = 0.5 * (width - 1);
  cam.cy = 0.5 * (height - 1);
  cam.camera_to_world.setIdentity();
  cam.camera_to_world.block<3, 1>(0, 0) = x;
  cam.camera_to_world.block<3, 1>(0, 1) = y;
  cam.camera_to_world.block<3, 1>(0, 2) = z;
  cam.camera_to_world.block<3, 1>(0, 3) = eye_world;
  validate_camera(cam, where);
  return cam;
}

Eigen::Vector3d unproject(const DepthCamera& cam, double u, double v, double depth) {
  const Eigen::Vector3d p_cam((u - cam.cx) / cam.fx * depth, (v - cam.cy) / cam.fy * depth, depth);
  return rotation(cam) * p_cam + eye(cam);
}

bool project(const DepthCamera& cam, const Eigen::Vector3d& world, double* u, double* v,
             double* depth) {
  const Eigen::Vector3d p = rotation(cam).transpose() * (world - eye(cam));
  if (!(p.z() > 0)) return false;
  if (u) *u = cam.fx * p.x() / p.z() + cam.cx;
  if (v) *v = cam.fy * p.y() / p.z() + cam.cy;
  if (depth) *depth = p.z();
  return true;
}

bool in_image(const DepthCamera& cam, double u, double v) {
  return u >= -0.5 && u < cam.width - 0.5 && v >= -0.5 && v < cam.height - 0.5;
}

Eigen::Vector3d ray_direction_world(const DepthCamera& cam, double u, double v) {
  const Eigen::Vector3d d_cam((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
  return (rotation(cam) * d_cam).normalized();
}

Eigen::Vector3d eye(const DepthCamera& cam) { return cam.camera_to_world.block<3, 1>(0, 3); }

void validate_camera(const DepthCamera& cam, const std::string& where) {
  validate_intrinsics(cam, where);
  validate_pose(cam, where);
  validate_depth_range(cam, where);
}

}  // namespace ssc
