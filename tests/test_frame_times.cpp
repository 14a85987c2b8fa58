// Frames with times of their own (cameras.json frame_times): a recording that dropped a frame
// and numbered its files on must fit exactly like the intact recording without that frame,
// while the same files without times (a renumbering) must not; bad times are InputErrors that
// name the file and the key.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "tests/expect_input_error.h"
#include "models/optim/reconstruction.h"
#include "models/sim/body.h"
#include "models/sim/observation_setup.h"
#include "models/sim/problem.h"

namespace ssc {
namespace {
namespace fs = std::filesystem;

struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name)
      : path(fs::temp_directory_path() / ("ssc_frame_times_" + std::to_string(::getpid()) + "_" + name)) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  std::string operator/(const std::string& name) const { return (path / name).string(); }
};

// The catalogue's ball (r = 0.1 m, 5 cm over the ground, 16x16 camera), 10 steps of 0.02 s:
// it falls, touches the ground at step 5 and is squashed, so every frame tells something.
const std::string kScene = std::string(SSC_SOURCE_DIR) + "/tests/catalogue/fixtures/ball.json";
const std::vector<std::string> kSteps = {"time.steps=10"};
constexpr int kDropped = 7;

const ObservationSet& rendered() {
  static const ObservationSet set = [] {
    const Scene scene = load_scene(kScene, kSteps);
    return render_observations(scene, build_body_grid(scene), parse_observation_spec(scene));
  }();
  return set;
}

ObservationSet without_frame(ObservationSet set, int f) {
  set.frames.erase(set.frames.begin() + f);
  set.frame_times.erase(set.frame_times.begin() + f);
  --set.frame_count;
  return set;
}

double fitted_youngs_modulus(const Problem& problem) {
  ReconstructionOptions o;
  o.fit = {"youngs_modulus"};
  o.starts = 1;  // from twice the scene's 5 kPa (much softer starts gain energy at dt = 0.02 s)
  o.initial_values = {Eigen::VectorXd::Constant(1, 10000.0)};
  o.optimizer_options.max_iterations = 12;
  const ReconstructionResult r = reconstruct(problem, o);
  for (const StartRecord& start : r.starts) EXPECT_FALSE(start.failed) << start.failure;
  return r.starts.at(std::size_t(r.best)).final[0];
}

TEST(FrameTimes, ObserveWritesTheTimesItRendersAt) {
  TempDir tmp("observe");
  const ObservationSet set = rendered();
  ASSERT_EQ(set.frame_count, 11);
  ASSERT_EQ(set.frame_times.size(), 11u);
  write_observations(tmp / "obs", set);
  const ObservationSet back = read_observations(tmp / "obs");
  for (int f = 0; f < 11; ++f) EXPECT_DOUBLE_EQ(frame_time(back, f), 0.02 * f);
  ASSERT_NE(camera_depth_noise(back, 0), nullptr);
  EXPECT_EQ(camera_depth_noise(back, 0)->sigma0_m, 0.0);
}

TEST(FrameTimes, ADroppedFrameIsAGapNotARenumbering) {
  TempDir tmp("gap");
  const ObservationSet intact = rendered();
  const ObservationSet gap = without_frame(intact, kDropped);
  ObservationSet renumbered = gap;  // what a naive exporter writes: no times, files 0..N-1
  renumbered.frame_times.clear();
  write_observations(tmp / "intact", intact);
  write_observations(tmp / "gap", gap);
  write_observations(tmp / "renumbered", renumbered);

  Problem reference = load_problem(kScene, kSteps, tmp / "intact");
  reference.frames.erase(reference.frames.begin() + kDropped);
  const Problem with_gap = load_problem(kScene, kSteps, tmp / "gap");
  const Problem naive = load_problem(kScene, kSteps, tmp / "renumbered");
  ASSERT_EQ(with_gap.frames.size(), reference.frames.size());
  for (std::size_t f = 0; f < reference.frames.size(); ++f) {
    EXPECT_EQ(with_gap.frames[f].step, reference.frames[f].step) << "frame " << f;
    EXPECT_EQ(with_gap.frames[f].points, reference.frames[f].points) << "frame " << f;
  }
  EXPECT_EQ(with_gap.frames.back().step, 10);
  EXPECT_EQ(naive.frames.back().step, 9);  // every frame after the gap one step early

  const double truth = reference.scene.material.youngs_modulus;
  const double e_reference = fitted_youngs_modulus(reference);
  const double e_gap = fitted_youngs_modulus(with_gap);
  const double e_naive = fitted_youngs_modulus(naive);
  std::printf("fitted E: intact without frame %d %.6g Pa, with the gap in frame_times %.6g Pa, renumbered %.6g Pa "
              "(truth %.6g Pa)\n", kDropped, e_reference, e_gap, e_naive, truth);
  EXPECT_DOUBLE_EQ(e_gap, e_reference);
  EXPECT_NEAR(e_reference, truth, 0.1 * truth);
  EXPECT_GT(std::abs(e_naive - e_reference), 0.02 * truth) << "the renumbered folder fits like the intact one";
}

