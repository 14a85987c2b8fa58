// Tests of the observation layer: pinhole camera maths, 16-bit depth PNG I/O, the
// observation folder format and the ray-cast depth renderer. Expected values are
// analytic (planes, spheres) or exact identities (round trips), never re-derived from the
// code under test.
#include <gtest/gtest.h>
#include <omp.h>
#include <png.h>
#include <unistd.h>

#include <Eigen/Dense>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <random>

#include "runtime/errors.h"
#include "tests/expect_input_error.h"
#include "models/observation/camera.h"
#include "models/observation/depth_png.h"
#include "models/observation/depth_render.h"
#include "models/observation/observation_set.h"

namespace fs = std::filesystem;
using Eigen::Vector3d;
using Mesh = std::pair<std::vector<Vector3d>, std::vector<std::array<int, 3>>>;

namespace ssc {
namespace {

// ---- helpers -------------------------------------------------------------------------

// A fresh folder under the system temp dir, removed at the end of the test.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name)
      : path(fs::temp_directory_path() / ("ssc_obs_test_" + std::to_string(::getpid()) + "_" + name)) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  std::string operator/(const std::string& name) const { return (path / name).string(); }
};


// Camera at the world origin whose camera frame equals the world frame (x right, y down,
// looking along +z).
DepthCamera axis_camera(int width, int height, double fov_deg = 60) {
  return make_look_at_camera("axis", width, height, fov_deg, Vector3d::Zero(), Vector3d(0, 0, 1),
                             Vector3d(0, -1, 0));
}

// Two triangles spanning the square centre +- half*(a, b).
Mesh quad(const Vector3d& centre, const Vector3d& a, const Vector3d& b, double half, bool flip = false) {
  Mesh m;
  m.first = {centre - half * a - half * b, centre + half * a - half * b, centre + half * a + half * b,
             centre - half * a + half * b};
  m.second = {{0, 1, 2}, {0, 2, 3}};
  if (flip) m.second = {{0, 2, 1}, {0, 3, 2}};
  return m;
}

Mesh plane_at_z(double z) { return quad(Vector3d(0, 0, z), Vector3d::UnitX(), Vector3d::UnitY(), 50.0); }

// Icosahedron subdivided `levels` times, vertices on the sphere (centre, radius).
Mesh icosphere(const Vector3d& centre, double radius, int levels) {
  const double g = (1 + std::sqrt(5.0)) / 2;
  std::vector<Vector3d> v = {{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0}, {0, -1, g}, {0, 1, g},
                             {0, -1, -g}, {0, 1, -g}, {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
  for (auto& p : v) p.normalize();
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      const auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[a] + v[b]).normalized());
      return mid[key] = int(v.size()) - 1;
    };
    std::vector<std::array<int, 3>> next;
    for (const auto& t : f) {
      const int a = midpoint(t[0], t[1]), b = midpoint(t[1], t[2]), c = midpoint(t[2], t[0]);
      next.insert(next.end(), {{t[0], a, c}, {t[1], b, a}, {t[2], c, b}, {a, b, c}});
    }
    f = next;
  }
  for (auto& p : v) p = centre + radius * p;
  return {v, f};
}

// Smallest distance from the centre to a triangle plane (the inscribed radius of the mesh).
double inscribed_radius(const Mesh& m, const Vector3d& centre) {
  double r = INFINITY;
  for (const auto& t : m.second) {
    const Vector3d n = (m.first[t[1]] - m.first[t[0]]).cross(m.first[t[2]] - m.first[t[0]]).normalized();
    r = std::min(r, std::fabs(n.dot(m.first[t[0]] - centre)));
  }
  return r;
}

// Nearest t > 0 of a unit ray o + t d on a sphere, or NaN.
double ray_sphere(const Vector3d& o, const Vector3d& d, const Vector3d& c, double r) {
  const double b = d.dot(o - c), q = (o - c).squaredNorm() - r * r, disc = b * b - q;
  if (disc < 0) return NAN;
  const double t = -b - std::sqrt(disc);
  return t > 0 ? t : NAN;
}

DepthImage random_depth_image(int w, int h, std::uint64_t seed, double lo, double hi) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> depth(lo, hi);
  DepthImage img;
  img.width = w;
  img.height = h;
  for (int i = 0; i < w * h; ++i) img.depth.push_back(i % 7 == 3 ? 0.0 : depth(rng));
  return img;
}

void write_png_simplified(const std::string& path, int w, int h, png_uint_32 format, const void* data) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = w;
  image.height = h;
  image.format = format;
  ASSERT_NE(png_image_write_to_file(&image, path.c_str(), 0, data, 0, nullptr), 0);
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void spit(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << bytes;
}

