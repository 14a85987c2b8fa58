// Depth with a patch of the table left around the body: points on a contact plane of the
// scene are refused (or, a few, warned about) when the problem is loaded, and clean renders
// of a body sitting on the plane, whose lowest side points lie on it too, pass in silence.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "tests/expect_input_error.h"
#include "models/io/run_record.h"
#include "models/sim/body.h"
#include "models/sim/observation_setup.h"
#include "models/sim/plane_points.h"
#include "models/sim/problem.h"

namespace ssc {
namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;

struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name)
      : path(fs::temp_directory_path() / ("ssc_plane_points_" + std::to_string(::getpid()) + "_" + name)) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  std::string operator/(const std::string& name) const { return (path / name).string(); }
};

// A 12 cm cube dropped from 2 cm onto the ground (it lands at step 3 and stays), seen from
// above and in front by a 64x48 camera with 2 mm depth noise.
std::string write_scene(const TempDir& tmp) {
  const json scene = {
      {"object", {{"primitive", "box"}, {"half_extents", {0.06, 0.06, 0.06}}, {"position", {0, 0.08, 0}}}},
      {"grid", {{"cell_size", 0.03}}},
      {"material", {{"youngs_modulus", 2e4}, {"poisson_ratio", 0.3}, {"density", 300}}},
      {"ground", {{"height", 0}, {"stiffness", 1e5}, {"softmin_alpha", 200}}},
      {"time", {{"dt", 0.02}, {"steps", 8}, {"theta", 0.6}}},
      {"observation",
       {{"noise", 0.002},
        {"depth_scale", 0.0001},
        {"cameras", {{{"name", "front"}, {"width", 64}, {"height", 48}, {"fov_deg", 45}, {"eye", {0, 0.35, 0.6}},
                      {"target", {0, 0.03, 0}}, {"min_depth", 0.1}, {"max_depth", 3}}}}}}};
  const std::string path = tmp / "cube.json";
  std::ofstream(path) << scene.dump(2);
  return path;
}

// Sets every empty pixel whose ray meets the plane y = 0 in the square of half side `half`
// about `centre` (x, z) to the plane's depth.
void add_table(ObservationSet& set, double half, const Eigen::Vector2d& centre = Eigen::Vector2d::Zero()) {
  for (int f = 0; f < set.frame_count; ++f)
    for (std::size_t c = 0; c < set.cameras.size(); ++c) {
      const DepthCamera& cam = set.cameras[c];
      DepthImage& image = set.frames[std::size_t(f)][c];
      for (int v = 0; v < image.height; ++v)
        for (int u = 0; u < image.width; ++u) {
          if (image.at(u, v) > 0) continue;
          const Eigen::Vector3d o = eye(cam), d = ray_direction_world(cam, u, v);
          if (d.y() >= 0) continue;
          const Eigen::Vector3d x = o - o.y() / d.y() * d;
          if (std::max(std::abs(x.x() - centre.x()), std::abs(x.z() - centre.y())) > half) continue;
          double z = 0;
          project(cam, x, nullptr, nullptr, &z);
          image.depth[std::size_t(v) * image.width + u] = std::round(z / set.depth_scale) * set.depth_scale;
        }
    }
}

bool warned(const std::string& code) {
  for (const Warning& w : warnings())
    if (w.code == code) return true;
  return false;
}

TEST(TablePoints, APatchOfTableAroundTheBodyIsRefused) {
  TempDir tmp("patch");
  const std::string scene_path = write_scene(tmp);
  const Scene scene = load_scene(scene_path);
  ObservationSet set = render_observations(scene, build_body_grid(scene), parse_observation_spec(scene));
  ASSERT_NE(camera_depth_noise(set, 0), nullptr);
  ASSERT_EQ(camera_depth_noise(set, 0)->sigma0_m, 0.002);

  // Clean renders, the cube sitting on the plane in the later frames: silent.
  write_observations(tmp / "clean", set);
  clear_warnings();
  const Problem clean = load_problem(scene_path, {}, tmp / "clean");
  EXPECT_FALSE(warned("table_points"));
  // ... although some of its points do lie within the band of the plane: the rule that keeps
  // them is the one under test.
  const std::vector<long> kept = table_points(clean.frames, scene.planes[0], plane_band(clean.observations));
  long near_plane = 0;
  for (const ObservedFrame& f : clean.frames)
    for (const Eigen::Vector3d& x : f.points) near_plane += std::abs(x.y()) <= plane_band(clean.observations);
  EXPECT_GT(near_plane, 0);
  for (long k : kept) EXPECT_EQ(k, 0);

  // A 24 x 24 cm patch of table around the cube.
  ObservationSet patch = set;
  add_table(patch, 0.12);
  write_observations(tmp / "patch", patch);
  expect_input_error([&] { load_problem(scene_path, {}, tmp / "patch"); },
                     {tmp / "patch", "ground.planes[0]", "the table", "segment the body", "depth_noise of cameras.json"});

  // Without a noise model the reader assumes 2 mm, and says so.
  patch.depth_noise.clear();
  write_observations(tmp / "patch_no_noise", patch);
  expect_input_error([&] { load_problem(scene_path, {}, tmp / "patch_no_noise"); },
                     {"ground.planes[0]", "gives no depth_noise"});
  clear_warnings();
}

TEST(TablePoints, ASmallPatchBesideTheBodyIsAWarning) {
  TempDir tmp("rim");
  const std::string scene_path = write_scene(tmp);
  const Scene scene = load_scene(scene_path);
  ObservationSet set = render_observations(scene, build_body_grid(scene), parse_observation_spec(scene));
  const long body_points = long(observed_points(set, 0).size());
  add_table(set, 0.015, Eigen::Vector2d(0.12, 0.05));  // 3 x 3 cm of table 6 cm beside the cube
  long rim = 0;
  for (int f = 0; f < set.frame_count; ++f) rim = std::max(rim, long(observed_points(set, f).size()) - body_points);
  ASSERT_GT(rim, kTablePointsWarning * body_points);
  ASSERT_LT(rim, 0.5 * kTablePointsError * body_points);
  write_observations(tmp / "rim", set);
  clear_warnings();
  try {
    load_problem(scene_path, {}, tmp / "rim");
    EXPECT_TRUE(warned("table_points")) << rim << " rim points against " << body_points;
  } catch (const InputError& e) {
    ADD_FAILURE() << "a rim of " << rim << " points against " << body_points << " body points is an error: " << e.what();
  }
  clear_warnings();
}

}  // namespace
}  // namespace ssc
