// The geometry of `ssc prepare`: RANSAC planes with a depth-dependent band, the world frame,
// Euler angles, the kd-tree, ICP and the global registration of a scan, the velocity from
// poses, the segmentation of depth edges and the choice of the object.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

#include "models/geometry/mesh.h"
#include "models/geometry/transform.h"
#include "models/recording/motion_estimate.h"
#include "models/recording/nearest_points.h"
#include "models/recording/object_selection.h"
#include "models/recording/plane_fit.h"
#include "models/recording/registration.h"
#include "models/recording/scan_model.h"
#include "models/recording/segmentation.h"
#include "models/recording/world_frame.h"
#include "tests/expect_input_error.h"

namespace ssc {
namespace {

const double kDeg = M_PI / 180;

TEST(PlaneFit, FindsTwoNoisyPlanesAmongClutter) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0, 0.003);
  std::uniform_real_distribution<double> uni(-1, 1);
  std::vector<Eigen::Vector3d> pts;
  const Eigen::Vector3d n1 = Eigen::Vector3d(0, -1, -0.4).normalized();  // a floor seen from above, tilted
  const Eigen::Vector3d n2 = Eigen::Vector3d(0, 0, -1);                  // a wall facing the camera
  const double d1 = n1.dot(Eigen::Vector3d(0, 0.5, 2));
  Eigen::Vector3d a1 = n1.cross(Eigen::Vector3d::UnitX()).normalized(), b1 = n1.cross(a1);
  for (int i = 0; i < 6000; ++i) pts.push_back(d1 * n1 + uni(rng) * a1 + uni(rng) * b1 + noise(rng) * n1);
  for (int i = 0; i < 3000; ++i) pts.push_back(Eigen::Vector3d(uni(rng), uni(rng), 3) + noise(rng) * n2);
  for (int i = 0; i < 1500; ++i) pts.push_back(Eigen::Vector3d(uni(rng), uni(rng), 2 + uni(rng)));  // clutter
  const std::vector<double> band(pts.size(), 0.009);
  const std::vector<DetectedPlane> planes = find_planes(pts, band, Eigen::Vector3d::Zero());
  ASSERT_GE(planes.size(), 2u);
  EXPECT_LT(std::acos(std::abs(planes[0].plane.normal.dot(n1))), 0.2 * kDeg);
  EXPECT_LT(std::abs(std::abs(planes[0].plane.offset) - std::abs(d1)), 0.001);
  EXPECT_LT(std::acos(std::abs(planes[1].plane.normal.dot(n2))), 0.3 * kDeg);
  EXPECT_NEAR(std::abs(planes[1].plane.offset), 3.0, 0.001);
  for (const DetectedPlane& p : planes) EXPECT_GT(-p.plane.offset, 0) << "normal towards the camera (origin)";
  EXPECT_NEAR(planes[0].rms, 0.003, 0.0005);
}

TEST(WorldFrame, UpBecomesYAndTheOriginIsZero) {
  const Eigen::Vector3d up = Eigen::Vector3d(0.1, -0.9, -0.4).normalized();
  const Eigen::Vector3d origin(0.05, 0.3, 1.2);
  const Eigen::Matrix4d m = camera_to_world_from_up(up, origin);
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  EXPECT_NEAR((r * r.transpose() - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
  EXPECT_NEAR(r.determinant(), 1, 1e-12);
  EXPECT_NEAR((r * up - Eigen::Vector3d::UnitY()).norm(), 0, 1e-12);
  EXPECT_NEAR((r * origin + m.topRightCorner<3, 1>()).norm(), 0, 1e-12);
  EXPECT_NEAR((r * Eigen::Vector3d::UnitX()).z(), 0, 1e-12) << "world x follows the camera's x: the camera's x lies in the world's xy-plane";
  EXPECT_GT((r * Eigen::Vector3d::UnitX()).x(), 0);
}

TEST(WorldFrame, EulerAnglesRoundTripThroughTheScenesTransform) {
  for (const Eigen::Vector3d& deg : {Eigen::Vector3d(10, -35, 170), Eigen::Vector3d(-80, 20, 5), Eigen::Vector3d(0, 0, 0)}) {
    Transform t;
    t.rotation_deg = deg;
    const Eigen::Vector3d back = euler_xyz_degrees(t.rotation());
    Transform u;
    u.rotation_deg = back;
    EXPECT_NEAR((u.rotation() - t.rotation()).norm(), 0, 1e-12) << deg.transpose();
  }
}

TEST(ScanRegistration, KdTreeAgreesWithBruteForce) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> uni(-1, 1);
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 3000; ++i) pts.push_back({uni(rng), uni(rng), uni(rng)});
  const NearestPoints tree(pts);
  for (int q = 0; q < 200; ++q) {
    const Eigen::Vector3d x(uni(rng), uni(rng), uni(rng));
    int best = 0;
    for (size_t i = 1; i < pts.size(); ++i)
      if ((pts[i] - x).squaredNorm() < (pts[std::size_t(best)] - x).squaredNorm()) best = int(i);
    EXPECT_EQ(tree.nearest(x), best);
  }
}

