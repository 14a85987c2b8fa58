// Which way is up, which plane holds the object, which planes it can reach. Up is the
// accelerometer's reading at rest (it points away from the ground), or else the normal of the
// largest plane within 45 degrees of the image's up with the object above it (cameras are held
// about upright; warning gravity_from_plane). The support is the nearest plane within 30
// degrees of level below the object whose points reach under it; the world origin is the point
// of it under the object. A plane is a contact plane when it is the support, or when the tracked
// object comes within its size of it where the plane has points.
#pragma once
#include <Eigen/Core>
#include <optional>
#include <string>

#include "models/recording/prepare.h"

namespace ssc {

// Sets p.up_camera, gravity_magnitude, gravity_from_plane, camera_to_world, the support plane
// and every plane's world normal and height. `search_image` is the image the planes were found
// in (their pixels index it). InputError when no plane is under the object. Returns the support's index.
int set_world_frame(PreparedRecording& p, const DepthComponent& object, const DepthImage& search_image,
                    const std::optional<Eigen::Vector3d>& gravity, const std::string& where);

// Marks the contact planes (at most 8, the scene's limit) from the tracked poses, and turns every
// plane's world normal to the object's side.
void mark_contact_planes(PreparedRecording& p, const DepthImage& search_image);

}  // namespace ssc
