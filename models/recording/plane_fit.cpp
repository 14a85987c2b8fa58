#include "models/recording/plane_fit.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <random>

namespace ssc {

Plane fit_plane(const std::vector<Eigen::Vector3d>& points, const std::vector<int>& indices,
                const Eigen::Vector3d& orient_towards) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int i : indices) mean += points[std::size_t(i)];
  mean /= double(indices.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int i : indices) {
    const Eigen::Vector3d d = points[std::size_t(i)] - mean;
    cov += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Plane plane;
  plane.normal = eig.eigenvectors().col(0).normalized();
  plane.offset = plane.normal.dot(mean);
  if (plane.distance(orient_towards) < 0) {
    plane.normal = -plane.normal;
    plane.offset = -plane.offset;
  }
  return plane;
}

namespace {

std::vector<int> inliers_of(const Plane& plane, const std::vector<Eigen::Vector3d>& points,
                            const std::vector<double>& band, const std::vector<int>& candidates) {
  std::vector<int> in;
  for (int i : candidates)
    if (std::abs(plane.distance(points[std::size_t(i)])) <= band[std::size_t(i)]) in.push_back(i);
  return in;
}

}  // namespace

std::vector<DetectedPlane> find_planes(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& band,
                                       const Eigen::Vector3d& orient_towards, const PlaneSearch& search) {
  std::mt19937_64 rng(search.seed);
  std::vector<int> remaining(points.size());
  for (size_t i = 0; i < points.size(); ++i) remaining[i] = int(i);
  const size_t min_inliers = std::max<size_t>(size_t(search.min_points), size_t(search.min_fraction * points.size()));
  std::vector<DetectedPlane> planes;
  while (int(planes.size()) < search.max_planes && remaining.size() >= min_inliers) {
    // Score hypotheses on a fixed subsample of what is left.
    std::vector<int> sample = remaining;
    std::shuffle(sample.begin(), sample.end(), rng);
    if (sample.size() > 4000) sample.resize(4000);
    std::uniform_int_distribution<size_t> pick(0, remaining.size() - 1);
    Plane best;
    size_t best_count = 0;
    for (int it = 0; it < search.iterations; ++it) {
      const Eigen::Vector3d& a = points[std::size_t(remaining[pick(rng)])];
      const Eigen::Vector3d& b = points[std::size_t(remaining[pick(rng)])];
      const Eigen::Vector3d& c = points[std::size_t(remaining[pick(rng)])];
      const Eigen::Vector3d n = (b - a).cross(c - a);
      if (n.norm() < 1e-12) continue;
      Plane h;
      h.normal = n.normalized();
      h.offset = h.normal.dot(a);
      size_t count = 0;
      for (int i : sample) count += std::abs(h.distance(points[std::size_t(i)])) <= band[std::size_t(i)];
      if (count > best_count) best_count = count, best = h;
    }
    if (best_count == 0) break;
    std::vector<int> in = inliers_of(best, points, band, remaining);
    for (int round = 0; round < 4 && in.size() >= 3; ++round) {
      best = fit_plane(points, in, orient_towards);
      in = inliers_of(best, points, band, remaining);
    }
    if (in.size() < min_inliers) break;
    DetectedPlane found;
    found.plane = best;
    double sum2 = 0;
    for (int i : in) sum2 += std::pow(best.distance(points[std::size_t(i)]), 2);
    found.rms = std::sqrt(sum2 / double(in.size()));
    found.inliers = in;
    std::vector<char> taken(points.size(), 0);
    for (int i : in) taken[std::size_t(i)] = 1;
    std::vector<int> rest;
    for (int i : remaining)
      if (!taken[std::size_t(i)]) rest.push_back(i);
    remaining.swap(rest);
    planes.push_back(std::move(found));
  }
  return planes;
}

}  // namespace ssc