// The bunny's camera-facing surface, posed, as a depth camera at the origin sees it.
struct BunnyView {
  ScanModel scan;
  RigidPose truth;
  std::vector<Eigen::Vector3d> observed;
  DepthImage depth;
  CameraView view;
};

BunnyView bunny_view(double noise_m) {
  BunnyView b;
  b.scan = make_scan_model(load_mesh(std::string(SSC_TEST_DATA_DIR) + "/bun_zipper_res3.ply"), 1.0);
  b.truth.rotation = (Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, 1, 0.2).normalized())).toRotationMatrix();
  b.truth.translation = Eigen::Vector3d(0.05, -0.02, 0.9);
  b.view.intrinsics = {200, 150, 250, 250, 99.5, 74.5};
  b.depth.width = 200, b.depth.height = 150;
  b.depth.depth.assign(200 * 150, 0.0);
  const ScanModel dense = make_scan_model(load_mesh(std::string(SSC_TEST_DATA_DIR) + "/bun_zipper_res3.ply"), 1.0, 60000, 11);
  std::mt19937_64 rng(2);
  std::normal_distribution<double> gauss(0, noise_m);
  // A z-buffer of the dense samples gives the visible surface.
  for (const Eigen::Vector3d& p : dense.points) {
    const Eigen::Vector3d x = b.truth.apply(p);
    const int u = int(std::lround(250 * x.x() / x.z() + 99.5)), v = int(std::lround(250 * x.y() / x.z() + 74.5));
    if (u < 0 || v < 0 || u >= 200 || v >= 150) continue;
    double& z = b.depth.depth[std::size_t(v * 200 + u)];
    if (z == 0 || x.z() < z) z = x.z();
  }
  for (int v = 0; v < 150; ++v)
    for (int u = 0; u < 200; ++u) {
      double& z = b.depth.depth[std::size_t(v * 200 + u)];
      if (z > 0) {
        z += gauss(rng);
        b.observed.push_back({(u - 99.5) / 250 * z, (v - 74.5) / 250 * z, z});
      }
    }
  b.view.depth = &b.depth;
  return b;
}