// ---- Camera --------------------------------------------------------------------------

TEST(CameraTest, PixelCentreFormulaAndPose) {
  DepthCamera cam;
  cam.width = 8;
  cam.height = 6;
  cam.fx = 100;
  cam.fy = 120;
  cam.cx = 3.5;
  cam.cy = 2.5;
  cam.camera_to_world.block<3, 1>(0, 3) = Vector3d(1, 2, 3);  // pure translation
  const Vector3d p = unproject(cam, 5, 1, 2.0);
  EXPECT_DOUBLE_EQ(p.x(), 1 + (5 - 3.5) / 100 * 2.0);
  EXPECT_DOUBLE_EQ(p.y(), 2 + (1 - 2.5) / 120 * 2.0);
  EXPECT_DOUBLE_EQ(p.z(), 3 + 2.0);
  EXPECT_EQ(eye(cam), Vector3d(1, 2, 3));
  const Vector3d d = ray_direction_world(cam, 3.5, 2.5);
  EXPECT_NEAR((d - Vector3d::UnitZ()).norm(), 0, 1e-15);
  EXPECT_FALSE(project(cam, Vector3d(1, 2, 2.5), nullptr, nullptr, nullptr));  // behind the camera
  EXPECT_TRUE(in_image(cam, -0.5, 5.49));
  EXPECT_FALSE(in_image(cam, 7.5, 0));
}

TEST(CameraTest, ProjectUnprojectRoundTrip) {
  const DepthCamera cam = make_look_at_camera("c", 64, 48, 50, Vector3d(1.5, 0.7, -2.2), Vector3d(0, 0.3, 0.1),
                                              Vector3d(0, 1, 0));
  for (double u : {0.0, 10.25, 31.5, 63.0})
    for (double v : {0.0, 7.75, 47.0})
      for (double z : {0.2, 1.3, 5.9}) {
        const Vector3d w = unproject(cam, u, v, z);
        double pu, pv, pz;
        ASSERT_TRUE(project(cam, w, &pu, &pv, &pz));
        EXPECT_NEAR(pu, u, 1e-10);
        EXPECT_NEAR(pv, v, 1e-10);
        EXPECT_NEAR(pz, z, 1e-12);
        // the ray direction points from the eye to the point
        EXPECT_NEAR((ray_direction_world(cam, u, v) - (w - eye(cam)).normalized()).norm(), 0, 1e-12);
      }
}

TEST(CameraTest, LookAtFollowsOpenCvConvention) {
  const Vector3d e(0, 1, 3), target(0, 1, 0), up(0, 1, 0);
  const DepthCamera cam = make_look_at_camera("c", 81, 61, 90, e, target, up);
  EXPECT_EQ(cam.cx, 40.0);
  EXPECT_EQ(cam.cy, 30.0);
  EXPECT_NEAR(cam.fy, 30.5, 1e-12);  // half height / tan(45 deg)
  EXPECT_EQ(cam.fx, cam.fy);
  double u, v, z;
  ASSERT_TRUE(project(cam, target, &u, &v, &z));
  EXPECT_NEAR(u, 40, 1e-12);
  EXPECT_NEAR(v, 30, 1e-12);
  EXPECT_NEAR(z, 3, 1e-12);
  // Looking along -z with +y up, world +x is to the right and world +y is up (smaller v).
  ASSERT_TRUE(project(cam, target + Vector3d(0.5, 0, 0), &u, &v, &z));
  EXPECT_GT(u, 40);
  EXPECT_NEAR(v, 30, 1e-12);
  ASSERT_TRUE(project(cam, target + Vector3d(0, 0.5, 0), &u, &v, &z));
  EXPECT_LT(v, 30);
  EXPECT_NEAR(v, 30 - 30.5 * 0.5 / 3, 1e-10);
  EXPECT_EQ(eye(cam), e);
}

TEST(CameraTest, ValidationRejectsBadCameras) {
  const DepthCamera good = axis_camera(10, 10);
  EXPECT_NO_THROW(validate_camera(good, "here"));
  auto bad = [&](const std::function<void(DepthCamera&)>& edit, const std::string& word) {
    DepthCamera c = good;
    edit(c);
    expect_input_error([&] { validate_camera(c, "obs/cameras.json: cameras[2]"); },
                       {"obs/cameras.json: cameras[2]", word});
  };
  bad([](DepthCamera& c) { c.width = 0; }, "width");
  bad([](DepthCamera& c) { c.fx = -1; }, "focal");
  bad([](DepthCamera& c) { c.cy = NAN; }, "principal");
  bad([](DepthCamera& c) { c.camera_to_world.topLeftCorner<3, 3>() *= 1.1; }, "orthonormal");
  bad([](DepthCamera& c) { c.camera_to_world(0, 0) = -1; }, "reflection");
  bad([](DepthCamera& c) { c.camera_to_world(3, 0) = 0.5; }, "last row");
  bad([](DepthCamera& c) { c.min_depth = 7; }, "min_depth");
  expect_input_error([] { make_look_at_camera("c", 10, 10, 60, Vector3d::Zero(), Vector3d(0, 2, 0),
                                              Vector3d(0, 1, 0)); }, {"parallel"});
}

