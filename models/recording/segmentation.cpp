#include "models/recording/segmentation.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace ssc {

std::vector<double> far_background(const std::vector<DepthImage>& frames, const SensorNoise& noise, double depth_scale) {
  if (frames.size() < 3) return {};
  const size_t n = frames.front().depth.size();
  std::vector<double> far(n, 0.0), readings;
  for (size_t i = 0; i < n; ++i) {
    readings.clear();
    for (const DepthImage& f : frames)
      if (f.depth[i] > 0) readings.push_back(f.depth[i]);
    if (readings.size() < 3) continue;
    std::sort(readings.begin(), readings.end());
    // The second largest reading is behind anything that moved past; the static readings are
    // those within the noise of it, and their median is the background's depth (the largest
    // readings alone would be biased away from the camera by the noise).
    const double behind = readings[readings.size() - 2];
    const double band = 2 * noise_band(noise, behind, depth_scale);
    const auto first = std::lower_bound(readings.begin(), readings.end(), behind - band);
    const size_t count = size_t(readings.end() - first);
    // Background is steady: nearly all readings agree. A moving object that has not cleared the
    // pixel yet changes its depth from frame to frame, and leaves the pixel without one.
    if (count < 2 || 4 * count < 3 * readings.size()) continue;
    far[i] = *(first + std::ptrdiff_t(count / 2));
  }
  return far;
}

std::vector<char> depth_edges(const DepthImage& img, const DepthIntrinsics& k, const SensorNoise& noise,
                              double depth_scale) {
  std::vector<char> edge(img.depth.size(), 0);
  for (int v = 0; v < img.height; ++v)
    for (int u = 0; u < img.width; ++u) {
      const double z = img.at(u, v);
      if (!(z > 0)) continue;
      const double limit = neighbour_jump_limit(noise, z, k.fx, depth_scale);
      for (int dv = -1; dv <= 1 && !edge[std::size_t(v * img.width + u)]; ++dv)
        for (int du = -1; du <= 1; ++du) {
          const int uu = u + du, vv = v + dv;
          if ((du == 0 && dv == 0) || uu < 0 || vv < 0 || uu >= img.width || vv >= img.height) continue;
          const double zn = img.at(uu, vv);
          if (zn > 0 && std::abs(zn - z) > limit * (du != 0 && dv != 0 ? 1.41 : 1.0)) {
            edge[std::size_t(v * img.width + u)] = 1;
            break;
          }
        }
    }
  return edge;
}

std::vector<PixelClass> classify_pixels(const DepthImage& img, const SegmentationContext& c) {
  const std::vector<char> edges = depth_edges(img, c.intrinsics, c.noise, c.depth_scale);
  std::vector<PixelClass> out(img.depth.size(), PixelClass::None);
  for (int v = 0; v < img.height; ++v)
    for (int u = 0; u < img.width; ++u) {
      const size_t i = size_t(v) * img.width + u;
      const double z = img.depth[i];
      if (!(z > 0)) continue;
      const double band = noise_band(c.noise, z, c.depth_scale);
      const Eigen::Vector3d p = back_project(c.intrinsics, u, v, z);
      // The band along the normal: a plane seen at an angle spreads the depth noise less along its normal.
      bool on_plane = false;
      for (const Plane& plane : c.planes)
        on_plane |= std::abs(plane.distance(p)) <= band;
      if (on_plane) out[i] = PixelClass::Plane;
      else if (!c.background.empty() && c.background[i] > 0 && z >= c.background[i] - 2 * band) out[i] = PixelClass::Static;
      else if (edges[i]) out[i] = PixelClass::Edge;
      else out[i] = PixelClass::Candidate;
    }
  return out;
}

Eigen::Vector3d principal_extents(const std::vector<Eigen::Vector3d>& points) {
  if (points.size() < 3) return Eigen::Vector3d::Zero();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points) mean += p;
  mean /= double(points.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : points) cov += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Eigen::Vector3d extents;
  for (int a = 0; a < 3; ++a) {
    std::vector<double> s;
    s.reserve(points.size());
    for (const auto& p : points) s.push_back(eig.eigenvectors().col(a).dot(p - mean));
    std::sort(s.begin(), s.end());
    const size_t lo = size_t(0.02 * (s.size() - 1)), hi = size_t(std::ceil(0.98 * (s.size() - 1)));
    extents[2 - a] = s[hi] - s[lo];
  }
  return extents;
}

std::vector<DepthComponent> depth_components(const DepthImage& img, const std::vector<PixelClass>& classes,
                                             const SegmentationContext& c, int min_pixels) {
  std::vector<int> label(img.depth.size(), -1);
  std::vector<DepthComponent> parts;
  std::vector<int> stack;
  for (size_t seed = 0; seed < img.depth.size(); ++seed) {
    if (classes[seed] != PixelClass::Candidate || label[seed] >= 0) continue;
    DepthComponent part;
    label[seed] = int(parts.size());
    stack.assign(1, int(seed));
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      part.pixels.push_back(i);
      const int u = i % img.width, v = i / img.width;
      const double z = img.depth[std::size_t(i)];
      const double limit = neighbour_jump_limit(c.noise, z, c.intrinsics.fx, c.depth_scale);
      const int du[4] = {1, -1, 0, 0}, dv[4] = {0, 0, 1, -1};
      for (int n = 0; n < 4; ++n) {
        const int uu = u + du[n], vv = v + dv[n];
        if (uu < 0 || vv < 0 || uu >= img.width || vv >= img.height) continue;
        const int j = vv * img.width + uu;
        if (classes[std::size_t(j)] != PixelClass::Candidate || label[std::size_t(j)] >= 0) continue;
        if (std::abs(img.depth[std::size_t(j)] - z) > limit) continue;
        label[std::size_t(j)] = label[seed];
        stack.push_back(j);
      }
    }
    parts.push_back(std::move(part));
  }
  std::vector<DepthComponent> kept;
  for (DepthComponent& part : parts) {
    if (int(part.pixels.size()) < min_pixels) continue;
    std::vector<Eigen::Vector3d> pts;
    for (int i : part.pixels) {
      const int u = i % img.width, v = i / img.width;
      pts.push_back(back_project(c.intrinsics, u, v, img.depth[std::size_t(i)]));
      part.pixel_centroid += Eigen::Vector2d(u, v);
      part.touches_border |= u < 2 || v < 2 || u >= img.width - 2 || v >= img.height - 2;
    }
    for (const auto& p : pts) part.centroid += p;
    part.centroid /= double(pts.size());
    part.pixel_centroid /= double(pts.size());
    part.extent = principal_extents(pts)[0];
    kept.push_back(std::move(part));
  }
  std::sort(kept.begin(), kept.end(), [](const DepthComponent& a, const DepthComponent& b) {
    return a.pixels.size() > b.pixels.size();
  });
  return kept;
}

}  // namespace ssc
