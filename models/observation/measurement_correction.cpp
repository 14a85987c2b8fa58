// The measurement correction of an observation set (see measurement_correction.h).
#include "models/observation/measurement_correction.h"

namespace ssc {

ObservationSet corrected(const ObservationSet& set, const MeasurementCorrection& m) {
  ObservationSet out = set;
  for (DepthCamera& cam : out.cameras) {
    cam.fx *= m.focal_scale;
    cam.fy *= m.focal_scale;
    cam.min_depth *= m.depth_scale;
    cam.max_depth *= m.depth_scale;
  }
  if (m.depth_scale != 1) {
    out.depth_scale *= m.depth_scale;
    for (std::vector<DepthImage>& frame : out.frames)
      for (DepthImage& image : frame)
        for (double& z : image.depth) z *= m.depth_scale;
  }
  out.first_frame_time += m.time_offset;
  for (double& t : out.frame_times) t += m.time_offset;
  return out;
}

}  // namespace ssc
