#include "models/recording/depth_points.h"

#include <algorithm>
#include <cmath>

namespace ssc {

double neighbour_jump_limit(const SensorNoise& noise, double z, double fx, double depth_scale) {
  const double footprint = z / fx;  // metres between two pixels at depth z
  return std::max(5.67 * footprint, 5 * noise.sigma(z) + 2 * depth_scale);  // tan(80 deg) = 5.67
}

PixelPoints pixel_points(const DepthImage& image, const DepthIntrinsics& k, const std::vector<char>* mask, int stride) {
  PixelPoints out;
  for (int v = 0; v < image.height; v += stride)
    for (int u = 0; u < image.width; u += stride) {
      const int i = v * image.width + u;
      const double z = image.depth[std::size_t(i)];
      if (!(z > 0) || (mask && !(*mask)[std::size_t(i)])) continue;
      out.points.push_back(back_project(k, u, v, z));
      out.pixels.push_back(i);
    }
  return out;
}

}  // namespace ssc
