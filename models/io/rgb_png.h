// 8-bit RGB pictures as PNG files (for people to look at, e.g. prepare's segmentation and
// pose checks). Written to a temporary sibling and renamed, like the depth PNGs.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace ssc {

struct RgbImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  // row-major, 3 bytes per pixel

  RgbImage() = default;
  RgbImage(int w, int h) : width(w), height(h), rgb(std::size_t(w) * h * 3, 0) {}
  void set(int u, int v, std::array<std::uint8_t, 3> c) {
    if (u < 0 || v < 0 || u >= width || v >= height) return;
    const std::size_t i = (std::size_t(v) * width + u) * 3;
    rgb[i] = c[0], rgb[i + 1] = c[1], rgb[i + 2] = c[2];
  }
};

// InputError (naming the path and the system's reason) when it cannot be written.
void write_rgb_png(const std::string& path, const RgbImage& image);

}  // namespace ssc
