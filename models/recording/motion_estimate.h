// The object's initial velocity from its registered poses in the first frames of free
// flight: the centre of mass follows c(t) = c0 + v t + g t^2 / 2 (gravity known), so v is the
// least-squares slope of c(t) - g t^2 / 2; the rotation follows R(t) = exp(t [w]) R0, so w is
// the least-squares slope of the rotation vectors of R(t) R0^T (a constant spin: exact for a
// body spinning about a principal axis, an approximation otherwise over a few frames).
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

// poses[f] at times[f] (s, from frame 0); centre: the scan's centre of mass in its own frame.
RigidVelocity estimate_velocity(const std::vector<RigidPose>& poses, const std::vector<double>& times,
                                const Eigen::Vector3d& centre, const Eigen::Vector3d& gravity);

}  // namespace ssc
