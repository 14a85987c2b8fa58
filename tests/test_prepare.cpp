// `ssc prepare` on synthetic raw recordings (tests/synthetic_recording.h): a bunny thrown onto
// a table, simulated by ssc, rendered with the room, clutter and a sensor model. Checks the
// pose (5 mm, 2 degrees), the planes (1 degree, 3 mm) and the initial velocity (10 %) against
// the truth, in the camera's frame (the only frame the two share).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <filesystem>
#include <fstream>

#include "models/io/run_record.h"
#include "models/recording/prepare.h"
#include "runtime/errors.h"
#include "tests/calculix_recording.h"
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

// A box scan centred on its origin (an OBJ of 8 vertices and 6 faces), half extents in the scan's units.
std::string write_box_obj(const std::string& path, double hx, double hy, double hz) {
  std::ofstream f(path);
  for (int i = 0; i < 8; ++i)
    f << "v " << ((i & 1) ? hx : -hx) << " " << ((i & 2) ? hy : -hy) << " " << ((i & 4) ? hz : -hz) << "\n";
  f << "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
  return path;
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
  for (const Warning& w : warnings()) EXPECT_NE(w.code, "camera_moving") << w.message;
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
  const std::string cube = write_box_obj(dir + "/dice.obj", 0.5, 0.5, 0.5);
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

// Open3D's camera poses (trajectory.log: per frame a line "i i n" and a 4x4 camera-to-world matrix).
std::vector<Eigen::Matrix4d> read_open3d_trajectory(const std::string& file) {
  std::ifstream in(file);
  std::vector<Eigen::Matrix4d> poses;
  int a, b, c;
  while (in >> a >> b >> c) {
    Eigen::Matrix4d m;
    for (int i = 0; i < 16; ++i) in >> m(i / 4, i % 4);
    poses.push_back(m);
  }
  return poses;
}

// Five consecutive frames of Open3D's RGB-D sample (tests/data/livingroom_frames: Redwood's
// "living room 1", 640x480, millimetres, a handheld camera rising 2.4 cm a frame) and the camera
// poses Open3D keeps with them. No object of ours is in it, and the camera moves, so prepare's
// static-background test and the registration do not apply (prepare assumes a camera at rest):
// this checks the reader, the plane search and the segmentation frame by frame, against what the
// poses say. The largest planes are the back wall (vertical) and the floor (level), and the floor
// found in every frame is one plane of the room (the same height to 1 cm while the camera rises
// 9.8 cm). The rocking chair in front of the camera (seen in frame 0's depth image: back, seat
// and rockers at u 340..610, v 110..380) is not one part: its flat back is taken for a plane of
// the room (it is 5 % of the view), its rockers are thin; its seat (around pixel (466, 261)) is a
// part of a seat's size and height above the floor, found at the same place of the room in every
// frame (to 2 cm).
TEST(PrepareRealRecording, LivingRoomFramesFloorWallAndChairSeat) {
  const std::string folder = std::string(SSC_TEST_DATA_DIR) + "/livingroom_frames";
  RecordingOptions options;
  options.fps = 30;
  const DepthRecording rec = read_recording(folder, options);
  EXPECT_EQ(rec.format, "open3d");
  ASSERT_EQ(rec.frames.size(), 5u);
  EXPECT_EQ(rec.intrinsics.width, 640);
  EXPECT_EQ(rec.intrinsics.height, 480);
  EXPECT_DOUBLE_EQ(rec.intrinsics.fx, 525);
  EXPECT_DOUBLE_EQ(rec.intrinsics.cy, 239.5);
  EXPECT_DOUBLE_EQ(rec.depth_scale, 0.001);
  EXPECT_NEAR(rec.timestamps.back(), 4.0 / 30, 1e-12);
  const std::vector<Eigen::Matrix4d> poses = read_open3d_trajectory(folder + "/trajectory.log");
  ASSERT_EQ(poses.size(), 5u);
  const SensorNoise noise;
  std::vector<double> floor_heights;
  std::vector<Eigen::Vector3d> seat_centres;
  for (size_t f = 0; f < rec.frames.size(); ++f) {
    const DepthImage& frame = rec.frames[f];
    const Eigen::Matrix3d R = poses[f].topLeftCorner<3, 3>();
    const Eigen::Vector3d t = poses[f].topRightCorner<3, 1>();
    const ImagePlanes found = find_image_planes(frame, rec.intrinsics, noise, rec.depth_scale);
    // The floor: the plane whose normal is the room's up (its y, in the poses' frame).
    const DetectedPlane* floor = nullptr;
    for (const DetectedPlane& d : found.planes)
      if (std::abs((R * d.plane.normal).y()) > std::cos(5 * kDeg) && !floor) floor = &d;
    ASSERT_NE(floor, nullptr) << "frame " << f;
    const Eigen::Vector3d up = R * floor->plane.normal;  // towards the camera, which is above the floor
    const double floor_height = floor->plane.offset + up.dot(t);  // up . x = height, world
    floor_heights.push_back(floor_height * (up.y() > 0 ? 1 : -1));
    const double tilt = std::acos(std::min(1.0, std::abs(up.y()))) / kDeg;
    // The two largest planes: the floor and the back wall (which of them has more points changes as the camera rises).
    ASSERT_GE(found.planes.size(), 2u);
    const DetectedPlane& wall = floor == &found.planes[0] ? found.planes[1] : found.planes[0];
    const double wall_tilt = std::asin(std::min(1.0, std::abs((R * wall.plane.normal).y()))) / kDeg;
    // Segmentation: the planes removed, then the connected parts.
    SegmentationContext context;
    context.intrinsics = rec.intrinsics;
    context.noise = noise;
    context.depth_scale = rec.depth_scale;
    for (const DetectedPlane& d : found.planes) context.planes.push_back(d.plane);
    const std::vector<PixelClass> classes = classify_pixels(frame, context);
    const std::vector<DepthComponent> parts = depth_components(frame, classes, context, 200);
    // The seat: the part nearest to the seat's pixel, frame 0's seen in the depth image, the later
    // frames' where the poses put frame 0's seat.
    Eigen::Vector2d pick(466, 261);
    if (f > 0) {
      const Eigen::Vector3d c = R.transpose() * (seat_centres[0] - t);
      pick = Eigen::Vector2d(rec.intrinsics.fx * c.x() / c.z() + rec.intrinsics.cx,
                             rec.intrinsics.fy * c.y() / c.z() + rec.intrinsics.cy);
    }
    const DepthComponent* seat = nullptr;
    for (const DepthComponent& part : parts)
      if (!seat || (part.pixel_centroid - pick).norm() < (seat->pixel_centroid - pick).norm()) seat = &part;
    ASSERT_NE(seat, nullptr) << "frame " << f;
    seat_centres.push_back(R * seat->centroid + t);
    const double seat_height = floor->plane.distance(seat->centroid);
    std::printf("frame %zu: %zu planes, the wall %.2f deg from vertical; floor %d inliers of %zu points, %.2f deg "
                "from the room's level, at y = %.4f m, %.3f m below the camera; %zu parts; the seat: %zu pixels around "
                "(%.0f, %.0f), %.3f m across, %.3f m above the floor, at (%.3f, %.3f, %.3f) m\n",
                f, found.planes.size(), wall_tilt, int(floor->inliers.size()), found.points.points.size(), tilt,
                floor_heights.back(), -floor->plane.offset, parts.size(), seat->pixels.size(), seat->pixel_centroid.x(),
                seat->pixel_centroid.y(), seat->extent, seat_height, seat_centres.back().x(), seat_centres.back().y(),
                seat_centres.back().z());
    EXPECT_LT(tilt, 1.0) << "frame " << f;
    EXPECT_LT(wall_tilt, 3.0) << "frame " << f << ": the largest planes are the floor and a wall";
    EXPECT_TRUE(floor == &found.planes[0] || floor == &found.planes[1]) << "frame " << f;
    EXPECT_GT(floor->inliers.size(), found.points.points.size() / 5) << "frame " << f << ": the floor fills a fifth of the view";
    EXPECT_LT((seat->pixel_centroid - pick).norm(), 30) << "frame " << f;
    EXPECT_GT(seat->extent, 0.2) << "frame " << f;
    EXPECT_LT(seat->extent, 0.6) << "frame " << f;
    EXPECT_GT(seat_height, 0.25) << "frame " << f;
    EXPECT_LT(seat_height, 0.55) << "frame " << f;
  }
  // The camera rose by 9.8 cm; the floor and the seat stayed where they are.
  EXPECT_NEAR((poses[4].topRightCorner<3, 1>() - poses[0].topRightCorner<3, 1>()).norm(), 0.098, 0.002);
  for (size_t f = 1; f < floor_heights.size(); ++f) {
    EXPECT_NEAR(floor_heights[f], floor_heights[0], 0.01) << "frame " << f;
    EXPECT_LT((seat_centres[f] - seat_centres[0]).norm(), 0.02) << "frame " << f;
  }
  // prepare itself, given a box of the seat's size and the seat's pixel, says that the camera moves.
  const std::string box = scratch("livingroom") + "/box.obj";
  {
    std::ofstream b(box);
    for (int i = 0; i < 8; ++i)
      b << "v " << ((i & 1) ? 0.15 : -0.15) << " " << ((i & 2) ? 0.15 : -0.15) << " " << ((i & 4) ? 0.15 : -0.15) << "\n";
    b << "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
  }
  PrepareOptions o;
  o.recording_folder = folder;
  o.recording.fps = 30;
  o.mesh = box;
  o.density = 100;
  o.pick = Eigen::Vector2d(466, 261);
  clear_warnings();
  prepare_recording(o);
  bool moving = false;
  for (const Warning& w : warnings()) moving |= w.code == "camera_moving";
  EXPECT_TRUE(moving);
}

}  // namespace
}  // namespace ssc

