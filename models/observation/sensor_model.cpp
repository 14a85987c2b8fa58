#include "models/observation/sensor_model.h"

#include <Eigen/Geometry>
#include <cmath>
#include <random>

namespace ssc {

namespace {

Eigen::Vector3d camera_point(const DepthCamera& c, int u, int v, double z) {
  return {(u - c.cx) / c.fx * z, (v - c.cy) / c.fy * z, z};
}

}  // namespace

DepthImage apply_sensor_model(const DepthImage& exact, const DepthCamera& cam, const DepthSensorModel& m,
                              std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0, 1);
  std::uniform_real_distribution<double> uni(0, 1);
  DepthImage out = exact;
  const double cos_grazing = std::cos(m.grazing_deg * M_PI / 180);
  const int w = exact.width, h = exact.height;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const double z = exact.at(u, v);
      double& o = out.depth[std::size_t(v) * w + u];
      if (!(z > 0)) continue;
      // Neighbours on one surface give the normal; a big jump marks an edge.
      bool edge = false;
      double far_neighbour = 0;
      for (int dv = -1; dv <= 1; ++dv)
        for (int du = -1; du <= 1; ++du) {
          const int uu = u + du, vv = v + dv;
          if (uu < 0 || vv < 0 || uu >= w || vv >= h) continue;
          const double zn = exact.at(uu, vv);
          if (zn > z + m.jump || (zn == 0 && (du || dv))) {
            edge = true;
            far_neighbour = std::max(far_neighbour, zn);
          }
        }
      if (edge && far_neighbour > 0 && uni(rng) < m.flying) {
        const double t = uni(rng);
        o = z + t * (far_neighbour - z);
        continue;
      }
      if (u > 0 && v > 0 && u < w - 1 && v < h - 1 && !edge) {
        const Eigen::Vector3d du = camera_point(cam, u + 1, v, exact.at(u + 1, v)) - camera_point(cam, u - 1, v, exact.at(u - 1, v));
        const Eigen::Vector3d dv = camera_point(cam, u, v + 1, exact.at(u, v + 1)) - camera_point(cam, u, v - 1, exact.at(u, v - 1));
        const Eigen::Vector3d n = du.cross(dv);
        const Eigen::Vector3d ray = camera_point(cam, u, v, z).normalized();
        if (n.norm() > 0 && std::abs(n.normalized().dot(ray)) < cos_grazing) {
          o = 0;
          continue;
        }
      }
      if (uni(rng) < m.dropout) {
        o = 0;
        continue;
      }
      o = z + (m.sigma0 + m.per_m2 * z * z) * gauss(rng);
    }
  for (double& z : out.depth) {
    if (z > 0) z = std::round(z / m.depth_unit) * m.depth_unit;
    if (z < cam.min_depth || z > cam.max_depth) z = 0;
  }
  return out;
}

}  // namespace ssc
