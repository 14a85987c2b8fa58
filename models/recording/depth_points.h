// Depth pixels as 3D points in the camera's frame (OpenCV convention, docs/observation-format.md),
// and the sensor noise that decides what counts as "the same surface": a depth z is
// uncertain by sigma(z) = sigma0 + per_m2 z^2 (structured light and time of flight alike), so
// every tolerance of the segmentation grows with the square of the depth.
#pragma once
#include <Eigen/Core>
#include <vector>

#include "models/observation/depth_png.h"
#include "models/recording/depth_recording.h"

namespace ssc {

struct SensorNoise {
  double sigma0 = 0.0012;  // m
  double per_m2 = 0.0019;  // 1/m
  double sigma(double z) const { return sigma0 + per_m2 * z * z; }
};

// The band around a surface within which a measured point lies on it: 3 sigma and one depth unit.
inline double noise_band(const SensorNoise& noise, double z, double depth_scale) {
  return 3 * noise.sigma(z) + depth_scale;
}

// Largest depth difference between two neighbouring pixels of one surface: a surface seen at up
// to 80 degrees from face-on (beyond it a sensor's readings are not to be trusted), or 5 sigma.
double neighbour_jump_limit(const SensorNoise& noise, double z, double fx, double depth_scale);

inline Eigen::Vector3d back_project(const DepthIntrinsics& k, int u, int v, double z) {
  return {(u - k.cx) / k.fx * z, (v - k.cy) / k.fy * z, z};
}

struct PixelPoints {
  std::vector<Eigen::Vector3d> points;  // camera frame, metres
  std::vector<int> pixels;              // v * width + u
};

// Every `stride`-th pixel (in u and v) with depth > 0 and, if mask is given, mask[pixel] != 0.
PixelPoints pixel_points(const DepthImage& image, const DepthIntrinsics& k, const std::vector<char>* mask = nullptr,
                         int stride = 1);

}  // namespace ssc
