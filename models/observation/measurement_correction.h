// A correction of how a recording was measured, as `ssc diagnose` fits it when the physics
// may be right and the measurement wrong: the cameras' focal lengths, the depth unit, and
// the clock of the frames. Each is one number; 1, 1 and 0 change nothing.
//
// A point seen at pixel (u, v) with recorded depth z lies, in the camera's frame, at
//   (k z (u - cx) / (s fx), k z (v - cy) / (s fy), k z)
// with s = focal_scale and k = depth_scale: the true focal lengths are s times the recorded
// ones (the principal point is kept) and the true depths k times the recorded ones. Frame f
// was taken at time frame_time(f) + time_offset.
#pragma once
#include "models/observation/observation_set.h"

namespace ssc {

struct MeasurementCorrection {
  double focal_scale = 1;  // true focal lengths / recorded
  double depth_scale = 1;  // true depths / recorded
  double time_offset = 0;  // seconds added to every frame's time
};

// The set as it would have been recorded with the corrected cameras and clock.
ObservationSet corrected(const ObservationSet& set, const MeasurementCorrection& m);

}  // namespace ssc
