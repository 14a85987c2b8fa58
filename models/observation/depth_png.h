// Depth images and their 16-bit PNG encoding. A depth image holds the camera z depth of
// every pixel in metres, 0 meaning "no measurement"; on disk it is a 16-bit single-channel
// grayscale PNG whose value k stands for k * depth_scale metres (the convention of common
// RGB-D cameras, e.g. depth_scale = 0.001 for millimetres). Reading and writing go through
// libpng with its setjmp/longjmp error handling confined to small functions that hold no
// C++ objects, so a corrupt or truncated file becomes an InputError, never a crash.
#pragma once
#include <string>
#include <vector>

namespace ssc {

struct DepthImage {
  int width = 0, height = 0;
  std::vector<double> depth;  // metres, 0 = no measurement, row-major: index v * width + u

  double at(int u, int v) const { return depth[std::size_t(v) * width + u]; }
};

// The depth each pixel will have after write_depth_png + read_depth_png:
// round(depth / depth_scale) * depth_scale. Depths that write_depth_png would reject
// (negative, NaN, above 65535 * depth_scale) are returned unchanged.
DepthImage quantize_depth(const DepthImage& image, double depth_scale);

// Writes `image` as a 16-bit grayscale PNG with value round(depth / depth_scale). Throws
// InputError (naming the path, the pixel and the fix) for a size mismatch, a non-positive
// depth_scale, or a depth that is negative, NaN, infinite or above 65535 * depth_scale.
// Depths below depth_scale / 2 become 0 (no measurement). The file is written to a
// temporary sibling first and renamed into place, so `path` is never half-written.
void write_depth_png(const std::string& path, const DepthImage& image, double depth_scale);

// Reads a 16-bit single-channel grayscale PNG (interlaced or not) into metres. Throws
// InputError naming the path and the problem for a missing or unreadable file, a file that
// is not a PNG, a truncated or corrupt PNG, and any other PNG type (8-bit, RGB, alpha, ...).
DepthImage read_depth_png(const std::string& path, double depth_scale);

}  // namespace ssc
