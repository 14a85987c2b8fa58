#include "models/recording/registration.h"

#include <Eigen/LU>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace ssc {

double rotation_angle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const double c = std::clamp(((a.transpose() * b).trace() - 1) / 2, -1.0, 1.0);
  return std::acos(c);
}

IcpResult icp_point_to_plane(const ScanModel& scan, const std::vector<Eigen::Vector3d>& observed, RigidPose pose,
                             double max_distance, double huber, int iterations) {
  IcpResult result;
  const double max2 = max_distance * max_distance;
  for (int it = 0; it < iterations; ++it) {
    Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
    double sum2 = 0;
    int matched = 0;
    for (const Eigen::Vector3d& q : observed) {
      const Eigen::Vector3d local = pose.rotation.transpose() * (q - pose.translation);
      double d2 = 0;
      const int k = scan.index->nearest(local, &d2);
      if (k < 0 || d2 > max2) continue;
      const Eigen::Vector3d p = pose.apply(scan.points[std::size_t(k)]);
      const Eigen::Vector3d n = pose.rotation * scan.normals[std::size_t(k)];
      const double r = (p - q).dot(n);
      const double w = std::abs(r) <= huber ? 1.0 : huber / std::abs(r);
      Eigen::Matrix<double, 6, 1> J;
      J.head<3>() = p.cross(n);
      J.tail<3>() = n;
      H += w * J * J.transpose();
      g += w * J * r;
      sum2 += r * r;
      ++matched;
    }
    result.matched = matched;
    result.rms = matched ? std::sqrt(sum2 / matched) : 0;
    result.iterations = it + 1;
    if (matched < 6) break;
    H.diagonal().array() += 1e-9 * H.diagonal().maxCoeff() + 1e-12;  // a sphere leaves rotations free
    const Eigen::Matrix<double, 6, 1> x = H.ldlt().solve(-g);
    const Eigen::Vector3d w = x.head<3>();
    const double angle = w.norm();
    const Eigen::Matrix3d dr = angle > 0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix()
                                         : Eigen::Matrix3d::Identity();
    pose.rotation = dr * pose.rotation;
    pose.translation = dr * pose.translation + x.tail<3>();
    if (angle < 1e-7 && x.tail<3>().norm() < 1e-7) break;
  }
  // Orthonormalise against drift.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(pose.rotation, Eigen::ComputeFullU | Eigen::ComputeFullV);
  pose.rotation = svd.matrixU() * svd.matrixV().transpose();
  result.pose = pose;
  return result;
}

double seen_through_fraction(const ScanModel& scan, const RigidPose& pose, const CameraView& view) {
  const Eigen::Matrix3d R = view.world_to_camera.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = view.world_to_camera.topRightCorner<3, 1>();
  int facing = 0, through = 0;
  const DepthImage& img = *view.depth;
  for (size_t i = 0; i < scan.points.size(); i += 2) {
    const Eigen::Vector3d p = R * pose.apply(scan.points[i]) + t;
    const Eigen::Vector3d n = R * pose.rotation * scan.normals[i];
    if (p.z() <= 0 || n.dot(p) >= 0) continue;  // behind the camera, or facing away from it
    const int u = int(std::lround(view.intrinsics.fx * p.x() / p.z() + view.intrinsics.cx));
    const int v = int(std::lround(view.intrinsics.fy * p.y() / p.z() + view.intrinsics.cy));
    if (u < 0 || v < 0 || u >= img.width || v >= img.height) continue;
    const double z = img.at(u, v);
    if (!(z > 0)) continue;
    ++facing;
    through += p.z() < z - view.tolerance;
  }
  return facing ? double(through) / facing : 0.0;
}

namespace {

// The 24 rotations of the cube: signed permutation matrices with determinant +1.
std::vector<Eigen::Matrix3d> cube_rotations() {
  std::vector<Eigen::Matrix3d> out;
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (const auto& p : perms)
    for (int s = 0; s < 8; ++s) {
      Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
      for (int r = 0; r < 3; ++r) m(r, p[r]) = (s >> r) & 1 ? -1.0 : 1.0;
      if (m.determinant() > 0) out.push_back(m);
    }
  return out;
}

Eigen::Matrix3d principal_axes(const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& mean) {
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : pts) cov += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Eigen::Matrix3d axes;
  for (int a = 0; a < 3; ++a) axes.col(a) = eig.eigenvectors().col(2 - a);
  if (axes.determinant() < 0) axes.col(2) = -axes.col(2);
  return axes;
}

// Truncated mean squared distance of observed points to the posed scan: robust to stray points.
double truncated_residual(const ScanModel& scan, const std::vector<Eigen::Vector3d>& observed, const RigidPose& pose,
                          double cap) {
  double sum = 0;
  for (const Eigen::Vector3d& q : observed) {
    double d2 = 0;
    scan.index->nearest(pose.rotation.transpose() * (q - pose.translation), &d2);
    sum += std::min(d2, cap * cap);
  }
  return std::sqrt(sum / std::max<size_t>(observed.size(), 1));
}

}  // namespace

RegistrationResult register_scan(const ScanModel& scan, const std::vector<Eigen::Vector3d>& observed,
                                 const CameraView& view, double huber) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& q : observed) mean += q;
  mean /= double(observed.size());
  const Eigen::Matrix3d observed_axes = principal_axes(observed, mean);
  // The visible surface is the near side: the centre lies about a quarter of the size further away.
  const Eigen::Matrix4d c2w = view.world_to_camera.inverse();
  const Eigen::Vector3d eye = c2w.topRightCorner<3, 1>();
  const Eigen::Vector3d away = (mean - eye).normalized();
  const Eigen::Vector3d centre_guess = mean + away * 0.25 * scan.extents.minCoeff();
  const double size = scan.extents.maxCoeff();
  const double cap = std::max(0.05 * size, 4 * huber);
  // Thin out the points for the search; the winner is refined on all of them.
  std::vector<Eigen::Vector3d> few;
  const size_t stride = std::max<size_t>(1, observed.size() / 400);
  for (size_t i = 0; i < observed.size(); i += stride) few.push_back(observed[i]);
  RegistrationResult best;
  best.score = 1e300;
  for (const Eigen::Matrix3d& g : cube_rotations()) {
    RigidPose start;
    start.rotation = observed_axes * g * scan.axes.transpose();
    start.translation = centre_guess - start.rotation * scan.centroid;
    IcpResult icp = icp_point_to_plane(scan, few, start, 0.5 * size, huber, 25);
    icp = icp_point_to_plane(scan, few, icp.pose, 0.1 * size, huber, 25);
    const double through = seen_through_fraction(scan, icp.pose, view);
    const double score = truncated_residual(scan, few, icp.pose, cap) + through * cap;
    ++best.hypotheses;
    if (score < best.score) {
      best.score = score;
      best.icp = icp;
      best.seen_through = through;
    }
  }
  IcpResult fine = icp_point_to_plane(scan, observed, best.icp.pose, 0.05 * size, huber, 50);
  fine = icp_point_to_plane(scan, observed, fine.pose, std::max(0.02 * size, 5 * huber), huber, 50);
  best.icp = fine;
  best.seen_through = seen_through_fraction(scan, fine.pose, view);
  return best;
}

}  // namespace ssc
