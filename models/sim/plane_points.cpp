// Observed points on a contact plane (see plane_points.h): a hash grid over the plane's
// coordinates of the points above the band, looked up for each point within it.
#include "models/sim/plane_points.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "models/io/run_record.h"
#include "runtime/errors.h"

namespace ssc {

double plane_depth_noise(const ObservationSet& set, std::string* source) {
  double noise = -1;
  for (size_t c = 0; c < set.cameras.size(); ++c) {
    const DepthNoise* model = camera_depth_noise(set, int(c));
    if (!model) continue;
    std::vector<double> depths;
    for (const std::vector<DepthImage>& frame : set.frames)
      if (c < frame.size())
        for (double z : frame[c].depth)
          if (z > 0) depths.push_back(z);
    if (depths.empty()) continue;
    std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
    noise = std::max(noise, model->sigma(depths[depths.size() / 2]));
  }
  if (source)
    *source = noise >= 0 ? "the depth_noise of cameras.json at the median measured depth"
                         : fmt::format("{:.3g} m, as cameras.json gives no depth_noise", kDefaultDepthNoise);
  return noise >= 0 ? noise : kDefaultDepthNoise;
}

double plane_band(const ObservationSet& set) { return kPlaneBandSigmas * plane_depth_noise(set) + set.depth_scale; }

std::vector<long> table_points(const std::vector<ObservedFrame>& frames, const PlaneSpec& plane, double band) {
  const Eigen::Vector3d n = plane.normal.normalized();
  const Eigen::Vector3d e1 = n.unitOrthogonal(), e2 = n.cross(e1);
  const double margin = std::max(kFootprintMargin, 2 * band);
  auto key = [margin](double a, double b) {
    return (std::int64_t(std::floor(a / margin)) << 32) ^ (std::int64_t(std::floor(b / margin)) & 0xffffffff);
  };
  std::vector<long> counts;
  for (const ObservedFrame& frame : frames) {
    std::unordered_map<std::int64_t, std::vector<Eigen::Vector2d>> above;
    std::vector<Eigen::Vector2d> on;
    for (const Eigen::Vector3d& x : frame.points) {
      const double d = n.dot(x) - plane.height;
      const Eigen::Vector2d q(e1.dot(x), e2.dot(x));
      if (std::abs(d) <= band) on.push_back(q);
      else if (d > band) above[key(q.x(), q.y())].push_back(q);
    }
    long count = 0;
    for (const Eigen::Vector2d& q : on) {
      bool under_body = false;
      for (int i = -1; i <= 1 && !under_body; ++i)
        for (int j = -1; j <= 1 && !under_body; ++j) {
          const auto it = above.find(key(q.x() + i * margin, q.y() + j * margin));
          if (it == above.end()) continue;
          for (const Eigen::Vector2d& p : it->second)
            if ((p - q).norm() <= margin) {
              under_body = true;
              break;
            }
        }
      count += !under_body;
    }
    counts.push_back(count);
  }
  return counts;
}

void check_table_points(const std::vector<ObservedFrame>& frames, const std::vector<PlaneSpec>& planes,
                        const ObservationSet& set, const std::string& dir) {
  const double band = plane_band(set);
  std::string noise;
  plane_depth_noise(set, &noise);
  for (std::size_t k = 0; k < planes.size(); ++k) {
    const std::vector<long> counts = table_points(frames, planes[k], band);
    int worst = -1;
    double worst_fraction = 0;
    long total = 0, points = 0;
    for (std::size_t f = 0; f < frames.size(); ++f) {
      total += counts[f];
      points += long(frames[f].points.size());
      const double fraction = frames[f].points.empty() ? 0 : double(counts[f]) / double(frames[f].points.size());
      if (fraction > worst_fraction) worst_fraction = fraction, worst = int(f);
    }
    if (worst_fraction <= kTablePointsWarning) continue;
    const std::string what = fmt::format(
        "{}: {} of the observed points ({:.1f} %; {:.1f} % in frame {}, the most) lie on ground.planes[{}] (within {:.3g} m "
        "of the plane: {:g} x the depth noise, from {}, plus one depth unit) away from the body: they are the table, "
        "not the body, and the fit bends the body towards them",
        dir, total, 100.0 * double(total) / double(std::max(points, 1L)), 100 * worst_fraction, worst, k, band,
        kPlaneBandSigmas, noise);
    const std::string fix = fmt::format(
        "remove them from the depth images (segment the body: set the support's pixels to 0), or, if the body is "
        "thinner than {:.3g} m or the scene's plane is not where the support is, check ground.planes[{}].height and "
        "depth_noise in cameras.json", band, k);
    if (worst_fraction > kTablePointsError)
      throw InputError(fmt::format("{} (more than {:.0f} % of a frame's points); {}", what, 100 * kTablePointsError, fix));
    warn("table_points", what + "; " + fix);
  }
}

}  // namespace ssc