// ---- DepthRender ---------------------------------------------------------------------

TEST(DepthRenderTest, FrontoParallelPlaneGivesZDepthNotRayLength) {
  const DepthCamera cam = axis_camera(40, 30, 70);
  for (bool flip : {false, true}) {  // both triangle sides are hit
    const Mesh m = quad(Vector3d(0, 0, 2), Vector3d::UnitX(), Vector3d::UnitY(), 50.0, flip);
    const DepthImage img = render_depth(cam, m.first, m.second, 0.0, 1);
    ASSERT_EQ(img.depth.size(), 40u * 30u);
    for (double d : img.depth) ASSERT_NEAR(d, 2.0, 1e-12);
  }
}

TEST(DepthRenderTest, TiltedPlaneMatchesAnalyticDepth) {
  const DepthCamera cam = make_look_at_camera("c", 48, 36, 60, Vector3d(0.3, -0.2, 0.1), Vector3d(0.3, -0.2, 5),
                                              Vector3d(0, -1, 0));  // camera frame = world frame, shifted
  const Vector3d n = Vector3d(0.4, -0.3, 1).normalized(), p0(0.5, 0, 2.5);
  const Vector3d a = n.cross(Vector3d::UnitX()).normalized(), b = n.cross(a);
  const Mesh m = quad(p0, a, b, 40.0);
  const DepthImage img = render_depth(cam, m.first, m.second, 0.0, 1);
  const Vector3d o = eye(cam);
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u) {
      const Vector3d r((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);  // z = 1 in camera = world frame
      const double z = n.dot(p0 - o) / n.dot(r);
      ASSERT_NEAR(img.at(u, v), z, 1e-10) << "pixel " << u << "," << v;
    }
  // sanity: the plane is really tilted across the image
  EXPECT_GT(std::fabs(img.at(0, 0) - img.at(47, 35)), 0.3);
}

TEST(DepthRenderTest, SphereDepthMatchesAnalyticWithinFacetError) {
  const Vector3d c(0, 0, 3);
  const double radius = 0.5;
  const Mesh m = icosphere(c, radius, 4);  // 5120 triangles
  const double r_in = inscribed_radius(m, c);
  ASSERT_GT(r_in, 0.497);
  const DepthCamera cam = axis_camera(61, 61, 30);
  const DepthImage img = render_depth(cam, m.first, m.second, 0.0, 1);
  // centre pixel looks straight at the sphere centre
  EXPECT_GE(img.at(30, 30), 3 - radius - 1e-12);
  EXPECT_LE(img.at(30, 30), 3 - r_in + 1e-12);
  int hits = 0;
  for (int v = 0; v < 61; ++v)
    for (int u = 0; u < 61; ++u) {
      const Vector3d d = ray_direction_world(cam, u, v);
      const double t_out = ray_sphere(eye(cam), d, c, radius), t_in = ray_sphere(eye(cam), d, c, r_in);
      const double z = img.at(u, v);
      if (std::isnan(t_out)) {
        EXPECT_EQ(z, 0.0) << u << "," << v;
      } else if (!std::isnan(t_in)) {
        ++hits;
        EXPECT_GE(z, t_out * d.z() - 1e-12) << u << "," << v;
        EXPECT_LE(z, t_in * d.z() + 1e-12) << u << "," << v;
      }
    }
  EXPECT_GT(hits, 500);  // the sphere covers a good part of the image
}

TEST(DepthRenderTest, NoiseHasRequestedStdAlongRayAndIsReproducible) {
  const DepthCamera cam = axis_camera(200, 150, 80);
  const Mesh m = plane_at_z(2.0);
  const double sigma = 0.01;
  const DepthImage img = render_depth(cam, m.first, m.second, sigma, 1234);
  double sum = 0, sum2 = 0;
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u) {
      const double len = Vector3d((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1).norm();
      const double e = (img.at(u, v) - 2.0) * len;  // noise along the ray
      sum += e;
      sum2 += e * e;
    }
  const double n = cam.width * cam.height, mean = sum / n, std = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(std, sigma, 0.1 * sigma);
  EXPECT_NEAR(mean, 0.0, 5 * sigma / std::sqrt(n));
  // bitwise reproducible, also with another thread count; another seed differs
  EXPECT_EQ(render_depth(cam, m.first, m.second, sigma, 1234).depth, img.depth);
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const DepthImage single = render_depth(cam, m.first, m.second, sigma, 1234);
  omp_set_num_threads(threads);
  EXPECT_EQ(single.depth, img.depth);
  EXPECT_NE(render_depth(cam, m.first, m.second, sigma, 1235).depth, img.depth);
  EXPECT_NE(mix_seed(1, 0, 1), mix_seed(1, 1, 0));
}

