// `ssc prepare` on synthetic raw recordings (tests/synthetic_recording.h): a bunny thrown onto
// a table, simulated by ssc, rendered with the room, clutter and a sensor model. Checks the
// pose (5 mm, 2 degrees), the planes (1 degree, 3 mm) and the initial velocity (10 %) against
// the truth, in the camera's frame (the only frame the two share).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <filesystem>

#include "models/io/run_record.h"
#include "models/recording/prepare.h"
#include "runtime/errors.h"
#include "tests/synthetic_recording.h"

namespace fs = std::filesystem;

namespace ssc {
namespace {

const double kDeg = M_PI / 180;

struct PreparedSynthetic {
  SyntheticRecording truth;
  PreparedRecording prepared;
  SyntheticRecordingSpec spec;
};

std::string scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("ssc-prepare-" + std::to_string(getpid()) + "-" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

PreparedSynthetic prepare_synthetic(const std::string& name, const SyntheticRecordingSpec& spec) {
  PreparedSynthetic s;
  s.spec = spec;
  s.truth = make_synthetic_recording(scratch(name), spec);
  PrepareOptions o;
  o.recording_folder = s.truth.folder;
  if (spec.layout == "tum") {  // TUM has timestamps, but no intrinsics file
    const DepthCamera& c = s.truth.camera;
    o.recording.intrinsics = fmt::format("{},{},{},{}", c.fx, c.fy, c.cx, c.cy);
  } else {
    o.recording.fps = spec.fps;
  }
  o.mesh = s.truth.scan;
  o.density = spec.density;
  o.noise = SensorNoise{spec.sensor.sigma0, spec.sensor.per_m2};
  o.resolution = spec.resolution;
  clear_warnings();
  s.prepared = prepare_recording(o);
  return s;
}

// A plane of the truth's world frame (n . x = h) in the truth camera's frame.
Plane truth_plane_in_camera(const DepthCamera& cam, const Eigen::Vector3d& n, double h) {
  const Eigen::Matrix3d R = cam.camera_to_world.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = cam.camera_to_world.topRightCorner<3, 1>();
  Plane p;
  p.normal = R.transpose() * n;  // n . (R x_c + t) = h  ->  (R^T n) . x_c = h - n . t
  p.offset = h - n.dot(t);
  if (p.offset > 0) p.normal = -p.normal, p.offset = -p.offset;  // towards the camera, as detected planes
  return p;
}

void check_pose_planes_velocity(const PreparedSynthetic& s) {
  const PreparedRecording& p = s.prepared;
  const DepthCamera& cam = s.truth.camera;
  const Eigen::Matrix4d truth_w2c = cam.camera_to_world.inverse();
  const Eigen::Matrix4d est_w2c = p.camera_to_world.inverse();
  // Pose of the scan in the camera frame: truth from the scene's placement, estimate from prepare.
  Transform placement;
  placement.position = s.spec.position;
  placement.rotation_deg = s.spec.rotation_deg;
  const Eigen::Matrix3d truth_R = truth_w2c.topLeftCorner<3, 3>() * placement.rotation();
  const Eigen::Vector3d truth_c = truth_w2c.topLeftCorner<3, 3>() * placement.apply(p.scan.centroid) + truth_w2c.topRightCorner<3, 1>();
  ASSERT_TRUE(p.poses[0].has_value());
  const Eigen::Matrix3d est_R = est_w2c.topLeftCorner<3, 3>() * p.poses[0]->rotation;
  const Eigen::Vector3d est_c = est_w2c.topLeftCorner<3, 3>() * p.poses[0]->apply(p.scan.centroid) + est_w2c.topRightCorner<3, 1>();
  const double position_error = (est_c - truth_c).norm(), angle_error = rotation_angle(est_R, truth_R);
  std::printf("pose: %.2f mm, %.2f deg (icp rms %.2f mm, %d points)\n", 1000 * position_error, angle_error / kDeg,
              1000 * p.first_registration.icp.rms, p.first_registration.icp.matched);
  EXPECT_LT(position_error, 0.005);
  EXPECT_LT(angle_error, 2 * kDeg);

  // Planes: the table top, the floor if in view, the back wall.
  struct Truth { const char* name; Eigen::Vector3d n; double h; bool required; };
  for (const Truth& t : {Truth{"table", {0, 1, 0}, 0.0, true}, Truth{"wall", {0, 0, 1}, s.truth.wall_z, true},
                         Truth{"floor", {0, 1, 0}, s.truth.floor_height, false}}) {
    const Plane tp = truth_plane_in_camera(cam, t.n, t.h);
    const PreparedPlane* match = nullptr;
    for (const PreparedPlane& pp : p.planes)
      if (std::acos(std::min(1.0, pp.camera.normal.dot(tp.normal))) < 5 * kDeg && std::abs(pp.camera.offset - tp.offset) < 0.05)
        match = &pp;
    if (!match) {
      EXPECT_FALSE(t.required) << "no plane found for the " << t.name;
      continue;
    }
    const double angle = std::acos(std::min(1.0, match->camera.normal.dot(tp.normal)));
    std::printf("%s: %.3f deg, %.2f mm, %zu inliers, support %d, contact %d\n", t.name, angle / kDeg,
                1000 * std::abs(match->camera.offset - tp.offset), match->pixels.size(), match->support, match->contact);
    EXPECT_LT(angle, 1 * kDeg) << t.name;
    EXPECT_LT(std::abs(match->camera.offset - tp.offset), 0.003) << t.name;
    if (std::string(t.name) == "table") {
      EXPECT_TRUE(match->support && match->contact);
    }
  }
  // Up: the truth's y in the camera frame.
  const Eigen::Vector3d truth_up = truth_w2c.topLeftCorner<3, 3>() * Eigen::Vector3d::UnitY();
  EXPECT_LT(std::acos(std::min(1.0, p.up_camera.dot(truth_up))), 1 * kDeg);

  // Initial velocity, in the camera frame.
  const Eigen::Vector3d truth_v = truth_w2c.topLeftCorner<3, 3>() * s.spec.velocity;
  const Eigen::Vector3d est_v = est_w2c.topLeftCorner<3, 3>() * p.velocity.linear;
  const Eigen::Vector3d truth_w = truth_w2c.topLeftCorner<3, 3>() * s.spec.angular_velocity;
  const Eigen::Vector3d est_w = est_w2c.topLeftCorner<3, 3>() * p.velocity.angular;
  std::printf("velocity: %.1f %% of %.3f m/s from %d frames; angular %.1f %% of %.2f rad/s\n",
              100 * (est_v - truth_v).norm() / truth_v.norm(), truth_v.norm(), p.velocity.frames,
              100 * (est_w - truth_w).norm() / truth_w.norm(), truth_w.norm());
  EXPECT_LT((est_v - truth_v).norm(), 0.1 * truth_v.norm());
  EXPECT_GE(p.velocity.frames, 3);
  // Every frame found the object.
  for (size_t f = 0; f < p.object_pixels.size(); ++f) EXPECT_GT(p.object_pixels[f], 100) << "frame " << f;
}

TEST(PrepareSynthetic, Open3dRecordingGivesPosePlanesAndVelocity) {
  SyntheticRecordingSpec spec;
  spec.hand = true;  // a moving part of the object's size at the border must not be taken for it
  const PreparedSynthetic s = prepare_synthetic("open3d", spec);
  check_pose_planes_velocity(s);
  // The observations keep the object only: none of the clutter, no table.
  const ObservationSet& obs = s.prepared.observations;
  EXPECT_EQ(obs.frame_count, s.spec.frames);
  for (int f = 0; f < obs.frame_count; ++f)
    for (const Eigen::Vector3d& x : observed_points(obs, f)) {
      const Eigen::Vector3d local = s.prepared.poses[std::size_t(f)]->rotation.transpose() *
                                    (x - s.prepared.poses[std::size_t(f)]->translation);
      double d2 = 0;
      s.prepared.scan.index->nearest(local, &d2);
      EXPECT_LT(std::sqrt(d2), 0.03) << "frame " << f << ": an observed point 3 cm off the tracked scan";
    }
}

TEST(PrepareSynthetic, TumRecordingWithJitteryTimestamps) {
  SyntheticRecordingSpec spec;
  spec.layout = "tum";
  spec.clutter = false;
  spec.eye = Eigen::Vector3d(-0.2, 0.55, 0.9);
  const PreparedSynthetic s = prepare_synthetic("tum", spec);
  check_pose_planes_velocity(s);
  EXPECT_EQ(s.prepared.timing.frame_index.back(), spec.frames - 1);
  EXPECT_NEAR(s.prepared.timing.frame_dt, 1.0 / 30, 0.0005);
}

}  // namespace
}  // namespace ssc

namespace ssc {
namespace {

// A real Kinect frame (tests/data/tum_desk_frame, TUM RGB-D via Open3D's test data): an office
// desk with objects on it, two chairs, the floor. The scan is a 0.15 m cube for the foam dice
// on the desk, picked by its pixel. Checks the TUM reader, the planes and the segmentation on
// real depth: the desk and the floor are level planes about a desk's height apart, the dice is
// found on the desk and registered resting on it.
TEST(PrepareRealRecording, TumDeskFrame) {
  const std::string dir = scratch("tum-desk");
  const std::string cube = dir + "/dice.obj";
  {
    std::ofstream f(cube);
    for (int i = 0; i < 8; ++i)
      f << "v " << ((i & 1) ? 0.5 : -0.5) << " " << ((i & 2) ? 0.5 : -0.5) << " " << ((i & 4) ? 0.5 : -0.5) << "\n";
    f << "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
  }
  PrepareOptions o;
  o.recording_folder = std::string(SSC_TEST_DATA_DIR) + "/tum_desk_frame";
  o.recording.intrinsics = "525,525,319.5,239.5";
  o.mesh = cube;
  o.scan_scale = 0.15;
  o.density = 100;
  o.pick = Eigen::Vector2d(147, 222);
  clear_warnings();
  const PreparedRecording p = prepare_recording(o);
  EXPECT_EQ(p.recording.format, "tum");
  EXPECT_DOUBLE_EQ(p.recording.depth_scale, 1.0 / 5000);
  ASSERT_EQ(p.recording.frames.size(), 1u);
  const PreparedPlane* desk = nullptr;
  const PreparedPlane* floor = nullptr;
  for (const PreparedPlane& plane : p.planes) {
    if (plane.support) desk = &plane;
    else if (plane.normal.y() > 0.99 && plane.height < -0.3 && !floor) floor = &plane;
  }
  ASSERT_NE(desk, nullptr);
  ASSERT_NE(floor, nullptr) << "no floor found";
  const double tilt = std::acos(std::min(1.0, std::abs(desk->normal.dot(floor->normal)))) / kDeg;
  std::printf("desk %.3f m above the floor, %.2f deg from parallel; dice: %d pixels, centre %.3f m above the desk, icp "
              "rms %.1f mm\n", desk->height - floor->height, tilt, p.object_pixels[0],
              desk->normal.dot(p.poses[0]->apply(p.scan.centroid)) - desk->height, 1000 * p.icp_rms[0]);
  EXPECT_NEAR(desk->height - floor->height, 0.72, 0.05) << "an office desk's height";
  EXPECT_LT(tilt, 3.0);
  EXPECT_GT(p.object_pixels[0], 1000);
  EXPECT_LT(p.object_pixels[0], 3000);
  // The dice rests on the desk: its centre half its size above it (a few mm of Kinect noise and scan size).
  EXPECT_NEAR(desk->normal.dot(p.poses[0]->apply(p.scan.centroid)) - desk->height, 0.075, 0.015);
  EXPECT_LT(p.icp_rms[0], 0.012);
  // Without --pick the desk's other objects of the dice's size are candidates too.
  o.pick.reset();
  try {
    prepare_recording(o);
    ADD_FAILURE() << "several candidates expected";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("several candidates"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ssc

namespace ssc {
namespace {

// Data made by another code than ssc's physics: the CalculiX drop of tests/data/calculix_drops
// (a 0.2 m cube, E = 50 kPa, dropped onto a frictionless 20 degree incline, ccx 2.20), its
// surface frames rendered as a raw Open3D recording at 60 frames per second with the incline,
// a back wall, a clutter box and the sensor model. The incline is the support, tilted: up comes
// from the accelerometer (--gravity). Checks the incline's angle and offset, the cube's
// position (a cube's pose is known up to its 24 symmetries: the nearest is compared) and the
// initial velocity from the frames before it lands.
TEST(PrepareSynthetic, CalculixDropOntoAnIncline) {
  namespace fs = std::filesystem;
  const std::string data = std::string(SSC_TEST_DATA_DIR) + "/calculix_drops/clean";
  const fs::path dir = scratch("calculix");
  const fs::path rec = dir / "recording";
  fs::create_directories(rec / "depth");
  DepthCamera cam = make_look_at_camera("ccx", 320, 240, 45, {0.55, 0.55, 1.1}, {0.2, 0.05, 0}, Eigen::Vector3d::UnitY());
  cam.min_depth = 0.2, cam.max_depth = 8;
  const double polar = 20 * kDeg;
  const Eigen::Vector3d n(std::sin(polar), std::cos(polar), 0);  // the incline through the origin
  const Eigen::Vector3d downhill = Eigen::Vector3d(std::cos(polar), -std::sin(polar), 0);
  TriangleSoup room;
  room.add_rectangle(-1.5 * downhill + Eigen::Vector3d(0, 0, -0.8), 3 * downhill, {0, 0, 1.6});
  room.add_rectangle({-3, -2, -1.0}, {6, 0, 0}, {0, 4, 0});  // a back wall
  room.add_box(Eigen::Vector3d(-0.3, 0, -0.45) + 0.06 * n, {0.06, 0.06, 0.06});  // clutter on the incline
  const double k[9] = {cam.fx, 0, 0, 0, cam.fy, 0, cam.cx, cam.cy, 1};
  std::ofstream(rec / "intrinsic.json")
      << nlohmann::json{{"width", 320}, {"height", 240}, {"intrinsic_matrix", std::vector<double>(k, k + 9)}}.dump();
  DepthSensorModel sensor;
  for (int f = 0; f < 13; ++f) {
    const TriangleMesh body = load_mesh(data + fmt::format("/frames/frame_{:04d}.ply", f));
    std::vector<std::array<int, 3>> tris;
    for (const Eigen::Vector3i& t : body.faces) tris.push_back({t.x(), t.y(), t.z()});
    TriangleSoup frame = room;
    frame.append(body.vertices, tris);
    const DepthImage exact = render_depth(cam, TriangleBvh(frame.vertices, frame.triangles), 0, 0);
    write_depth_png((rec / fmt::format("depth/{:06d}.png", f)).string(), apply_sensor_model(exact, cam, sensor, 77 + f),
                    0.001);
  }
  const fs::path cube = dir / "cube.obj";
  {
    std::ofstream c(cube);
    for (int i = 0; i < 8; ++i) c << "v " << ((i & 1) ? 0.1 : -0.1) << " " << ((i & 2) ? 0.1 : -0.1) << " " << ((i & 4) ? 0.1 : -0.1) << "\n";
    c << "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
  }
  PrepareOptions o;
  o.recording_folder = rec.string();
  o.recording.fps = 60;
  o.mesh = cube.string();
  o.density = 500;
  o.noise = SensorNoise{sensor.sigma0, sensor.per_m2};
  const Eigen::Matrix3d c2w = cam.camera_to_world.topLeftCorner<3, 3>();
  o.gravity = c2w.transpose() * Eigen::Vector3d(0, 9.81, 0);  // the accelerometer at rest reads "up"
  clear_warnings();
  const PreparedRecording p = prepare_recording(o);
  // The incline in the truth's frame: the prepared support plane's normal and offset mapped back.
  const Eigen::Matrix4d truth_w2c = cam.camera_to_world.inverse();
  const Plane truth = truth_plane_in_camera(cam, n, 0.0);
  const PreparedPlane* support = nullptr;
  for (const PreparedPlane& plane : p.planes)
    if (plane.support) support = &plane;
  ASSERT_NE(support, nullptr);
  const double angle = std::acos(std::min(1.0, support->camera.normal.dot(truth.normal))) / kDeg;
  const double tilt = std::acos(std::min(1.0, support->normal.y())) / kDeg;
  // The cube's centre: the truth is frame 0's body (the ccx mesh's vertex centroid, a cube's centre).
  const TriangleMesh first = load_mesh(data + "/frames/frame_0000.ply");
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& v : first.vertices) centre += v;
  centre /= double(first.vertices.size());
  const Eigen::Matrix4d est_w2c = p.camera_to_world.inverse();
  const Eigen::Vector3d truth_c = truth_w2c.topLeftCorner<3, 3>() * centre + truth_w2c.topRightCorner<3, 1>();
  const Eigen::Vector3d est_c = est_w2c.topLeftCorner<3, 3>() * p.poses[0]->apply(p.scan.centroid) + est_w2c.topRightCorner<3, 1>();
  const Eigen::Vector3d truth_v = truth_w2c.topLeftCorner<3, 3>() * Eigen::Vector3d(0.3, -1.5, 0);
  const Eigen::Vector3d est_v = est_w2c.topLeftCorner<3, 3>() * p.velocity.linear;
  std::printf("incline: %.3f deg from the truth, %.2f deg from level (truth 20), %.2f mm; cube centre %.2f mm; velocity "
              "%.1f %% of %.2f m/s from %d frames\n", angle, tilt, 1000 * std::abs(support->camera.offset - truth.offset),
              1000 * (est_c - truth_c).norm(), 100 * (est_v - truth_v).norm() / truth_v.norm(), truth_v.norm(),
              p.velocity.frames);
  EXPECT_LT(angle, 1.0);
  EXPECT_NEAR(tilt, 20.0, 1.0);
  EXPECT_LT(std::abs(support->camera.offset - truth.offset), 0.003);
  EXPECT_LT((est_c - truth_c).norm(), 0.005);
  EXPECT_LT((est_v - truth_v).norm(), 0.1 * truth_v.norm());
  EXPECT_GE(p.velocity.frames, 2);
  for (size_t f = 0; f < p.object_pixels.size(); ++f) EXPECT_GT(p.object_pixels[f], 300) << "frame " << f;
}

}  // namespace
}  // namespace ssc
