// The measurement correction (models/observation/measurement_correction.h): a focal-length
// scale s and a depth scale k move a pixel's point in its camera's frame to
// (k z (u - cx) / (s fx), k z (v - cy) / (s fy), k z), and a time offset shifts every frame's
// time. Expected values from the pinhole formula, not from the code under test.
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "models/observation/measurement_correction.h"
#include "models/observation/observation_set.h"

namespace ssc {
namespace {

ObservationSet one_pixel_set(bool with_times) {
  ObservationSet set;
  set.dt = 0.1;
  set.depth_scale = 1e-4;
  set.frame_count = 2;
  if (with_times) set.frame_times = {0.0, 0.1};
  DepthCamera cam = make_look_at_camera("cam", 8, 6, 50, {0.3, 0.8, 2.0}, {0, 0, 0}, {0, 1, 0});
  set.cameras = {cam};
  for (int f = 0; f < 2; ++f) {
    DepthImage image{8, 6, std::vector<double>(48, 0.0)};
    image.depth[size_t(2 * 8 + 6)] = 1.7;  // pixel (6, 2)
    set.frames.push_back({image});
  }
  return set;
}

TEST(MeasurementCorrection, FocalAndDepthScaleMoveThePointInItsCameraFrame) {
  const ObservationSet set = one_pixel_set(false);
  const DepthCamera& cam = set.cameras[0];
  const double s = 0.95, k = 1.02, z = 1.7;
  const ObservationSet fixed = corrected(set, {s, k, 0});
  const std::vector<Eigen::Vector3d> points = observed_points(fixed, 0);
  ASSERT_EQ(points.size(), 1u);
  const Eigen::Vector3d local(k * z * (6 - cam.cx) / (s * cam.fx), k * z * (2 - cam.cy) / (s * cam.fy), k * z);
  const Eigen::Vector3d expected =
      cam.camera_to_world.topLeftCorner<3, 3>() * local + cam.camera_to_world.topRightCorner<3, 1>();
  EXPECT_LT((points[0] - expected).norm(), 1e-12);
  // The depth range and the unit move with the depths, so that the corrected set is valid.
  EXPECT_DOUBLE_EQ(fixed.cameras[0].max_depth, k * cam.max_depth);
  EXPECT_DOUBLE_EQ(fixed.depth_scale, k * set.depth_scale);
  EXPECT_NO_THROW(validate_observations(fixed, "corrected"));
  // No correction changes nothing.
  EXPECT_LT((observed_points(corrected(set, {}), 0)[0] - observed_points(set, 0)[0]).norm(), 1e-15);
}

TEST(MeasurementCorrection, TimeOffsetShiftsEveryFramesTime) {
  for (bool with_times : {false, true}) {
    const ObservationSet fixed = corrected(one_pixel_set(with_times), {1, 1, 0.025});
    EXPECT_NEAR(frame_time(fixed, 0), 0.025, 1e-15) << with_times;
    EXPECT_NEAR(frame_time(fixed, 1), 0.125, 1e-15) << with_times;
  }
}

}  // namespace
}  // namespace ssc