TEST(ScanRegistration, IcpRecoversASmallOffset) {
  const BunnyView b = bunny_view(0.0005);
  RigidPose start = b.truth;
  start.rotation = Eigen::AngleAxisd(4 * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix() * start.rotation;
  start.translation += Eigen::Vector3d(0.008, -0.005, 0.006);
  const IcpResult r = icp_point_to_plane(b.scan, b.observed, start, 0.05, 0.001, 60);
  const Eigen::Vector3d c_true = b.truth.apply(b.scan.centroid), c = r.pose.apply(b.scan.centroid);
  EXPECT_LT((c - c_true).norm(), 0.002);
  EXPECT_LT(rotation_angle(r.pose.rotation, b.truth.rotation), 1 * kDeg);
  EXPECT_LT(r.rms, 0.0025);
}

TEST(ScanRegistration, GlobalRegistrationNeedsNoStart) {
  const BunnyView b = bunny_view(0.001);
  const RegistrationResult r = register_scan(b.scan, b.observed, b.view, 0.002);
  EXPECT_EQ(r.hypotheses, 24);
  const Eigen::Vector3d c_true = b.truth.apply(b.scan.centroid), c = r.icp.pose.apply(b.scan.centroid);
  std::printf("global registration: %.2f mm, %.2f deg, rms %.2f mm, seen through %.3f\n", 1000 * (c - c_true).norm(),
              rotation_angle(r.icp.pose.rotation, b.truth.rotation) / kDeg, 1000 * r.icp.rms, r.seen_through);
  EXPECT_LT((c - c_true).norm(), 0.003);
  EXPECT_LT(rotation_angle(r.icp.pose.rotation, b.truth.rotation), 2 * kDeg);
}

TEST(MotionEstimate, VelocityOfAThrownSpinningBody) {
  const Eigen::Vector3d v(0.4, 1.2, -0.3), w(0.5, 4, -1), g(0, -9.81, 0), centre(0.01, 0.02, -0.01);
  RigidPose p0;
  p0.rotation = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()).toRotationMatrix();
  p0.translation = Eigen::Vector3d(0.1, 0.3, 0);
  std::vector<RigidPose> poses;
  std::vector<double> times;
  const Eigen::Vector3d c0 = p0.apply(centre);
  for (int f = 0; f < 5; ++f) {
    const double t = f / 30.0;
    RigidPose p;
    p.rotation = Eigen::AngleAxisd(w.norm() * t, w.normalized()).toRotationMatrix() * p0.rotation;
    const Eigen::Vector3d c = c0 + v * t + 0.5 * g * t * t;
    p.translation = c - p.rotation * centre;
    poses.push_back(p);
    times.push_back(t);
  }
  const RigidVelocity e = estimate_velocity(poses, times, centre, g);
  EXPECT_NEAR((e.linear - v).norm(), 0, 1e-9);
  EXPECT_NEAR((e.angular - w).norm(), 0, 1e-9);
  EXPECT_EQ(e.frames, 5);
}

TEST(Segmentation, DepthEdgesAndFlyingPixelsAreNotCandidates) {
  // A 40x30 image: a wall at 2 m with a box at 1 m in its middle and one flying pixel between them.
  DepthImage img;
  img.width = 40, img.height = 30;
  img.depth.assign(1200, 2.0);
  for (int v = 10; v < 20; ++v)
    for (int u = 15; u < 25; ++u) img.depth[std::size_t(v * 40 + u)] = 1.0;
  img.depth[std::size_t(15 * 40 + 25)] = 1.5;  // a flying pixel right of the box
  SegmentationContext c;
  c.intrinsics = {40, 30, 40, 40, 19.5, 14.5};
  c.depth_scale = 0.001;
  const std::vector<PixelClass> classes = classify_pixels(img, c);
  EXPECT_EQ(classes[std::size_t(15 * 40 + 25)], PixelClass::Edge);
  EXPECT_EQ(classes[std::size_t(15 * 40 + 20)], PixelClass::Candidate);
  const std::vector<DepthComponent> parts = depth_components(img, classes, c, 5);
  ASSERT_EQ(parts.size(), 2u);  // the wall around, and the box's inside (its rim is an edge)
  EXPECT_EQ(parts[1].pixels.size(), 8u * 8u);
  EXPECT_NEAR(parts[1].centroid.z(), 1.0, 1e-12);
  c.planes.push_back(Plane{Eigen::Vector3d(0, 0, -1), -2.0});
  const std::vector<DepthComponent> without_wall = depth_components(img, classify_pixels(img, c), c, 5);
  ASSERT_EQ(without_wall.size(), 1u);
  EXPECT_FALSE(without_wall[0].touches_border);
}

