// Registering the scan to a frame's object points. A global start needs no initial guess:
// the scan's principal axes are put onto the observed points' principal axes in each of the
// 24 proper ways (every signed permutation with determinant +1: partial views shorten the
// axes, so their order is not trusted), and each start is refined by ICP; the start that ends
// best wins. Best means the smallest truncated residual plus a penalty for scan surface
// that faces the camera in front of what the camera measured (it would have been seen). ICP
// is point-to-plane (observed point to the scan's surface through its nearest sample and
// normal), with Huber weights, on the scan's frame kd-tree.
#pragma once
#include <Eigen/Core>
#include <vector>

#include "models/observation/depth_png.h"
#include "models/recording/depth_recording.h"
#include "models/recording/scan_model.h"

namespace ssc {

struct RigidPose {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // world = rotation * scan + translation
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Vector3d apply(const Eigen::Vector3d& p) const { return rotation * p + translation; }
};

struct IcpResult {
  RigidPose pose;
  double rms = 0;      // m, point-to-plane, over the matched points
  int matched = 0;     // observed points within the match distance
  int iterations = 0;
};

// ICP from `start`; observed points in the frame where `start` places the scan. Pairs farther
// apart than max_distance are not used; huber (m) bounds each residual's weight.
IcpResult icp_point_to_plane(const ScanModel& scan, const std::vector<Eigen::Vector3d>& observed, RigidPose start,
                             double max_distance, double huber, int iterations);

// What the camera saw, for judging a pose: the frame's depth, the camera, and the world-to-camera map.
struct CameraView {
  const DepthImage* depth = nullptr;
  DepthIntrinsics intrinsics;
  Eigen::Matrix4d world_to_camera = Eigen::Matrix4d::Identity();
  double tolerance = 0.02;  // m: scan surface this far in front of the measured depth counts as seen through
};

struct RegistrationResult {
  IcpResult icp;
  double score = 0;            // lower is better
  double seen_through = 0;     // fraction of camera-facing scan samples in front of the measured depth
  int hypotheses = 0;
};

// The global registration above. huber: the depth noise's scale (m).
RegistrationResult register_scan(const ScanModel& scan, const std::vector<Eigen::Vector3d>& observed,
                                 const CameraView& view, double huber);

// Fraction of the scan's camera-facing samples, posed, that lie in front of the measured depth.
double seen_through_fraction(const ScanModel& scan, const RigidPose& pose, const CameraView& view);

// Rotation angle (radians) between two rotations.
double rotation_angle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);

}  // namespace ssc
