#include "models/recording/scan_model.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <map>
#include <random>

#include "models/recording/segmentation.h"

namespace ssc {

ScanModel make_scan_model(const TriangleMesh& mesh, double scale, int samples, std::uint64_t seed) {
  ScanModel m;
  std::vector<double> area_cdf;
  double area = 0, signed_volume = 0;
  Eigen::Vector3d area_centroid = Eigen::Vector3d::Zero(), volume_moment = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second_moment = Eigen::Matrix3d::Zero();  // the integral of x x^T over the volume
  std::map<std::pair<int, int>, int> edges;
  for (const Eigen::Vector3i& f : mesh.faces) {
    const Eigen::Vector3d a = scale * mesh.vertices[std::size_t(f.x())], b = scale * mesh.vertices[std::size_t(f.y())],
                          c = scale * mesh.vertices[std::size_t(f.z())];
    const double A = 0.5 * (b - a).cross(c - a).norm();
    area += A;
    area_cdf.push_back(area);
    area_centroid += A * (a + b + c) / 3;
    const double v6 = a.dot(b.cross(c));  // six times the signed volume of (0, a, b, c)
    signed_volume += v6 / 6;
    volume_moment += v6 / 6 * (a + b + c) / 4;
    const Eigen::Vector3d sum = a + b + c;  // the tetrahedron (0, a, b, c)'s second moment
    second_moment += v6 / 120 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + sum * sum.transpose());
    for (int e = 0; e < 3; ++e) {
      int i = f[e], j = f[(e + 1) % 3];
      if (i > j) std::swap(i, j);
      ++edges[{i, j}];
    }
  }
  for (const auto& [edge, count] : edges) m.open_edges += count != 2;
  // The divergence theorem's volume; for a scan with holes (open_edges > 0) an approximation
  // that is good while the holes are small.
  if (std::abs(signed_volume) > 1e-9 * std::pow(area, 1.5)) {
    m.volume = std::abs(signed_volume);
    m.centroid = volume_moment / signed_volume;
    const double sign = signed_volume < 0 ? -1.0 : 1.0;
    const Eigen::Matrix3d central = sign * second_moment - m.volume * m.centroid * m.centroid.transpose();
    m.inertia = central.trace() * Eigen::Matrix3d::Identity() - central;
  } else {
    m.centroid = area_centroid / std::max(area, 1e-300);
  }
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(0, 1);
  for (int s = 0; s < samples && area > 0; ++s) {
    const size_t t = size_t(std::lower_bound(area_cdf.begin(), area_cdf.end(), uni(rng) * area) - area_cdf.begin());
    const Eigen::Vector3i& f = mesh.faces[std::min(t, mesh.faces.size() - 1)];
    const Eigen::Vector3d a = scale * mesh.vertices[std::size_t(f.x())], b = scale * mesh.vertices[std::size_t(f.y())],
                          c = scale * mesh.vertices[std::size_t(f.z())];
    double r1 = uni(rng), r2 = uni(rng);
    if (r1 + r2 > 1) r1 = 1 - r1, r2 = 1 - r2;
    Eigen::Vector3d n = (b - a).cross(c - a);
    if (n.norm() == 0) continue;
    m.points.push_back(a + r1 * (b - a) + r2 * (c - a));
    m.normals.push_back(n.normalized() * (signed_volume < 0 ? -1.0 : 1.0));
  }
  m.extents = principal_extents(m.points);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : m.points) cov += (p - m.centroid) * (p - m.centroid).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  for (int a = 0; a < 3; ++a) m.axes.col(a) = eig.eigenvectors().col(2 - a);
  if (m.axes.determinant() < 0) m.axes.col(2) = -m.axes.col(2);
  m.index = std::make_shared<NearestPoints>(m.points);
  return m;
}

}  // namespace ssc