TEST(DepthRenderTest, DepthOutsideRangeAndMissesAreZero) {
  const DepthCamera cam = axis_camera(20, 20);  // range [0.1, 6]
  for (double z : {0.05, 6.5}) {
    const Mesh m = plane_at_z(z);
    for (double d : render_depth(cam, m.first, m.second, 0.0, 1).depth) EXPECT_EQ(d, 0.0);
  }
  const Mesh behind = plane_at_z(-2.0);
  for (double d : render_depth(cam, behind.first, behind.second, 0.0, 1).depth) EXPECT_EQ(d, 0.0);
  for (double d : render_depth(cam, {}, {}, 0.0, 1).depth) EXPECT_EQ(d, 0.0);
  // the nearer of two planes wins
  Mesh two = plane_at_z(3.0);
  const Mesh near = plane_at_z(1.5);
  for (const auto& t : near.second) two.second.push_back({t[0] + 4, t[1] + 4, t[2] + 4});
  two.first.insert(two.first.end(), near.first.begin(), near.first.end());
  for (double d : render_depth(cam, two.first, two.second, 0.0, 1).depth) EXPECT_NEAR(d, 1.5, 1e-12);
  expect_input_error([&] { render_depth(cam, near.first, {{0, 1, 9}}, 0.0, 1); }, {"triangle 0", "vertex 9"});
}

// ---- DepthPng ------------------------------------------------------------------------

TEST(DepthPngTest, RoundTripIsExactToTheQuantisation) {
  TempDir dir("png_roundtrip");
  const double scale = 0.001;
  DepthImage img = random_depth_image(37, 23, 7, 0.1, 6.0);
  img.depth[5] = 65535 * scale;  // the largest representable depth
  write_depth_png(dir / "a.png", img, scale);
  const DepthImage back = read_depth_png(dir / "a.png", scale);
  ASSERT_EQ(back.width, 37);
  ASSERT_EQ(back.height, 23);
  for (std::size_t i = 0; i < img.depth.size(); ++i)
    ASSERT_EQ(back.depth[i], std::round(img.depth[i] / scale) * scale) << i;
  EXPECT_EQ(quantize_depth(img, scale).depth, back.depth);
  write_depth_png(dir / "b.png", back, scale);
  EXPECT_EQ(read_depth_png(dir / "b.png", scale).depth, back.depth);
  EXPECT_EQ(slurp(dir / "a.png"), slurp(dir / "b.png"));
  EXPECT_FALSE(fs::exists(dir / ("a.png.tmp-" + std::to_string(::getpid()))));
}

TEST(DepthPngTest, WriteRejectsUnrepresentableDepths) {
  TempDir dir("png_write_errors");
  const std::string path = dir / "x.png";
  for (double bad : {-0.01, double(NAN), 65535 * 0.001 + 0.01}) {
    DepthImage img = random_depth_image(4, 3, 1, 0.5, 1.0);
    img.depth[6] = bad;
    expect_input_error([&] { write_depth_png(path, img, 0.001); }, {path, "u=2, v=1"});
    EXPECT_FALSE(fs::exists(path));
  }
  DepthImage wrong = random_depth_image(4, 3, 1, 0.5, 1.0);
  wrong.width = 5;
  expect_input_error([&] { write_depth_png(path, wrong, 0.001); }, {path});
}

