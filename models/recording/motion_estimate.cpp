#include "models/recording/motion_estimate.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <cmath>

namespace ssc {

namespace {

Eigen::Matrix3d exp_rotation(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  return angle > 0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
}

Eigen::Vector3d log_rotation(const Eigen::Matrix3d& r) {
  const Eigen::AngleAxisd aa(r);
  return aa.angle() * aa.axis();
}

}  // namespace

Eigen::Matrix3d torque_free_rotation(const Eigen::Matrix3d& r0, const Eigen::Vector3d& w0, const Eigen::Matrix3d& inertia,
                                     double t, double step) {
  const Eigen::Matrix3d inverse = inertia.inverse();
  const Eigen::Vector3d momentum = r0 * inertia * r0.transpose() * w0;  // world, constant
  auto omega = [&](const Eigen::Matrix3d& r) -> Eigen::Vector3d { return r * inverse * r.transpose() * momentum; };
  const int steps = std::max(1, int(std::ceil(std::abs(t) / step)));
  const double h = t / steps;
  Eigen::Matrix3d r = r0;
  for (int k = 0; k < steps; ++k) {  // the exponential midpoint rule
    const Eigen::Matrix3d half = exp_rotation(0.5 * h * omega(r)) * r;
    r = exp_rotation(h * omega(half)) * r;
  }
  return r;
}

RigidVelocity estimate_velocity(const std::vector<RigidPose>& poses, const std::vector<double>& times,
                                const Eigen::Vector3d& centre, const Eigen::Vector3d& gravity,
                                const Eigen::Matrix3d& inertia) {
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
  if (n < 3 || !(inertia.determinant() > 0)) return out;
  // Torque-free refinement: Gauss-Newton on w0, residuals log(R_f R_pred(t_f)^T), forward differences.
  auto residuals = [&](const Eigen::Vector3d& w0) {  // one integration through the frames
    Eigen::VectorXd r(3 * (n - 1));
    Eigen::Matrix3d rot = poses[0].rotation;
    Eigen::Vector3d w = w0;
    for (size_t f = 1; f < n; ++f) {
      const Eigen::Matrix3d next = torque_free_rotation(rot, w, inertia, times[f] - times[f - 1]);
      // The angular momentum is constant: carry w to the new rotation.
      const Eigen::Vector3d momentum = rot * inertia * rot.transpose() * w;
      w = next * inertia.inverse() * next.transpose() * momentum;
      rot = next;
      r.segment<3>(3 * (f - 1)) = log_rotation(poses[f].rotation * rot.transpose());
    }
    return r;
  };
  Eigen::Vector3d w = out.angular;
  Eigen::VectorXd r = residuals(w);
  for (int it = 0; it < 8; ++it) {
    Eigen::MatrixXd J(r.size(), 3);
    for (int a = 0; a < 3; ++a) {
      Eigen::Vector3d dw = w;
      dw[a] += 1e-6;
      J.col(a) = (residuals(dw) - r) / 1e-6;
    }
    const Eigen::Vector3d step = (J.transpose() * J).ldlt().solve(-J.transpose() * r);
    const Eigen::VectorXd trial = residuals(w + step);
    if (trial.squaredNorm() >= r.squaredNorm()) break;
    w += step;
    r = trial;
    if (step.norm() < 1e-9) break;
  }
  out.angular = w;
  return out;
}

}  // namespace ssc
