// The pictures a user checks a prepared recording with, at a glance: frame 0's depth (grey,
// near is bright), the planes found (each its colour; contact planes bright, others dim),
// the object's mask in the first, a middle and the last frame (red over the depth; what was
// removed as plane (blue), static background (dark) or depth edge (magenta); other candidate
// parts yellow), and the posed scan drawn over the depth (green dots) in the
// first, a middle and the last frame.
#pragma once
#include <string>
#include <vector>

#include "models/io/rgb_png.h"
#include "models/recording/prepare.h"

namespace ssc {

RgbImage depth_picture(const DepthImage& depth);
RgbImage planes_picture(const PreparedRecording& p);
RgbImage object_picture(const PreparedRecording& p, int frame);
RgbImage pose_picture(const PreparedRecording& p, int frame);

// Writes frame0_depth.png, frame0_planes.png, frame0_object.png, middle_object.png,
// last_object.png (the masks of the first, a middle and the last frame) and pose_first.png,
// pose_middle.png, pose_last.png into `folder`; returns their names.
std::vector<std::string> write_prepare_pictures(const std::string& folder, const PreparedRecording& p);

}  // namespace ssc