TEST(DepthPngTest, ReadErrorsNameTheFile) {
  TempDir dir("png_read_errors");
  const std::string missing = dir / "missing.png";
  expect_input_error([&] { read_depth_png(missing, 0.001); }, {missing, "cannot open"});

  const std::string text = dir / "text.png";
  spit(text, "this is not a png at all");
  expect_input_error([&] { read_depth_png(text, 0.001); }, {text, "not a PNG"});

  const std::string good = dir / "good.png";
  write_depth_png(good, random_depth_image(64, 64, 3, 0.5, 5.0), 0.001);
  const std::string bytes = slurp(good);
  const std::string truncated = dir / "truncated.png";
  spit(truncated, bytes.substr(0, bytes.size() / 2));
  expect_input_error([&] { read_depth_png(truncated, 0.001); }, {truncated, "corrupt or truncated"});
  const std::string header_only = dir / "header_only.png";
  spit(header_only, bytes.substr(0, 20));
  expect_input_error([&] { read_depth_png(header_only, 0.001); }, {header_only});
  const std::string garbled = dir / "garbled.png";
  std::string g = bytes;
  for (std::size_t i = 60; i < g.size() - 20; i += 7) g[i] = char(g[i] ^ 0x5a);
  spit(garbled, g);
  expect_input_error([&] { read_depth_png(garbled, 0.001); }, {garbled});

  const std::string gray8 = dir / "gray8.png";
  const std::vector<unsigned char> pixels8(16 * 8, 100);
  write_png_simplified(gray8, 16, 8, PNG_FORMAT_GRAY, pixels8.data());
  expect_input_error([&] { read_depth_png(gray8, 0.001); }, {gray8, "8-bit grayscale", "16-bit"});
  const std::string rgb16 = dir / "rgb16.png";
  const std::vector<png_uint_16> pixels16(16 * 8 * 3, 1000);
  write_png_simplified(rgb16, 16, 8, PNG_FORMAT_LINEAR_RGB, pixels16.data());
  expect_input_error([&] { read_depth_png(rgb16, 0.001); }, {rgb16, "16-bit RGB"});
  expect_input_error([&] { read_depth_png(good, 0.0); }, {good, "depth_scale"});
}

// ---- Observation ---------------------------------------------------------------------

ObservationSet small_set() {
  ObservationSet set;
  set.dt = 1.0 / 30;
  set.depth_scale = 0.0005;
  set.first_frame_time = 0.1;
  set.frame_count = 3;
  set.cameras = {make_look_at_camera("front", 48, 36, 40, Vector3d(0, 0.5, 2.5), Vector3d(0, 0.4, 0),
                                     Vector3d(0, 1, 0)),
                 make_look_at_camera("side", 40, 32, 40, Vector3d(2.0, 1.0, 0.3), Vector3d(0, 0.3, 0),
                                     Vector3d(0, 1, 0))};
  set.cameras[1].min_depth = 0.2;
  set.cameras[1].max_depth = 4.0;
  set.depth_patterns = {"cam0/depth_%04d.png", "side/d%d.png"};
  for (int f = 0; f < set.frame_count; ++f) {
    const Mesh ball = icosphere(Vector3d(0, 0.4 - 0.05 * f, 0), 0.4, 2);
    std::vector<DepthImage> images;
    for (std::size_t i = 0; i < set.cameras.size(); ++i)
      images.push_back(quantize_depth(
          render_depth(set.cameras[i], ball.first, ball.second, 0.002, mix_seed(5, f, i)), set.depth_scale));
    set.frames.push_back(images);
  }
  return set;
}

nlohmann::json read_json(const std::string& path) { return nlohmann::json::parse(slurp(path)); }
void write_json(const std::string& path, const nlohmann::json& j) { spit(path, j.dump(2)); }

TEST(ObservationTest, DepthPatternsFormatFrameNumbers) {
  EXPECT_EQ(depth_file_name("cam0/depth_%04d.png", 7), "cam0/depth_0007.png");
  EXPECT_EQ(depth_file_name("d%d.png", 123), "d123.png");
  EXPECT_EQ(depth_file_name("a%%b_%02d.png", 5), "a%b_05.png");
  EXPECT_EQ(default_depth_pattern(2), "cam2/depth_%04d.png");
  for (const char* bad : {"depth.png", "d%d_%d.png", "d%s.png", "/abs/d%d.png", "../d%d.png", "d%x.png"})
    expect_input_error([&] { depth_file_name(bad, 0, "cameras.json: cameras[0]"); }, {"cameras.json: cameras[0]", bad});
}

