// A depth sensor's imperfections, applied to an exact rendered depth image so that synthetic
// recordings look like real ones: axial noise growing with the square of the depth, no
// reading on surfaces seen at grazing incidence, random dropout, flying pixels (mixed readings
// between a foreground edge and the background behind it) and quantisation to the sensor's
// depth unit. Seeded: the same image, model and seed give the same result.
#pragma once
#include <cstdint>

#include "models/observation/camera.h"
#include "models/observation/depth_png.h"

namespace ssc {

struct DepthSensorModel {
  double sigma0 = 0.001;        // m: axial noise sigma(z) = sigma0 + per_m2 z^2
  double per_m2 = 0.0015;       // 1/m
  double grazing_deg = 78;      // no reading where the surface is seen more edge-on than this
  double dropout = 0.01;        // fraction of readings lost at random
  double flying = 0.5;          // fraction of the pixels beside a depth jump that read a mixed depth
  double jump = 0.05;           // m: a depth jump between neighbours this large is an edge
  double depth_unit = 0.001;    // m: readings are whole multiples of it
};

DepthImage apply_sensor_model(const DepthImage& exact, const DepthCamera& camera, const DepthSensorModel& model,
                              std::uint64_t seed);

}  // namespace ssc
