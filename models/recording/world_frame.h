// The world frame ssc's scenes use, from a camera's view of the room: world y points up
// (against gravity), x follows the camera's x axis as far as it is horizontal, and the origin
// is a point of the plane the object rests on or falls onto. camera_to_world follows.
#pragma once
#include <Eigen/Core>

namespace ssc {

// up_camera: the up direction in the camera's frame (unit); origin_camera: the world origin
// in the camera's frame. A rigid, right-handed pose (observation format convention).
Eigen::Matrix4d camera_to_world_from_up(const Eigen::Vector3d& up_camera, const Eigen::Vector3d& origin_camera);

// The rotation part as Euler angles in degrees with R = Rz Ry Rx (the scenes' rotation_deg).
Eigen::Vector3d euler_xyz_degrees(const Eigen::Matrix3d& rotation);

}  // namespace ssc