namespace ssc {
namespace {

// Data made by another code than ssc's physics: the CalculiX drop of tests/calculix_recording.h
// (a 0.2 m cube dropped onto a 20 degree incline, rendered as a raw Open3D recording with a back
// wall, a clutter box and the sensor model). The incline is the support, tilted: up comes from
// the accelerometer (--gravity). Checks the incline's angle and offset, the cube's position (a
// cube's pose is known up to its 24 symmetries: its centre is compared) and the initial velocity
// from the frames before it lands.
TEST(PrepareSynthetic, CalculixDropOntoAnIncline) {
  const CalculixRecording r = make_calculix_recording(scratch("calculix"));
  const DepthCamera& cam = r.camera;
  const std::string& data = r.data;
  const Eigen::Vector3d& n = r.incline_normal;
  PrepareOptions o;
  o.recording_folder = r.folder;
  o.recording.fps = r.fps;
  o.mesh = r.scan;
  o.density = 500;
  o.noise = SensorNoise{r.sensor.sigma0, r.sensor.per_m2};
  o.gravity = r.gravity_camera;
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
  const Eigen::Vector3d truth_v = truth_w2c.topLeftCorner<3, 3>() * r.initial_velocity;
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

namespace ssc {
namespace {

// Three consecutive frames of a real structured-light camera (tests/data/pcl_floor_frames: PCL's
// ImageGrabber test sequence, 640x480, millimetres, about 4 frames a second as saved): a closed
// laptop standing on a carpet floor with a box lying beside it, the camera looking down at about
// 45 degrees and nearly still. Checks the TUM reader with real, uneven timestamps and a depth
// scale other than TUM's, and the plane search on real depth: the floor is the largest plane of
// every frame and nearly the same plane in all three (its fit turns by 0.4 degrees and moves by
// 3 mm from the first frame to the last: enough to change the far pixels' depth beyond the noise,
// so prepare warns camera_moving here), the box's top is a plane parallel to it, a box's height
// above it. Nothing else moves in these frames, so the object search and the registration are not
// tested here (prepare takes what does not move for the background).
TEST(PrepareRealRecording, PclFloorFramesFloorAndBoxTop) {
  RecordingOptions options;
  options.intrinsics = "525,525,320,240";  // the sequence's own xml files
  options.depth_scale = 0.001;
  const DepthRecording rec = read_recording(std::string(SSC_TEST_DATA_DIR) + "/pcl_floor_frames", options);
  EXPECT_EQ(rec.format, "tum");
  ASSERT_EQ(rec.frames.size(), 3u);
  EXPECT_NEAR(rec.timestamps[1] - rec.timestamps[0], 0.254471, 1e-6);
  EXPECT_NEAR(rec.timestamps[2] - rec.timestamps[1], 0.263712, 1e-6);
  const SensorNoise noise;
  std::vector<Plane> floors;
  for (size_t f = 0; f < rec.frames.size(); ++f) {
    const ImagePlanes found = find_image_planes(rec.frames[f], rec.intrinsics, noise, rec.depth_scale);
    ASSERT_GE(found.planes.size(), 2u) << "frame " << f;
    const Plane& floor = found.planes[0].plane;  // the largest
    const double pitch = std::acos(std::clamp(floor.normal.dot(Eigen::Vector3d(0, -1, 0)), -1.0, 1.0)) / kDeg;
    const double camera_height = -floor.offset;  // the camera, at the origin, above the floor (normal towards it)
    // The box's top: a smaller plane facing the same way, between the floor and the camera.
    const DetectedPlane* top = nullptr;
    for (size_t i = 1; i < found.planes.size() && !top; ++i)
      if (found.planes[i].plane.normal.dot(floor.normal) > std::cos(5 * kDeg)) top = &found.planes[i];
    ASSERT_NE(top, nullptr) << "frame " << f << ": no plane parallel to the floor";
    const double tilt = std::acos(std::min(1.0, top->plane.normal.dot(floor.normal))) / kDeg;
    const double above = top->plane.offset - floor.offset;
    std::printf("frame %zu: floor %.0f deg from the image's up, camera %.3f m above it (rms %.1f mm, %zu points); box "
                "top %.1f deg from parallel, %.3f m above the floor (%zu points)\n", f, pitch, camera_height,
                1000 * found.planes[0].rms, found.planes[0].inliers.size(), tilt, above, top->inliers.size());
    EXPECT_GT(pitch, 30) << "a camera looking down at the floor";
    EXPECT_LT(pitch, 60);
    EXPECT_GT(camera_height, 0.5);
    EXPECT_LT(camera_height, 1.2);
    EXPECT_LT(found.planes[0].rms, 0.006) << "a floor fitted to real Kinect-class depth at 0.7-1.7 m";
    EXPECT_LT(tilt, 5.0);
    EXPECT_GT(above, 0.06) << "a box lying on the floor";
    EXPECT_LT(above, 0.15);
    floors.push_back(floor);
  }
  for (size_t f = 1; f < floors.size(); ++f) {  // the camera nearly still: one floor
    EXPECT_LT(std::acos(std::min(1.0, floors[f].normal.dot(floors[0].normal))) / kDeg, 1.0) << "frame " << f;
    EXPECT_NEAR(floors[f].offset, floors[0].offset, 0.005) << "frame " << f;
  }
  // prepare without --gravity, picking the box (a scan of about its size): up is the floor's
  // normal although the camera looks down by more than 45 degrees, and the slight camera motion
  // is told.
  const std::string dir = scratch("pcl-floor");
  const std::string box = write_box_obj(dir + "/box.obj", 0.125, 0.06, 0.075);
  PrepareOptions o;
  o.recording_folder = std::string(SSC_TEST_DATA_DIR) + "/pcl_floor_frames";
  o.recording = options;
  o.mesh = box;
  o.density = 100;
  o.pick = Eigen::Vector2d(440, 240);
  clear_warnings();
  const PreparedRecording p = prepare_recording(o);
  EXPECT_TRUE(p.gravity_from_plane);
  EXPECT_LT(std::acos(std::min(1.0, p.up_camera.dot(floors[0].normal))) / kDeg, 1.0);
  bool moving = false;
  for (const Warning& w : warnings()) moving |= w.code == "camera_moving";
  EXPECT_TRUE(moving);
}

}  // namespace
}  // namespace ssc
