// Which depth pixels of a frame can be the object: not on a plane of the room (within the
// depth-dependent noise band), not static background (as deep as the farthest reading that
// pixel gives over the recording), not on a depth edge (flying pixels, the mixed readings a
// sensor gives between a foreground edge and the background behind it, and surfaces seen
// edge-on). What is left falls into connected parts (neighbouring pixels whose depths differ
// by less than one surface can); prepare picks the object among them by its size.
#pragma once
#include <Eigen/Core>
#include <vector>

#include "models/recording/depth_points.h"
#include "models/recording/depth_recording.h"
#include "models/recording/plane_fit.h"

namespace ssc {

struct SegmentationContext {
  DepthIntrinsics intrinsics;
  SensorNoise noise;
  double depth_scale = 0.001;
  std::vector<Plane> planes;         // camera frame
  std::vector<double> background;    // per pixel: the recording's far depth, or empty (no static test)
};

// Per pixel the depth behind anything that moves: the median of the readings within the noise
// of the second largest one (the largest may be a flying pixel), 0 where fewer than 3 frames
// read it or fewer than three quarters of its readings (or 2) agree. Empty for a recording of fewer than 3 frames.
std::vector<double> far_background(const std::vector<DepthImage>& frames, const SensorNoise& noise, double depth_scale);

// Pixels with a neighbour (8-neighbourhood) whose depth jumps by more than one surface can.
std::vector<char> depth_edges(const DepthImage& image, const DepthIntrinsics& k, const SensorNoise& noise,
                              double depth_scale);

enum class PixelClass : char { None = 0, Candidate, Plane, Static, Edge };

// Every pixel's class in this frame (None: no reading).
std::vector<PixelClass> classify_pixels(const DepthImage& image, const SegmentationContext& context);

struct DepthComponent {
  std::vector<int> pixels;               // v * width + u
  Eigen::Vector3d centroid{0, 0, 0};     // camera frame
  double extent = 0;                     // m, the largest spread along its principal axes (2nd..98th percentile)
  bool touches_border = false;           // a pixel in the image's outer 2 pixels
  Eigen::Vector2d pixel_centroid{0, 0};  // u, v
};

// Connected parts of the candidate pixels with at least min_pixels pixels, largest first.
std::vector<DepthComponent> depth_components(const DepthImage& image, const std::vector<PixelClass>& classes,
                                             const SegmentationContext& context, int min_pixels);

// The spread of points along their principal axes (robust: 2nd to 98th percentile), largest first.
Eigen::Vector3d principal_extents(const std::vector<Eigen::Vector3d>& points);

}  // namespace ssc