TEST(ObservationTest, WriteThenReadIsBitwiseIdentical) {
  TempDir tmp("roundtrip");
  const std::string dir = tmp / "obs";
  const ObservationSet set = small_set();
  long measured = 0;
  for (double d : set.frames[0][0].depth) measured += d > 0;
  ASSERT_GT(measured, 150);  // the ball is in view
  write_observations(dir, set);
  const ObservationSet back = read_observations(dir);
  EXPECT_EQ(back.dt, set.dt);
  EXPECT_EQ(back.depth_scale, set.depth_scale);
  EXPECT_EQ(back.first_frame_time, set.first_frame_time);
  EXPECT_EQ(back.frame_count, set.frame_count);
  EXPECT_EQ(back.depth_patterns, set.depth_patterns);
  ASSERT_EQ(back.cameras.size(), 2u);
  for (int i = 0; i < 2; ++i) {
    const DepthCamera &a = set.cameras[i], &b = back.cameras[i];
    EXPECT_EQ(b.name, a.name);
    EXPECT_EQ(b.width, a.width);
    EXPECT_EQ(b.height, a.height);
    EXPECT_EQ(b.fx, a.fx);
    EXPECT_EQ(b.fy, a.fy);
    EXPECT_EQ(b.cx, a.cx);
    EXPECT_EQ(b.cy, a.cy);
    EXPECT_EQ(b.camera_to_world, a.camera_to_world);
    EXPECT_EQ(b.min_depth, a.min_depth);
    EXPECT_EQ(b.max_depth, a.max_depth);
  }
  ASSERT_EQ(back.frames.size(), 3u);
  for (int f = 0; f < 3; ++f)
    for (int i = 0; i < 2; ++i) {
      EXPECT_EQ(back.frames[f][i].width, set.frames[f][i].width);
      EXPECT_EQ(back.frames[f][i].depth, set.frames[f][i].depth) << "frame " << f << " camera " << i;
    }
  EXPECT_TRUE(fs::exists(tmp / "obs/side/d2.png"));
  EXPECT_TRUE(fs::exists(tmp / "obs/cam0/depth_0002.png"));

  // A file the user put into the folder keeps it from being replaced; without it, rewriting
  // replaces the folder as a whole (frame 2 disappears) and leaves no temporary siblings.
  spit(tmp / "obs/stale.txt", "old");
  ObservationSet two = set;
  two.frame_count = 2;
  two.frames.pop_back();
  expect_input_error([&] { write_observations(dir + "/", two); }, {"stale.txt"});
  EXPECT_TRUE(fs::exists(tmp / "obs/stale.txt"));
  fs::remove(tmp / "obs/stale.txt");
  write_observations(dir + "/", two);
  EXPECT_FALSE(fs::exists(tmp / "obs/cam0/depth_0002.png"));
  EXPECT_EQ(read_observations(dir).frame_count, 2);
  EXPECT_EQ(std::distance(fs::directory_iterator(tmp.path), fs::directory_iterator{}), 1);
}

TEST(ObservationTest, ObservedPointsAreUnprojectedMeasuredPixels) {
  const ObservationSet set = small_set();
  const std::vector<Vector3d> pts = observed_points(set, 1);
  std::size_t expected = 0;
  for (const DepthImage& img : set.frames[1])
    for (double d : img.depth) expected += d > 0;
  ASSERT_EQ(pts.size(), expected);
  // every point lies on the ball of frame 1 (centre y = 0.35, r = 0.4) up to facets and noise
  for (const Vector3d& p : pts) EXPECT_NEAR((p - Vector3d(0, 0.35, 0)).norm(), 0.4, 0.04);
  // the first point is the first measured pixel of camera 0, row-major
  const DepthImage& img = set.frames[1][0];
  int first = 0;
  while (img.depth[first] == 0) ++first;
  EXPECT_EQ(pts[0], unproject(set.cameras[0], first % img.width, first / img.width, img.depth[first]));
  EXPECT_THROW(observed_points(set, 3), InputError);
}

TEST(ObservationTest, WriterRefusesInvalidSetsAndForeignFolders) {
  TempDir tmp("writer_errors");
  ObservationSet set = small_set();
  set.frames[1][1].depth[3] = 4.5;  // beyond camera 1's max_depth 4.0
  expect_input_error([&] { write_observations(tmp / "obs", set); }, {"frame 1", "side", "max_depth"});
  set = small_set();
  set.frames[2].pop_back();
  expect_input_error([&] { write_observations(tmp / "obs", set); }, {"frame 2"});
  set = small_set();
  set.depth_patterns[1] = set.depth_patterns[0];
  expect_input_error([&] { write_observations(tmp / "obs", set); }, {"another camera"});
  spit(tmp / "precious.txt", "keep me");
  expect_input_error([&] { write_observations(tmp.path.string(), small_set()); }, {"ssc did not make"});
  EXPECT_TRUE(fs::exists(tmp / "precious.txt"));
  EXPECT_FALSE(fs::exists(tmp / "obs"));
}

// Writes a valid folder, lets `corrupt` break it, and expects read_observations to fail
// with a message containing `parts` (where "<dir>" is replaced by the folder path).
void expect_read_error(const std::string& name, const std::function<void(const std::string&)>& corrupt,
                       std::vector<std::string> parts) {
  TempDir tmp(name);
  const std::string dir = tmp / "obs";
  write_observations(dir, small_set());
  ASSERT_NO_THROW(read_observations(dir));
  corrupt(dir);
  for (auto& p : parts)
    if (p.rfind("<dir>", 0) == 0) p = dir + p.substr(5);
  SCOPED_TRACE(name);
  expect_input_error([&] { read_observations(dir); }, parts);
}

