#include "models/recording/motion_estimate.h"

#include <Eigen/Geometry>

namespace ssc {

RigidVelocity estimate_velocity(const std::vector<RigidPose>& poses, const std::vector<double>& times,
                                const Eigen::Vector3d& centre, const Eigen::Vector3d& gravity) {
  RigidVelocity out;
  const size_t n = std::min(poses.size(), times.size());
  out.frames = int(n);
  if (n < 2) return out;
  // Linear: fit y(t) = a + v t to y = c(t) - g t^2 / 2.
  double st = 0, stt = 0;
  Eigen::Vector3d sy = Eigen::Vector3d::Zero(), sty = Eigen::Vector3d::Zero();
  Eigen::Vector3d sw = Eigen::Vector3d::Zero();
  double stt_w = 0;
  const Eigen::Matrix3d r0t = poses[0].rotation.transpose();
  for (size_t f = 0; f < n; ++f) {
    const double t = times[f];
    const Eigen::Vector3d y = poses[f].apply(centre) - 0.5 * gravity * t * t;
    st += t, stt += t * t, sy += y, sty += t * y;
    const Eigen::AngleAxisd aa(poses[f].rotation * r0t);
    sw += t * aa.angle() * aa.axis();  // rotation vector, through the origin at t = 0
    stt_w += t * t;
  }
  const double denom = double(n) * stt - st * st;
  out.linear = (double(n) * sty - st * sy) / denom;
  out.angular = sw / stt_w;
  return out;
}

}  // namespace ssc
