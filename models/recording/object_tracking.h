// Following the object from frame 1 on: each frame is segmented like the first, the part
// nearest to where the object should be (constant acceleration under gravity from the last two
// poses) is the object, with every part close to it (ears, a handle, a side seen past an edge
// are parts of their own); the scan follows by ICP from the predicted pose, and is registered
// afresh (registration.h) where ICP loses it, e.g. at a bounce that turns the motion round
// within a frame. A frame without such a part is empty (warning object_lost).
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

#include "models/recording/prepare.h"

namespace ssc {

// The world points of the masked pixels of `image`.
std::vector<Eigen::Vector3d> object_points_world(const DepthImage& image, const DepthIntrinsics& k,
                                                 const std::vector<char>& mask, const Eigen::Matrix4d& camera_to_world);

// Fills p.object_masks, object_pixels, poses, icp_rms and the middle and last frames'
// picture_classes for frames 1..N-1; frame 0 must be set. huber: the ICP's noise scale (m).
void track_object(PreparedRecording& p, const SegmentationContext& context, int min_pixels, double huber,
                  const std::string& where);

}  // namespace ssc
