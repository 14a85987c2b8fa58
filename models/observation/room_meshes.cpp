#include "models/observation/room_meshes.h"

namespace ssc {

void TriangleSoup::add_rectangle(const Eigen::Vector3d& corner, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const int base = int(vertices.size());
  vertices.push_back(corner);
  vertices.push_back(corner + a);
  vertices.push_back(corner + a + b);
  vertices.push_back(corner + b);
  triangles.push_back({base, base + 1, base + 2});
  triangles.push_back({base, base + 2, base + 3});
}

void TriangleSoup::add_box(const Eigen::Vector3d& c, const Eigen::Vector3d& h, const Eigen::Matrix3d& r) {
  const Eigen::Vector3d ax = r.col(0) * h.x(), ay = r.col(1) * h.y(), az = r.col(2) * h.z();
  add_rectangle(c - ax - ay - az, 2 * ax, 2 * ay);  // -z face
  add_rectangle(c - ax - ay + az, 2 * ax, 2 * ay);  // +z face
  add_rectangle(c - ax - ay - az, 2 * ax, 2 * az);  // -y face
  add_rectangle(c - ax + ay - az, 2 * ax, 2 * az);  // +y face
  add_rectangle(c - ax - ay - az, 2 * ay, 2 * az);  // -x face
  add_rectangle(c + ax - ay - az, 2 * ay, 2 * az);  // +x face
}

void TriangleSoup::append(const std::vector<Eigen::Vector3d>& v, const std::vector<std::array<int, 3>>& t) {
  const int base = int(vertices.size());
  vertices.insert(vertices.end(), v.begin(), v.end());
  for (const auto& tri : t) triangles.push_back({tri[0] + base, tri[1] + base, tri[2] + base});
}

}  // namespace ssc
