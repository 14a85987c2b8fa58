// Nearest-neighbour queries over a fixed set of 3D points: a kd-tree (median splits along
// the widest axis, leaves of up to 8 points) for ICP's closest-point search.
#pragma once
#include <Eigen/Core>
#include <vector>

namespace ssc {

class NearestPoints {
 public:
  explicit NearestPoints(std::vector<Eigen::Vector3d> points);
  // Index of the point nearest to q and its squared distance; -1 when empty.
  int nearest(const Eigen::Vector3d& q, double* distance2 = nullptr) const;
  const std::vector<Eigen::Vector3d>& points() const { return points_; }

 private:
  struct Node {
    int begin = 0, end = 0;       // points order_[begin, end) for a leaf
    int axis = -1;                // -1: leaf
    double split = 0;
    int left = -1, right = -1;
  };
  int build(int begin, int end);
  void search(int node, const Eigen::Vector3d& q, int* best, double* best2) const;
  std::vector<Eigen::Vector3d> points_;
  std::vector<int> order_;
  std::vector<Node> nodes_;
};

}  // namespace ssc