TEST(ObservationTest, ReaderReportsEveryProblemWithItsPath) {
  expect_read_error("no_json", [](const std::string& d) { fs::remove(d + "/cameras.json"); },
                    {"<dir>/cameras.json", "missing cameras.json"});
  expect_read_error("bad_json", [](const std::string& d) { spit(d + "/cameras.json", "{ \"format\": "); },
                    {"<dir>/cameras.json", "malformed JSON", "parse error"});
  expect_read_error("missing_key", [](const std::string& d) {
    auto j = read_json(d + "/cameras.json");
    j["cameras"][1].erase("fx");
    write_json(d + "/cameras.json", j);
  }, {"<dir>/cameras.json", "missing key 'cameras[1].fx'"});
  expect_read_error("missing_top_key", [](const std::string& d) {
    auto j = read_json(d + "/cameras.json");
    j.erase("depth_scale");
    write_json(d + "/cameras.json", j);
  }, {"<dir>/cameras.json", "missing key 'depth_scale'"});
  expect_read_error("wrong_type", [](const std::string& d) {
    auto j = read_json(d + "/cameras.json");
    j["cameras"][0]["width"] = "48";
    write_json(d + "/cameras.json", j);
  }, {"<dir>/cameras.json", "cameras[0].width", "must be a number"});
  expect_read_error("bad_pose", [](const std::string& d) {
    auto j = read_json(d + "/cameras.json");
    j["cameras"][0]["camera_to_world"] = {1, 0, 0};
    write_json(d + "/cameras.json", j);
  }, {"<dir>/cameras.json", "camera_to_world", "16 numbers"});
  expect_read_error("format", [](const std::string& d) {
    auto j = read_json(d + "/cameras.json");
    j["format"] = "ssc-depth-v9";
    write_json(d + "/cameras.json", j);
  }, {"<dir>/cameras.json", "unknown format 'ssc-depth-v9'"});
  expect_read_error("bad_camera", [](const std::string& d) {
    auto j = read_json(d + "/cameras.json");
    j["cameras"][1]["max_depth"] = 0.1;
    write_json(d + "/cameras.json", j);
  }, {"<dir>/cameras.json", "cameras[1]", "max_depth"});
  expect_read_error("size_mismatch", [](const std::string& d) {
    write_depth_png(d + "/side/d1.png", random_depth_image(41, 32, 1, 1, 2), 0.0005);
  }, {"<dir>/side/d1.png", "41x32", "40x32"});
  expect_read_error("missing_frame", [](const std::string& d) { fs::remove(d + "/side/d2.png"); },
                    {"<dir>/side/d2.png", "frame 2", "camera 1 ('side')", "frame_count"});
  expect_read_error("too_many_frames", [](const std::string& d) {
    auto j = read_json(d + "/cameras.json");
    j["frame_count"] = 4;
    write_json(d + "/cameras.json", j);
  }, {"<dir>/cam0/depth_0003.png", "frame 3"});
  expect_read_error("beyond_range", [](const std::string& d) {
    DepthImage img = random_depth_image(40, 32, 1, 1, 2);
    img.depth[40 * 2 + 5] = 5.0;  // camera 'side' has max_depth 4
    img.depth[40 * 3 + 1] = 4.5;
    write_depth_png(d + "/side/d0.png", img, 0.0005);
  }, {"<dir>/side/d0.png", "2 pixel(s)", "u=5, v=2", "max_depth", "set such pixels to 0"});
  expect_read_error("below_range", [](const std::string& d) {
    DepthImage img = random_depth_image(48, 36, 1, 1, 2);
    img.depth[0] = 0.05;  // min_depth 0.1
    write_depth_png(d + "/cam0/depth_0001.png", img, 0.0005);
  }, {"<dir>/cam0/depth_0001.png", "1 pixel(s)", "u=0, v=0"});
  expect_read_error("corrupt_png", [](const std::string& d) {
    const std::string p = d + "/cam0/depth_0000.png";
    const std::string bytes = slurp(p);
    spit(p, bytes.substr(0, bytes.size() - 30));
  }, {"<dir>/cam0/depth_0000.png", "corrupt or truncated"});
  expect_read_error("eight_bit", [](const std::string& d) {
    const std::vector<unsigned char> px(48 * 36, 9);
    write_png_simplified(d + "/cam0/depth_0001.png", 48, 36, PNG_FORMAT_GRAY, px.data());
  }, {"<dir>/cam0/depth_0001.png", "8-bit"});
  TempDir tmp("no_folder");
  expect_input_error([&] { read_observations(tmp / "nothing"); }, {tmp / "nothing", "does not exist"});
}

