// The object's initial velocity from its registered poses in the first frames of free
// flight: the centre of mass follows c(t) = c0 + v t + g t^2 / 2 (gravity known), so v is the
// least-squares slope of c(t) - g t^2 / 2. The rotation's start is the least-squares slope of
// the rotation vectors of R(t) R0^T (a constant spin); with the body's inertia it is refined to
// the torque-free motion of a rigid body (angular momentum constant, w(t) = I(t)^-1 L, which
// precesses unless the body spins about a principal axis) by Gauss-Newton on the rotations.
#pragma once
#include <Eigen/Core>
#include <vector>

#include "models/recording/registration.h"

namespace ssc {

struct RigidVelocity {
  Eigen::Vector3d linear{0, 0, 0};   // m/s, of the centre of mass
  Eigen::Vector3d angular{0, 0, 0};  // rad/s, about the centre of mass
  int frames = 0;                    // frames the estimate used (fewer than 2: none)
};

// poses[f] at times[f] (s, from frame 0); centre: the scan's centre of mass in its own frame;
// inertia: about it, in the scan's frame (any positive multiple; zero: constant spin only).
RigidVelocity estimate_velocity(const std::vector<RigidPose>& poses, const std::vector<double>& times,
                                const Eigen::Vector3d& centre, const Eigen::Vector3d& gravity,
                                const Eigen::Matrix3d& inertia = Eigen::Matrix3d::Zero());

// The rotation of a torque-free rigid body after time t from rotation r0 with angular velocity
// w0 (world frame), inertia in the body's frame; integrated in steps of at most `step` seconds.
Eigen::Matrix3d torque_free_rotation(const Eigen::Matrix3d& r0, const Eigen::Vector3d& w0, const Eigen::Matrix3d& inertia,
                                     double t, double step = 2e-4);

}  // namespace ssc
