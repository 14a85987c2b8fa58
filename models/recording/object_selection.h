// Which connected part of the first frame is the object: the one whose size matches the
// scan's. A part seen from one side spans between 0.3 and 1.3 times the scan's largest
// extent. Parts at the image border (a hand, clutter cut by the frame) give way to a part
// inside the image; what stays ambiguous is an error that lists the parts and asks for --pick.
// A part that would match a scan a thousand times smaller (or larger) is the error "the scan
// is in millimetres" (or the depth scale is off).
#pragma once
#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "models/recording/segmentation.h"

namespace ssc {

bool size_matches_scan(double part_extent, double scan_extent);

// Index into parts; InputError for none or several. scan_extent in metres (scaled).
int select_object_part(const std::vector<DepthComponent>& parts, double scan_extent, double scan_scale,
                       const std::optional<Eigen::Vector2d>& pick, const std::string& where);

}  // namespace ssc