TEST(ObservationTest, DepthNoiseModelIsOptionalReadsBackAndIsChecked) {
  TempDir tmp("noise");
  ObservationSet set = small_set();
  write_observations(tmp / "none", set);
  EXPECT_TRUE(read_observations(tmp / "none").depth_noise.empty());
  EXPECT_EQ(camera_depth_noise(read_observations(tmp / "none"), 0), nullptr);
  // One model for both cameras is written once, at the top level.
  set.depth_noise.assign(2, DepthNoise{0.0012, 0.0019, false});
  write_observations(tmp / "shared", set);
  const nlohmann::json shared = read_json(tmp / "shared/cameras.json");
  EXPECT_EQ(shared["depth_noise"]["sigma0_m"], 0.0012);
  EXPECT_EQ(shared["depth_noise"]["along"], "depth");
  EXPECT_FALSE(shared["cameras"][0].contains("depth_noise"));
  const ObservationSet back = read_observations(tmp / "shared");
  ASSERT_EQ(back.depth_noise.size(), 2u);
  EXPECT_TRUE(*back.depth_noise[1] == *set.depth_noise[1]);
  EXPECT_DOUBLE_EQ(camera_depth_noise(back, 1)->sigma(2.0), 0.0012 + 0.0019 * 4);
  // Different models, and one camera without: per camera; a camera's own model wins over the top level's.
  set.depth_noise[0] = DepthNoise{0.003, 0.0, true};
  set.depth_noise[1].reset();
  write_observations(tmp / "own", set);
  ObservationSet own = read_observations(tmp / "own");
  ASSERT_EQ(own.depth_noise.size(), 2u);
  EXPECT_TRUE(own.depth_noise[0] && own.depth_noise[0]->along_ray && own.depth_noise[0]->sigma0_m == 0.003);
  EXPECT_FALSE(own.depth_noise[1]);
  nlohmann::json j = read_json(tmp / "own/cameras.json");
  j["depth_noise"] = {{"sigma0_m", 0.005}};
  write_json(tmp / "own/cameras.json", j);
  own = read_observations(tmp / "own");
  EXPECT_EQ(own.depth_noise[0]->sigma0_m, 0.003);
  EXPECT_EQ(own.depth_noise[1]->sigma0_m, 0.005);
  EXPECT_EQ(own.depth_noise[1]->per_m2, 0.0);

  expect_read_error("negative_noise", [](const std::string& d) {
    auto j = read_json(d + "/cameras.json");
    j["depth_noise"] = {{"sigma0_m", -0.001}};
    write_json(d + "/cameras.json", j);
  }, {"<dir>/cameras.json", "depth_noise", "sigma0_m = -0.001"});
  expect_read_error("noise_along", [](const std::string& d) {
    auto j = read_json(d + "/cameras.json");
    j["cameras"][1]["depth_noise"] = {{"sigma0_m", 0.001}, {"along", "normal"}};
    write_json(d + "/cameras.json", j);
  }, {"<dir>/cameras.json", "cameras[1].depth_noise.along", "'normal'"});
  expect_read_error("noise_type", [](const std::string& d) {
    auto j = read_json(d + "/cameras.json");
    j["depth_noise"] = 0.002;
    write_json(d + "/cameras.json", j);
  }, {"<dir>/cameras.json", "'depth_noise' must be an object"});
  set.depth_noise[0] = DepthNoise{std::nan(""), 0.0, false};
  expect_input_error([&] { write_observations(tmp / "bad", set); }, {"cameras[0]", "depth_noise"});
}

TEST(ObservationTest, BoundaryDepthsSurviveQuantisation) {
  // Depths at the ends of the range can round past them; the reader allows half a unit.
  TempDir tmp("boundary");
  ObservationSet set = small_set();
  set.depth_scale = 0.0024;                // camera 1: range [0.2, 4.0]
  set.frames[0][1].depth[0] = 4.0;         // 1666.67 units -> 1667 -> 4.0008 m > max_depth
  set.frames[0][1].depth[1] = 3.9999;      // -> 1667 as well
  set.frames[0][1].depth[2] = 0.2;         // 83.33 units -> 83 -> 0.1992 m < min_depth
  write_observations(tmp / "obs", set);
  const ObservationSet back = read_observations(tmp / "obs");
  EXPECT_GT(back.frames[0][1].depth[0], 4.0);
  EXPECT_LT(back.frames[0][1].depth[2], 0.2);
}

}  // namespace
}  // namespace ssc