// Writes the rendered set, lets `edit` change cameras.json, and expects load_problem to fail
// naming cameras.json and every part.
void expect_times_error(const std::string& name, const std::function<void(nlohmann::json&)>& edit,
                        std::vector<std::string> parts) {
  TempDir tmp(name);
  write_observations(tmp / "obs", rendered());
  const std::string file = tmp / "obs/cameras.json";
  nlohmann::json j = nlohmann::json::parse(std::ifstream(file));
  edit(j);
  std::ofstream(file) << j.dump(2);
  parts.push_back(file);
  SCOPED_TRACE(name);
  expect_input_error([&] { load_problem(kScene, kSteps, tmp / "obs"); }, parts);
}

TEST(FrameTimes, BadTimesNameTheFileAndKey) {
  expect_times_error("decreasing", [](nlohmann::json& j) { j["frame_times"][4] = 0.05; },
                     {"frame_times[4] = 0.05", "not after frame_times[3]", "increase strictly"});
  expect_times_error("equal", [](nlohmann::json& j) { j["frame_times"][3] = 0.04; },
                     {"frame_times[3]", "not after frame_times[2]"});
  expect_times_error("count", [](nlohmann::json& j) { j["frame_times"].erase(10); },
                     {"frame_times has 10 entries", "frame_count = 11"});
  expect_times_error("string", [](nlohmann::json& j) { j["frame_times"][2] = "0.04"; },
                     {"frame_times[2]", "must be a number"});
  expect_times_error("not_array", [](nlohmann::json& j) { j["frame_times"] = 0.02; },
                     {"frame_times", "array"});
  expect_times_error("milliseconds", [](nlohmann::json& j) {
    for (auto& t : j["frame_times"]) t = 1000 * t.get<double>();
  }, {"frame_times", "median", "milliseconds"});
  expect_times_error("first_frame_time", [](nlohmann::json& j) { j["first_frame_time"] = 0.1; },
                     {"first_frame_time", "frame_times[0]"});
  expect_times_error("off_step", [](nlohmann::json& j) { j["frame_times"][6] = 0.125; },
                     {"frame_times[6]", "0.25 steps", "time.dt"});
  expect_times_error("negative", [](nlohmann::json& j) {
    for (auto& t : j["frame_times"]) t = t.get<double>() - 0.04;
    j["first_frame_time"] = -0.04;
  }, {"frame_times[0]", "before the simulation starts"});
  expect_times_error("negative_noise", [](nlohmann::json& j) { j["depth_noise"] = {{"sigma0_m", -0.001}}; },
                     {"depth_noise"});
  // Within the tolerance (a timestamp written with few digits) is the nearest step.
  TempDir tmp("rounded");
  ObservationSet set = rendered();
  set.frame_times[3] = 0.0600004;
  write_observations(tmp / "obs", set);
  EXPECT_EQ(load_problem(kScene, kSteps, tmp / "obs").frames[3].step, 3);
}

TEST(FrameTimes, TwoFramesOnOneStepAreRefused) {
  // 0.0399999 s and 0.04 s are both within the tolerance of step 2 (time.dt = 0.02 s).
  expect_times_error("same_step", [](nlohmann::json& j) { j["frame_times"][1] = 0.0399999; },
                     {"frame_times[1]", "frame_times[2]", "same simulation step", "time.dt"});
}

}  // namespace
}  // namespace ssc
