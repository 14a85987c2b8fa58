// `ssc render` through the command line: rendering the PLY frames that `ssc simulate` writes
// must give the observation folder that `ssc observe` renders from the simulation itself
// (the PLYs store float32 vertices, so depths may differ by a quantisation step), and every
// bad input is an error naming the file and the fix.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "models/observation/observation_set.h"
#include "tests/cli_test_folder.h"

namespace ssc {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// A tilted 0.2 m box thrown onto the ground, seen by two cameras of different sizes, 9 frames.
json small_scene() {
  json j;
  j["object"] = {{"primitive", "box"}, {"half_extents", {0.1, 0.1, 0.1}}, {"position", {0, 0.16, 0}},
                 {"rotation_deg", {10, 20, 0}}};
  j["grid"] = {{"cell_size", 0.04}};
  j["material"] = {{"youngs_modulus", 2e4}, {"density", 200}};
  j["ground"] = {{"height", 0.0}, {"stiffness", 1e5}};
  j["initial"] = {{"linear_velocity", {0.2, -0.8, 0}}};
  j["time"] = {{"dt", 0.01}, {"steps", 8}};
  j["observation"] = {{"cameras",
                       {{{"width", 64}, {"height", 48}, {"eye", {0, 0.5, 1.0}}, {"target", {0, 0.05, 0}}},
                        {{"width", 40}, {"height", 30}, {"eye", {0.8, 0.4, 0.3}}, {"target", {0, 0.05, 0}}}}}};
  return j;
}

class Render : public CliTestFolder {
 protected:
  Render() : CliTestFolder("ssc-render-") {}
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  // Simulates the small scene into dir_/sim (PLY frames); returns the scene file.
  std::string simulate() {
    const std::string scene = write("scene.json", small_scene());
    std::string out, err;
    EXPECT_EQ(run("simulate '" + scene + "' --out '" + path("sim") + "' --device cpu --quiet", &out, &err), 0) << err;
    return scene;
  }
  int render(const std::string& args, std::string* err) {
    std::string out;
    return run("render " + args + " --quiet", &out, err);
  }
};

TEST_F(Render, FramesOfSimulateEqualObserve) {
  const std::string scene = simulate();
  std::string out, err;
  ASSERT_EQ(run("observe '" + scene + "' --out '" + path("obs") + "' --device cpu --quiet", &out, &err), 0) << err;
  ASSERT_EQ(render("'" + path("sim/frames") + "' --cameras '" + scene + "' --dt 0.01 --out '" + path("ren") + "'", &err), 0)
      << err;
  const ObservationSet a = read_observations(path("obs")), b = read_observations(path("ren"));
  ASSERT_EQ(b.frame_count, a.frame_count);
  EXPECT_EQ(b.dt, a.dt);
  EXPECT_EQ(b.first_frame_time, a.first_frame_time);
  EXPECT_EQ(b.depth_scale, a.depth_scale);
  ASSERT_EQ(b.cameras.size(), a.cameras.size());
  long measured = 0, differ = 0;
  for (int f = 0; f < a.frame_count; ++f)
    for (size_t c = 0; c < a.cameras.size(); ++c) {
      EXPECT_TRUE(b.cameras[c].camera_to_world.isApprox(a.cameras[c].camera_to_world, 1e-12));
      EXPECT_EQ(b.cameras[c].fx, a.cameras[c].fx);
      const DepthImage &x = a.frames[f][c], &y = b.frames[f][c];
      ASSERT_EQ(x.depth.size(), y.depth.size());
      for (size_t k = 0; k < x.depth.size(); ++k) {
        measured += x.depth[k] > 0;
        EXPECT_EQ(x.depth[k] > 0, y.depth[k] > 0) << "frame " << f << " camera " << c << " pixel " << k;
        EXPECT_LE(std::abs(x.depth[k] - y.depth[k]), 1.0000001 * a.depth_scale) << "frame " << f << " pixel " << k;
        differ += x.depth[k] != y.depth[k];
      }
    }
  EXPECT_GT(measured, 1000);  // the cameras see the body
  std::printf("render vs observe: %ld measured pixels, %ld differ by one quantisation step\n", measured, differ);
  const json manifest = read_json(dir_ / "ren" / "ssc.json");
  EXPECT_EQ(manifest.at("meshes").size(), 9u);
  EXPECT_EQ(manifest.at("meshes")[8].get<std::string>(), path("sim/frames") + "/frame_0008.ply");
}

// Times from a file, noise and seed, and an observation folder's cameras.json as the cameras file.
TEST_F(Render, TimesFileNoiseAndCamerasJson) {
  const std::string scene = simulate();
  std::string err;
  std::ofstream(path("times.txt")) << "# seconds\n0.5\n0.51\n0.52\n0.53\n0.54\n0.55\n0.56\n0.57\n0.58\n";
  ASSERT_EQ(render("'" + path("sim/frames/frame_*.ply") + "' --cameras '" + scene + "' --times '" + path("times.txt") +
                       "' --noise 0.002 --seed 7 --out '" + path("a") + "'",
                   &err),
            0)
      << err;
  const ObservationSet a = read_observations(path("a"));
  EXPECT_DOUBLE_EQ(a.first_frame_time, 0.5);
  EXPECT_NEAR(a.dt, 0.01, 1e-12);
  ASSERT_EQ(render("'" + path("sim/frames") + "' --cameras '" + path("a/cameras.json") +
                       "' --fps 100 --first-time 0.5 --noise 0.002 --seed 7 --out '" + path("b") + "'",
                   &err),
            0)
      << err;
  ASSERT_EQ(render("'" + path("sim/frames") + "' --cameras '" + scene + "' --fps 100 --out '" + path("c") + "'", &err), 0)
      << err;
  const ObservationSet b = read_observations(path("b")), c = read_observations(path("c"));
  double diff = 0;
  for (int f = 0; f < a.frame_count; ++f) {
    EXPECT_EQ(a.frames[f][1].depth, b.frames[f][1].depth);  // same seed, same noise
    for (size_t k = 0; k < a.frames[f][0].depth.size(); ++k)
      if (a.frames[f][0].depth[k] > 0 && c.frames[f][0].depth[k] > 0)
        diff = std::max(diff, std::abs(a.frames[f][0].depth[k] - c.frames[f][0].depth[k]));
  }
  EXPECT_GT(diff, 0.002);  // the noise is there
  EXPECT_LT(diff, 0.02);   // and about 2 mm
}

TEST_F(Render, BadInputsAreNamed) {
  const std::string scene = simulate();
  const std::string frames = "'" + path("sim/frames") + "'";
  std::string err;
  auto expect_error = [&](const std::string& args, const std::string& part) {
    EXPECT_EQ(render(args + " --out '" + path("out") + "'", &err), 2) << args;
    EXPECT_NE(err.find(part), std::string::npos) << args << "\n" << err;
    EXPECT_FALSE(fs::exists(path("out"))) << args;
  };
  expect_error("'" + path("nothing.ply") + "' --cameras '" + scene + "' --fps 60", "nothing.ply: no such file");
  fs::create_directories(path("empty"));
  expect_error("'" + path("empty") + "' --cameras '" + scene + "' --fps 60", "holds no .ply file");
  expect_error("'" + path("sim/nothing_*.ply") + "' --cameras '" + scene + "' --fps 60", "matches no .ply file");
  std::ofstream(path("blank.ply")).close();
  expect_error("'" + path("blank.ply") + "' --cameras '" + scene + "' --fps 60", "blank.ply' is empty");
  write("nocam.json", json{{"name", "no cameras"}});
  expect_error(frames + " --cameras '" + path("nocam.json") + "' --fps 60", "has no camera");
  write("zerocams.json", json{{"cameras", json::array()}});
  expect_error(frames + " --cameras '" + path("zerocams.json") + "' --fps 60", "at least one camera");
  std::ofstream(path("t3.txt")) << "0\n0.1\n0.2\n";
  expect_error(frames + " --cameras '" + scene + "' --times '" + path("t3.txt") + "'", "lists 3 times for 9 mesh frames");
  std::ofstream(path("uneven.txt")) << "0 0.01 0.02 0.03 0.045 0.05 0.06 0.07 0.08\n";
  expect_error(frames + " --cameras '" + scene + "' --times '" + path("uneven.txt") + "'", "is not one time");
  std::ofstream(path("uneven.json")) << "[0, 0.01, 0.02, 0.03, 0.045, 0.05, 0.06, 0.07, 0.08]";
  expect_error(frames + " --cameras '" + scene + "' --times '" + path("uneven.json") + "'", "evenly spaced frames only");
  expect_error(frames + " --cameras '" + scene + "'", "exactly one of --fps F, --dt S or --times FILE");
  expect_error(frames + " --cameras '" + scene + "' --fps 60 --dt 0.1", "exactly one of");
  json away = small_scene();
  away["observation"]["cameras"][0]["target"] = {0, 5, 0};
  away["observation"]["cameras"][1]["target"] = {0, 5, 0};
  expect_error(frames + " --cameras '" + write("away.json", away) + "' --fps 60", "no camera sees any of the 9 meshes");
}

}  // namespace
}  // namespace ssc
