// Pinhole depth camera, OpenCV convention: the camera looks along its +z axis, x points
// right and y down in the image. Pixel (u, v) with integer u, v is the centre of the pixel
// in column u, row v, and a pixel with depth z (the camera-space z, not the ray length)
// is the camera-space point p_cam = ((u - cx) / fx * z, (v - cy) / fy * z, z). The pose
// camera_to_world maps camera-space points to world points (metres); its last column is
// the eye position. Depths outside [min_depth, max_depth] are not measured (stored as 0).
// This is the camera of the ssc depth format (docs/observation-format.md), used alike by
// synthetic renders and real RGB-D recordings.
#pragma once
#include <Eigen/Core>
#include <string>

namespace ssc {

struct DepthCamera {
  std::string name;
  int width = 0, height = 0;             // pixels
  double fx = 0, fy = 0, cx = 0, cy = 0; // focal lengths and principal point, pixels
  Eigen::Matrix4d camera_to_world = Eigen::Matrix4d::Identity();  // rigid, metres
  double min_depth = 0.1, max_depth = 6.0;                        // metres (z depth)
};

// A camera at `eye` looking at `target` with `up` pointing up in the image (so image y,
// which points down, is as close to -up as possible). Square pixels, fy from the vertical
// field of view over the full image height, principal point at the image centre
// ((width-1)/2, (height-1)/2). Throws InputError for degenerate inputs (eye == target,
// up parallel to the viewing direction, non-positive sizes, fov outside (0, 180)).
DepthCamera make_look_at_camera(const std::string& name, int width, int height, double fov_y_deg,
                                const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                                const Eigen::Vector3d& up);

// World point of pixel (u, v) with z depth `depth`.
Eigen::Vector3d unproject(const DepthCamera& cam, double u, double v, double depth);

// Pixel coordinates and z depth of a world point. Returns false (and leaves the outputs
// untouched) when the point is not strictly in front of the camera (z <= 0). The pixel may
// lie outside the image; use in_image() to check. Null output pointers are allowed.
bool project(const DepthCamera& cam, const Eigen::Vector3d& world, double* u, double* v,
             double* depth);

// True if (u, v) lies inside the pixel area [-0.5, width - 0.5) x [-0.5, height - 0.5).
bool in_image(const DepthCamera& cam, double u, double v);

// Unit viewing direction (world) of the ray through pixel (u, v).
Eigen::Vector3d ray_direction_world(const DepthCamera& cam, double u, double v);

// Camera centre in world coordinates.
Eigen::Vector3d eye(const DepthCamera& cam);

// Checks the camera: positive sizes and focal lengths, finite principal point, a rigid
// camera_to_world (orthonormal rotation with determinant +1, last row 0 0 0 1), and
// 0 < min_depth < max_depth, all finite. Throws InputError naming `where` (a file and key,
// e.g. "obs/cameras.json: cameras[1]") and the fix.
void validate_camera(const DepthCamera& cam, const std::string& where);

}  // namespace ssc
