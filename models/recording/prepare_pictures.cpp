#include "models/recording/prepare_pictures.h"

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>

namespace ssc {

namespace {

using Colour = std::array<std::uint8_t, 3>;

Colour grey_of(double z, double lo, double hi) {
  if (!(z > 0)) return {0, 0, 40};  // no reading: dark blue
  const double s = hi > lo ? std::clamp((hi - z) / (hi - lo), 0.0, 1.0) : 1.0;
  const auto g = std::uint8_t(50 + 190 * s);
  return {g, g, g};
}

Colour tint(Colour base, Colour colour, double amount) {
  Colour out;
  for (int c = 0; c < 3; ++c) out[std::size_t(c)] = std::uint8_t((1 - amount) * base[std::size_t(c)] + amount * colour[std::size_t(c)]);
  return out;
}

const Colour kPlaneColours[] = {{230, 159, 0}, {86, 180, 233}, {0, 158, 115}, {240, 228, 66}, {0, 114, 178}, {213, 94, 0},
                                {204, 121, 167}, {150, 150, 255}};

}  // namespace

RgbImage depth_picture(const DepthImage& depth) {
  std::vector<double> valid;
  for (double z : depth.depth)
    if (z > 0) valid.push_back(z);
  std::sort(valid.begin(), valid.end());
  const double lo = valid.empty() ? 0 : valid[valid.size() / 50], hi = valid.empty() ? 1 : valid[valid.size() * 49 / 50];
  RgbImage img(depth.width, depth.height);
  for (int v = 0; v < depth.height; ++v)
    for (int u = 0; u < depth.width; ++u) img.set(u, v, grey_of(depth.at(u, v), lo, hi));
  return img;
}

RgbImage planes_picture(const PreparedRecording& p) {
  RgbImage img = depth_picture(p.recording.frames.front());
  for (size_t k = 0; k < p.planes.size(); ++k) {
    const Colour c = kPlaneColours[k % 8];
    const double amount = p.planes[k].contact ? 0.85 : 0.4;
    // The plane search ran on a thinned image: colour each inlier's block of pixels.
    const int w = p.recording.intrinsics.width;
    for (int i : p.planes[k].pixels) {
      const int u0 = i % w, v0 = i / w;
      for (int dv = 0; dv < p.plane_stride; ++dv)
        for (int du = 0; du < p.plane_stride; ++du) {
          const int u = u0 + du, v = v0 + dv;
          if (u >= img.width || v >= img.height) continue;
          const std::size_t j = (std::size_t(v) * img.width + u) * 3;
          img.set(u, v, tint({img.rgb[j], img.rgb[j + 1], img.rgb[j + 2]}, c, amount));
        }
    }
  }
  return img;
}

RgbImage object_picture(const PreparedRecording& p, int frame) {
  RgbImage img = depth_picture(p.recording.frames[std::size_t(frame)]);
  const int last = int(p.recording.frames.size()) - 1;
  const std::size_t which = frame == 0 ? 0 : (frame == last && p.picture_classes.size() > 2 ? 2 : 1);
  if (which >= p.picture_classes.size()) return img;
  const std::vector<PixelClass>& classes = p.picture_classes[which];
  for (size_t i = 0; i < classes.size(); ++i) {
    const int u = int(i) % img.width, v = int(i) / img.width;
    const std::size_t j = i * 3;
    const Colour base = {img.rgb[j], img.rgb[j + 1], img.rgb[j + 2]};
    if (p.object_masks[std::size_t(frame)][i]) img.set(u, v, {230, 30, 30});
    else if (classes[i] == PixelClass::Plane) img.set(u, v, tint(base, {0, 0, 160}, 0.35));
    else if (classes[i] == PixelClass::Static) img.set(u, v, tint(base, {0, 0, 0}, 0.5));
    else if (classes[i] == PixelClass::Edge) img.set(u, v, {255, 0, 255});
    else if (classes[i] == PixelClass::Candidate) img.set(u, v, tint(base, {255, 200, 0}, 0.6));
  }
  return img;
}

RgbImage pose_picture(const PreparedRecording& p, int frame) {
  RgbImage img = depth_picture(p.recording.frames[std::size_t(frame)]);
  for (size_t i = 0; i < p.object_masks[std::size_t(frame)].size(); ++i)
    if (p.object_masks[std::size_t(frame)][i]) {
      const std::size_t j = i * 3;
      img.set(int(i) % img.width, int(i) / img.width, tint({img.rgb[j], img.rgb[j + 1], img.rgb[j + 2]}, {230, 30, 30}, 0.5));
    }
  if (!p.poses[std::size_t(frame)]) return img;
  const Eigen::Matrix4d w2c = p.camera_to_world.inverse();
  const DepthIntrinsics& k = p.recording.intrinsics;
  for (size_t s = 0; s < p.scan.points.size(); ++s) {
    const Eigen::Vector3d x = w2c.topLeftCorner<3, 3>() * p.poses[std::size_t(frame)]->apply(p.scan.points[s]) +
                              w2c.topRightCorner<3, 1>();
    const Eigen::Vector3d n = w2c.topLeftCorner<3, 3>() * p.poses[std::size_t(frame)]->rotation * p.scan.normals[s];
    if (x.z() <= 0 || n.dot(x) >= 0) continue;  // only the side facing the camera
    img.set(int(std::lround(k.fx * x.x() / x.z() + k.cx)), int(std::lround(k.fy * x.y() / x.z() + k.cy)), {40, 230, 40});
  }
  return img;
}

std::vector<std::string> write_prepare_pictures(const std::string& folder, const PreparedRecording& p) {
  const int last = int(p.recording.frames.size()) - 1;
  const std::vector<std::pair<std::string, RgbImage>> pictures = {
      {"frame0_depth.png", depth_picture(p.recording.frames.front())},
      {"frame0_planes.png", planes_picture(p)},
      {"frame0_object.png", object_picture(p, 0)},
      {"middle_object.png", object_picture(p, last / 2)},
      {"last_object.png", object_picture(p, last)},
      {"pose_first.png", pose_picture(p, 0)},
      {"pose_middle.png", pose_picture(p, last / 2)},
      {"pose_last.png", pose_picture(p, last)}};
  std::vector<std::string> names;
  for (const auto& [name, image] : pictures) {
    write_rgb_png((std::filesystem::path(folder) / name).string(), image);
    names.push_back(name);
  }
  return names;
}

}  // namespace ssc
