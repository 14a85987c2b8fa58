// Following the object through the frames (object_tracking.h).
#include "models/recording/object_tracking.h"

#include <fmt/format.h>

#include <Eigen/LU>
#include <algorithm>

#include "models/io/run_record.h"
#include "models/recording/depth_points.h"
#include "models/recording/registration.h"

namespace ssc {

std::vector<Eigen::Vector3d> object_points_world(const DepthImage& img, const DepthIntrinsics& k,
                                                 const std::vector<char>& mask, const Eigen::Matrix4d& c2w) {
  std::vector<Eigen::Vector3d> pts;
  const PixelPoints pp = pixel_points(img, k, &mask);
  for (const Eigen::Vector3d& q : pp.points) pts.push_back(c2w.topLeftCorner<3, 3>() * q + c2w.topRightCorner<3, 1>());
  return pts;
}

void track_object(PreparedRecording& p, const SegmentationContext& context, int min_pixels, double huber,
                  const std::string& where) {
  const DepthRecording& rec = p.recording;
  const DepthIntrinsics& k = rec.intrinsics;
  const int frames = int(rec.frames.size());
  const size_t pixel_count = size_t(k.width) * k.height;
  const double scan_extent = p.scan.extents[0];
  const Eigen::Matrix3d R = p.camera_to_world.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = p.camera_to_world.topRightCorner<3, 1>();
  CameraView view;
  view.intrinsics = k;
  view.world_to_camera = p.camera_to_world.inverse();
  std::vector<int> lost;
  Eigen::Vector3d last_centre = p.poses[0]->apply(p.scan.centroid), velocity = Eigen::Vector3d::Zero();
  RigidPose last_pose = *p.poses[0];
  int last_frame = 0;
  const double frame_dt = p.timing.frame_dt;
  const Eigen::Vector3d g_world(0, -p.gravity_magnitude, 0);
  for (int f = 1; f < frames; ++f) {
    const double dt = (p.timing.frame_index[std::size_t(f)] - p.timing.frame_index[std::size_t(last_frame)]) * frame_dt;
    const Eigen::Vector3d predicted = last_centre + velocity * dt + 0.5 * g_world * dt * dt;
    const std::vector<PixelClass> classes = classify_pixels(rec.frames[std::size_t(f)], context);
    if (f == (frames - 1) / 2 || f == frames - 1) p.picture_classes.push_back(classes);
    const std::vector<DepthComponent> fparts = depth_components(rec.frames[std::size_t(f)], classes, context, min_pixels);
    // The part nearest to where the object should be, and every part close to it (ears, a
    // handle, a side seen past an edge are parts of their own).
    std::vector<Eigen::Vector3d> centres;
    int best = -1;
    double best_d = 1e300;
    for (size_t i = 0; i < fparts.size(); ++i) {
      centres.push_back(R * fparts[i].centroid + t);
      const double d = (centres.back() - predicted).norm();
      if (d < best_d && d < scan_extent + 2 * velocity.norm() * dt + 0.05) best_d = d, best = int(i);
    }
    if (best < 0) {
      lost.push_back(f);
      p.object_masks[std::size_t(f)].assign(pixel_count, 0);
      continue;
    }
    p.object_masks[std::size_t(f)].assign(pixel_count, 0);
    for (size_t i = 0; i < fparts.size(); ++i) {
      const double near = std::min((centres[i] - predicted).norm(), (centres[i] - centres[std::size_t(best)]).norm());
      if (int(i) != best && near > 0.6 * scan_extent) continue;
      for (int pixel : fparts[i].pixels) p.object_masks[std::size_t(f)][std::size_t(pixel)] = 1;
      p.object_pixels[std::size_t(f)] += int(fparts[i].pixels.size());
    }
    RigidPose start = last_pose;
    start.translation += predicted - last_centre;
    const std::vector<Eigen::Vector3d> pts =
        object_points_world(rec.frames[std::size_t(f)], k, p.object_masks[std::size_t(f)], p.camera_to_world);
    IcpResult icp = icp_point_to_plane(p.scan, pts, start, 0.2 * scan_extent, huber, 40);
    icp = icp_point_to_plane(p.scan, pts, icp.pose, std::max(0.03 * scan_extent, 5 * huber), huber, 40);
    if (icp.matched < int(0.8 * pts.size()) || icp.rms > std::max(1.5 * p.icp_rms[0], huber)) {
      // Lost track (a bounce turns the motion round within a frame): register this frame afresh.
      CameraView frame_view = view;
      frame_view.depth = &rec.frames[std::size_t(f)];
      const RegistrationResult again = register_scan(p.scan, pts, frame_view, huber);
      if (again.icp.matched > icp.matched || (again.icp.matched == icp.matched && again.icp.rms < icp.rms)) icp = again.icp;
    }
    p.poses[std::size_t(f)] = icp.pose;
    p.icp_rms[std::size_t(f)] = icp.rms;
    const Eigen::Vector3d centre = icp.pose.apply(p.scan.centroid);
    velocity = (centre - last_centre) / dt + 0.5 * g_world * dt;  // at the end of the interval
    last_centre = centre;
    last_pose = icp.pose;
    last_frame = f;
  }
  if (!lost.empty()) {
    std::string list;
    for (size_t i = 0; i < lost.size() && i < 10; ++i) list += (i ? ", " : "") + std::to_string(lost[i]);
    warn("object_lost", fmt::format("{}: the object was not found in {} of {} frames ({}{}); those frames are empty "
                                    "in the observations", where, lost.size(), frames, list, lost.size() > 10 ? ", ..." : ""));
  }

}

}  // namespace ssc
