// Which way is up, which plane holds the object, which it can reach (scene_planes.h).
#include "models/recording/scene_planes.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "models/io/run_record.h"
#include "models/recording/depth_points.h"
#include "models/recording/world_frame.h"
#include "runtime/errors.h"

namespace ssc {

namespace {

constexpr double kFloorLikeCos = 0.866;  // a plane within 30 degrees of level can hold the object
// Without --gravity, up is the largest plane within 60 degrees of the image's up with the object
// above it: cameras look down at tables and floors by up to about 60 degrees (the real floor
// frames of tests/data/pcl_floor_frames at 46).
constexpr double kImageUpCos = 0.5;

// Distance from a camera-frame point to the nearest inlier of a plane (its inliers are pixels of `img`).
double distance_to_inliers(const Eigen::Vector3d& x, const std::vector<int>& pixels, const DepthImage& img,
                           const DepthIntrinsics& k) {
  double best = 1e300;
  for (size_t n = 0; n < pixels.size(); n += 3) {
    const int i = pixels[n];
    best = std::min(best, (back_project(k, i % img.width, i / img.width, img.depth[std::size_t(i)]) - x).squaredNorm());
  }
  return std::sqrt(best);
}

}  // namespace

int set_world_frame(PreparedRecording& p, const DepthComponent& object, const DepthImage& search_image,
                    const std::optional<Eigen::Vector3d>& gravity, const std::string& where) {
  const DepthIntrinsics& k = p.recording.intrinsics;
  const double scan_extent = p.scan.extents[0];
  // Up: the accelerometer's reading at rest points away from the ground (it measures the
  // support's push, not gravity); without it the largest plane under the object within
  // kImageUpCos of the image's up.
  if (gravity) {
    if (!(gravity->norm() > 0) || !gravity->allFinite())
      throw InputError("--gravity: give the accelerometer's reading at rest in the depth camera's frame, e.g. 0,-9.81,0");
    p.up_camera = gravity->normalized();
    p.gravity_magnitude = gravity->norm();
    if (std::abs(p.gravity_magnitude - 9.81) > 1.5)
      warn("gravity_magnitude", fmt::format("--gravity has magnitude {:.3g} m/s^2, not about 9.81: check its unit; the "
                                            "scene uses {:.3g}", p.gravity_magnitude, p.gravity_magnitude));
  } else {
    int best = -1;
    for (size_t i = 0; i < p.planes.size(); ++i) {
      const Plane& pl = p.planes[i].camera;
      if (pl.normal.dot(Eigen::Vector3d(0, -1, 0)) > kImageUpCos && pl.distance(object.centroid) > 0) {
        best = int(i);
        break;  // planes come largest first
      }
    }
    if (best < 0)
      throw InputError(fmt::format("{}: no plane under the object: none of the {} planes found is level enough (within "
                                   "{:.0f} degrees of the image's up) with the object above it; give the accelerometer's "
                                   "reading with --gravity gx,gy,gz, and make sure the table or floor the object "
                                   "falls onto is in view", where, p.planes.size(), std::acos(kImageUpCos) * 180 / M_PI));
    p.up_camera = p.planes[std::size_t(best)].camera.normal;
    p.gravity_from_plane = true;
    warn("gravity_from_plane", fmt::format("{}: no --gravity: up is taken as the normal of the largest level plane "
                                           "({:.0f} pixels); give the accelerometer's reading at rest "
                                           "(--gravity gx,gy,gz in the depth camera's frame) if the surface is not level",
                                           where, double(p.planes[std::size_t(best)].pixels.size()) * p.plane_stride * p.plane_stride));
  }

  // The support: the nearest level plane below the object whose inliers reach under it.
  int support = -1;
  double support_drop = 1e300;
  for (size_t i = 0; i < p.planes.size(); ++i) {
    const Plane& pl = p.planes[i].camera;
    const double cos_up = pl.normal.dot(p.up_camera);
    if (cos_up < kFloorLikeCos) continue;
    const double drop = pl.distance(object.centroid) / cos_up;  // along up, from the object down to the plane
    if (drop <= 0) continue;
    const Eigen::Vector3d foot = object.centroid - drop * p.up_camera;
    if (distance_to_inliers(foot, p.planes[i].pixels, search_image, k) > std::max(0.1, scan_extent)) continue;
    if (drop < support_drop) support_drop = drop, support = int(i);
  }
  if (support < 0)
    throw InputError(fmt::format("{}: no plane under the object: of the {} planes found, none is level (within 30 "
                                 "degrees of up) and reaches under the object at (u, v) = ({:.0f}, {:.0f}); the table "
                                 "or floor it falls onto must be in view{}", where, p.planes.size(),
                                 object.pixel_centroid.x(), object.pixel_centroid.y(),
                                 p.gravity_from_plane ? "" : ", and --gravity must be the accelerometer's reading at rest (pointing up)"));
  p.planes[std::size_t(support)].support = true;
  const Eigen::Vector3d origin = object.centroid - support_drop * p.up_camera;
  p.camera_to_world = camera_to_world_from_up(p.up_camera, origin);
  const Eigen::Matrix3d R = p.camera_to_world.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = p.camera_to_world.topRightCorner<3, 1>();
  for (PreparedPlane& plane : p.planes) {
    plane.normal = R * plane.camera.normal;
    plane.height = plane.camera.offset + plane.normal.dot(t);
  }

  return support;
}

void mark_contact_planes(PreparedRecording& p, const DepthImage& search_image) {
  const DepthIntrinsics& k = p.recording.intrinsics;
  const double scan_extent = p.scan.extents[0];
  const Eigen::Matrix3d R = p.camera_to_world.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = p.camera_to_world.topRightCorner<3, 1>();
  for (size_t i = 0; i < p.planes.size(); ++i) {
    PreparedPlane& plane = p.planes[i];
    if (plane.support) {
      plane.contact = true;
      continue;
    }
    for (size_t f = 0; f < p.poses.size() && !plane.contact; ++f) {
      if (!p.poses[f]) continue;
      const Eigen::Vector3d c = p.poses[f]->apply(p.scan.centroid);
      const Eigen::Vector3d c_cam = R.transpose() * (c - t);
      const double d = plane.camera.distance(c_cam);
      if (std::abs(d) > scan_extent) continue;
      if (distance_to_inliers(c_cam - d * plane.camera.normal, plane.pixels, search_image, k) < scan_extent)
        plane.contact = true;
    }
  }
  // World normals point to the side the object is on.
  for (PreparedPlane& plane : p.planes) {
    const Eigen::Vector3d c = p.poses[0]->apply(p.scan.centroid);
    if (plane.normal.dot(c) - plane.height < 0) {
      plane.normal = -plane.normal;
      plane.height = -plane.height;
    }
  }
  int contacts = 0;
  for (PreparedPlane& plane : p.planes)
    if (plane.contact && ++contacts > 8) plane.contact = false;  // the scene holds up to 8

}

}  // namespace ssc
