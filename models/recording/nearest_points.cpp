#include "models/recording/nearest_points.h"

#include <algorithm>

namespace ssc {

NearestPoints::NearestPoints(std::vector<Eigen::Vector3d> points) : points_(std::move(points)) {
  order_.resize(points_.size());
  for (size_t i = 0; i < order_.size(); ++i) order_[i] = int(i);
  if (!points_.empty()) build(0, int(points_.size()));
}

int NearestPoints::build(int begin, int end) {
  const int id = int(nodes_.size());
  nodes_.push_back({begin, end});
  if (end - begin <= 8) return id;
  Eigen::Vector3d lo = points_[std::size_t(order_[std::size_t(begin)])], hi = lo;
  for (int i = begin; i < end; ++i) {
    lo = lo.cwiseMin(points_[std::size_t(order_[std::size_t(i)])]);
    hi = hi.cwiseMax(points_[std::size_t(order_[std::size_t(i)])]);
  }
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  const int mid = (begin + end) / 2;
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                   [&](int a, int b) { return points_[std::size_t(a)][axis] < points_[std::size_t(b)][axis]; });
  const double split = points_[std::size_t(order_[std::size_t(mid)])][axis];
  const int left = build(begin, mid);
  const int right = build(mid, end);
  nodes_[std::size_t(id)].axis = axis;
  nodes_[std::size_t(id)].split = split;
  nodes_[std::size_t(id)].left = left;
  nodes_[std::size_t(id)].right = right;
  return id;
}

void NearestPoints::search(int id, const Eigen::Vector3d& q, int* best, double* best2) const {
  const Node& n = nodes_[std::size_t(id)];
  if (n.axis < 0) {
    for (int i = n.begin; i < n.end; ++i) {
      const double d2 = (points_[std::size_t(order_[std::size_t(i)])] - q).squaredNorm();
      if (d2 < *best2) *best2 = d2, *best = order_[std::size_t(i)];
    }
    return;
  }
  const double diff = q[n.axis] - n.split;
  const int near = diff < 0 ? n.left : n.right, far = diff < 0 ? n.right : n.left;
  search(near, q, best, best2);
  if (diff * diff < *best2) search(far, q, best, best2);
}

int NearestPoints::nearest(const Eigen::Vector3d& q, double* distance2) const {
  int best = -1;
  double best2 = 1e300;
  if (!points_.empty()) search(0, q, &best, &best2);
  if (distance2) *distance2 = best2;
  return best;
}

}  // namespace ssc