TEST(ObjectSelection, SizeDecidesAndMillimetreScansAreNamed) {
  std::vector<DepthComponent> parts(3);
  parts[0].extent = 0.6, parts[1].extent = 0.12, parts[2].extent = 0.03;
  parts[1].pixel_centroid = {50, 40};
  EXPECT_EQ(select_object_part(parts, 0.15, 1, std::nullopt, "rec"), 1);
  expect_input_error([&] { select_object_part(parts, 150, 1, std::nullopt, "rec"); }, {"rec", "millimetres", "--scan-scale 0.001"});
  parts[2].extent = 0.1;
  expect_input_error([&] { select_object_part(parts, 0.15, 1, std::nullopt, "rec"); }, {"several candidates", "--pick"});
  EXPECT_EQ(select_object_part(parts, 0.15, 1, Eigen::Vector2d(52, 41), "rec"), 1);
  // A part of the object's size at the image border (a hand, clutter cut by the frame) gives way.
  parts[2].touches_border = true;
  EXPECT_EQ(select_object_part(parts, 0.15, 1, std::nullopt, "rec"), 1);
  expect_input_error([&] { select_object_part({}, 0.15, 1, std::nullopt, "rec"); }, {"no object found"});
}

}  // namespace
}  // namespace ssc

namespace ssc {
namespace {

TEST(MotionEstimate, TorqueFreeSpinOfAnAsymmetricBody) {
  // A body with three different principal moments, spinning off its principal axes: its angular
  // velocity precesses, so a constant spin fits the rotations only roughly; the torque-free
  // model recovers the start exactly.
  const Eigen::Matrix3d inertia = Eigen::Vector3d(1.0, 2.0, 3.5).asDiagonal();
  const Eigen::Vector3d w0(1.0, 4.0, -2.0), centre(0, 0, 0), g(0, -9.81, 0);
  const Eigen::Matrix3d r0 = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  std::vector<RigidPose> poses;
  std::vector<double> times;
  for (int f = 0; f < 5; ++f) {
    RigidPose p;
    p.rotation = torque_free_rotation(r0, w0, inertia, f / 30.0, 1e-5);
    poses.push_back(p);
    times.push_back(f / 30.0);
  }
  const RigidVelocity constant = estimate_velocity(poses, times, centre, g);
  const RigidVelocity free = estimate_velocity(poses, times, centre, g, inertia);
  std::printf("constant spin: %.2f %% off; torque-free: %.2g %% off\n", 100 * (constant.angular - w0).norm() / w0.norm(),
              100 * (free.angular - w0).norm() / w0.norm());
  EXPECT_GT((constant.angular - w0).norm(), 0.01 * w0.norm()) << "the test body must precess visibly";
  EXPECT_LT((free.angular - w0).norm(), 1e-4 * w0.norm());
  // The integrator: a spin about a principal axis is a constant rotation.
  const Eigen::Matrix3d about_z = torque_free_rotation(Eigen::Matrix3d::Identity(), {0, 0, 3}, inertia, 0.5);
  EXPECT_NEAR((about_z - Eigen::AngleAxisd(1.5, Eigen::Vector3d::UnitZ()).toRotationMatrix()).norm(), 0, 1e-9);
}

TEST(ScanRegistration, InertiaOfABox) {
  // A 0.2 x 0.4 x 0.6 box: I_xx = V (b^2 + c^2) / 12 per unit density.
  TriangleMesh box;
  for (int i = 0; i < 8; ++i) box.vertices.push_back({(i & 1) ? 0.1 : -0.1, (i & 2) ? 0.2 : -0.2, (i & 4) ? 0.3 : -0.3});
  for (const auto& q : std::vector<std::array<int, 4>>{{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}}) {
    box.faces.push_back({q[0], q[1], q[2]});
    box.faces.push_back({q[0], q[2], q[3]});
  }
  const ScanModel m = make_scan_model(box, 1.0, 500);
  const double V = 0.2 * 0.4 * 0.6;
  EXPECT_NEAR(m.volume, V, 1e-12);
  EXPECT_NEAR(m.centroid.norm(), 0, 1e-12);
  EXPECT_NEAR(m.inertia(0, 0), V * (0.16 + 0.36) / 12, 1e-12);
  EXPECT_NEAR(m.inertia(1, 1), V * (0.04 + 0.36) / 12, 1e-12);
  EXPECT_NEAR(m.inertia(2, 2), V * (0.04 + 0.16) / 12, 1e-12);
  EXPECT_NEAR(m.inertia(0, 1), 0, 1e-12);
  EXPECT_EQ(m.open_edges, 0);
}

}  // namespace
}  // namespace ssc
