// Trust: output folders that never take a user's file, checks that stop a wrong run from
// passing as a result (energy audit, start inside the ground, volume lost, unmatched
// points), and one name per parameter across --set, --fit and result.json.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "expect_input_error.h"
#include "models/io/output_dir.h"
#include "models/io/text_file.h"
#include "models/io/run_record.h"
#include "models/optim/reconstruction.h"
#include "models/sim/body.h"
#include "models/sim/deformed_surface.h"
#include "models/sim/match_check.h"
#include "models/sim/observation_setup.h"
#include "models/observation/depth_render.h"
#include "models/sim/parameters.h"
#include "models/sim/problem.h"
#include "models/sim/scene.h"
#include "models/sim/simulation.h"

namespace ssc {
namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;

struct Sandbox {
  fs::path path;
  Sandbox() : path(fs::temp_directory_path() / ("ssc_trust_" + std::to_string(::getpid()))) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~Sandbox() { fs::remove_all(path); }
  std::string operator/(const std::string& name) const { return (path / name).string(); }
};

void spit(const std::string& path, const std::string& text) { std::ofstream(path) << text; }
std::string slurp(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST(OutputFolder, NewFolderAppearsWithItsManifestOnlyOnCommit) {
  Sandbox box;
  {
    OutputDir out(box / "run");
    spit(out.file("a.txt"), "1");
    out.manifest()["device"] = "cpu";
    EXPECT_FALSE(fs::exists(box / "run"));
    EXPECT_TRUE(fs::exists(box / ".run.ssc-lock"));
    out.commit();
  }
  EXPECT_EQ(slurp(box / "run/a.txt"), "1");
  EXPECT_FALSE(fs::exists(box / ".run.ssc-lock"));
  const json m = json::parse(slurp(box / "run/ssc.json"));
  EXPECT_EQ(m["ssc_output"], true);
  EXPECT_EQ(m["status"], "complete");
  EXPECT_EQ(m["exit_status"], 0);
  EXPECT_EQ(m["device"], "cpu");
  EXPECT_EQ(m["ssc_version"], SSC_VERSION);
  for (const char* key : {"ssc_commit", "command_line", "started", "ended", "warnings"}) EXPECT_TRUE(m.contains(key)) << key;
  // Only the folder itself is left beside it.
  EXPECT_EQ(std::distance(fs::directory_iterator(box.path), fs::directory_iterator{}), 1);
}

TEST(OutputFolder, ReplacesOnlyItsOwnFoldersAtomically) {
  Sandbox box;
  {
    OutputDir out(box / "run");
    spit(out.file("old.txt"), "old");
    out.commit();
  }
  {
    OutputDir out(box / "run");
    spit(out.file("new.txt"), "new");
    EXPECT_EQ(slurp(box / "run/old.txt"), "old");  // untouched until commit
    out.commit();
  }
  EXPECT_FALSE(fs::exists(box / "run/old.txt"));
  EXPECT_EQ(slurp(box / "run/new.txt"), "new");
  // An uncommitted run keeps the previous output and leaves nothing behind.
  { OutputDir out(box / "run"); spit(out.file("half.txt"), "x"); }
  EXPECT_EQ(slurp(box / "run/new.txt"), "new");
  EXPECT_EQ(std::distance(fs::directory_iterator(box.path), fs::directory_iterator{}), 1);
  // An empty folder is taken.
  fs::create_directories(box / "empty");
  { OutputDir out(box / "empty"); spit(out.file("x"), "x"); out.commit(); }
  EXPECT_TRUE(fs::exists(box / "empty/x"));
}

TEST(OutputFolder, RefusesWhatSscDidNotMake) {
  Sandbox box;
  fs::create_directories(box / "mine");
  spit(box / "mine/precious.txt", "keep");
  spit(box / "file.txt", "keep");
  fs::create_directories(box / "fake");
  spit(box / "fake/ssc.json", "{\"ssc_output\": false}");
  fs::create_directory_symlink(box / "mine", box / "link");
  expect_input_error([&] { OutputDir out(box / "mine"); }, {"mine", "ssc did not make"});
  expect_input_error([&] { OutputDir out(box / "fake"); }, {"ssc did not make"});
  expect_input_error([&] { OutputDir out(box / "file.txt"); }, {"is a file"});
  expect_input_error([&] { OutputDir out(box / "link"); }, {"symbolic link"});
  expect_input_error([&] { OutputDir out("/"); }, {"root"});
  expect_input_error([&] { OutputDir out("."); }, {"working folder"});
  expect_input_error([&] { OutputDir out(".."); }, {"working folder"});
  expect_input_error([&] { OutputDir out(box.path.string(), {box / "mine/scene.json"}); }, {"holds the input"});
  expect_input_error([&] { OutputDir out(box / "mine", {box / "mine"}); }, {"holds the input"});
  const char* home = std::getenv("HOME");
  if (home && *home) expect_input_error([&] { OutputDir out(home); }, {"home folder"});
  EXPECT_EQ(slurp(box / "mine/precious.txt"), "keep");
  EXPECT_EQ(slurp(box / "file.txt"), "keep");
  EXPECT_FALSE(fs::exists(box / ".mine.ssc-lock"));
}

TEST(OutputFolder, AUserFileInsideAnOutputKeepsItFromBeingReplaced) {
  Sandbox box;
  { OutputDir out(box / "run"); spit(out.file("a.txt"), "1"); out.commit(); }
  spit(box / "run/notes.txt", "mine");
  expect_input_error([&] { OutputDir out(box / "run"); }, {"notes.txt", "did not write"});
  // ... also when it appears while the run is writing.
  fs::remove(box / "run/notes.txt");
  {
    OutputDir out(box / "run");
    spit(box / "run/notes.txt", "mine");
    expect_input_error([&] { out.commit(); }, {"notes.txt"});
  }
  EXPECT_EQ(slurp(box / "run/notes.txt"), "mine");
  EXPECT_EQ(slurp(box / "run/a.txt"), "1");
}

TEST(OutputFolder, ALockKeepsASecondWriterOff) {
  Sandbox box;
  OutputDir first(box / "run");
  expect_input_error([&] { OutputDir second(box / "run"); }, {"another ssc run"});
  first.commit();
}

TEST(OutputFolder, StaleTemporaryFoldersOfDeadRunsAreRemoved) {
  Sandbox box;
  // A process id that cannot be running: beyond the kernel's pid range.
  char host[256] = {0};
  gethostname(host, sizeof host - 1);
  const std::string stale = box / ".run.ssc-tmp-99999999";
  fs::create_directories(stale);
  spit(stale + "/ssc.json", json{{"ssc_output", true}, {"status", "running"}, {"pid", 99999999}, {"host", host}}.dump());
  // Left alone: a folder that is not ssc's, and one whose manifest names another process
  // (a user's copy named like ours).
  const std::string foreign = box / ".run.ssc-tmp-99999998";
  fs::create_directories(foreign);
  const std::string copy = box / ".run.ssc-old-99999997";
  fs::create_directories(copy);
  spit(copy + "/ssc.json", json{{"ssc_output", true}, {"pid", 12}, {"host", host}}.dump());
  { OutputDir out(box / "run"); out.commit(); }
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(foreign));
  EXPECT_TRUE(fs::exists(copy));
}

TEST(OutputFolder, InterruptCleanupRemovesUnfinishedFolders) {
  Sandbox box;
  OutputDir out(box / "run");
  spit(out.file("partial"), "x");
  remove_unfinished_outputs();
  EXPECT_FALSE(fs::exists(out.path()));
  EXPECT_FALSE(fs::exists(box / ".run.ssc-lock"));
}

// What `ssc simulate` does when interrupted: the clean-up runs while the command is still
// adding frames. Nothing of the output may be left, however the two interleave.
TEST(OutputFolder, InterruptCleanupWhileTheCommandWritesLeavesNothing) {
  Sandbox box;
  for (int trial = 0; trial < 40; ++trial) {
    OutputDir out(box / "run");
    std::atomic<bool> started{false}, stop{false};
    std::thread writer([&] {
      try {
        const std::string frames = out.make_folder("frames");
        for (int f = 0; !stop; ++f) {
          write_text_file(frames + "/frame_" + std::to_string(f) + ".ply", std::string(2000, 'x'));
          started = true;
        }
      } catch (const InputError&) {  // the folder is gone: the write fails
      }
    });
    while (!started) std::this_thread::yield();
    std::this_thread::sleep_for(std::chrono::microseconds(200 * (trial % 5)));
    remove_unfinished_outputs();
    stop = true;
    writer.join();
    std::vector<std::string> left;
    for (const auto& e : fs::directory_iterator(box.path)) left.push_back(e.path().filename().string());
    ASSERT_TRUE(left.empty()) << "trial " << trial << ": " << left.front() << " was left";
  }
}

TEST(RunRecord, HeldWarningsArePrintedOnceAtTheEnd) {
  clear_warnings();
  hold_warnings();
  testing::internal::CaptureStderr();
  warn("first", "the first warning");
  warn("second", "the second warning");
  warn("first", "the first warning");  // recorded once
  const std::string while_running = testing::internal::GetCapturedStderr();
  testing::internal::CaptureStderr();
  print_held_warnings();
  print_held_warnings();  // nothing new
  const std::string at_end = testing::internal::GetCapturedStderr();
  hold_warnings(false);
  EXPECT_EQ(while_running, "");
  EXPECT_EQ(at_end, "ssc: warning: the first warning\nssc: warning: the second warning\n");
  EXPECT_EQ(warnings_json().size(), 2u);
  clear_warnings();
}

json falling_box(double stiffness, double alpha, double dt) {
  return json{{"object", {{"primitive", "box"}, {"half_extents", {0.1, 0.1, 0.1}}, {"position", {0, 0.25, 0}}}},
              {"grid", {{"cell_size", 0.05}}},
              {"material", {{"youngs_modulus", 5e4}, {"poisson_ratio", 0.35}, {"density", 500}, {"mass_damping", 0},
                            {"stiffness_damping", 0}}},
              {"initial", {{"linear_velocity", {0, -1.1, 0}}}},
              {"ground", {{"height", 0}, {"angles_deg", {20, 0}}, {"stiffness", stiffness}, {"softmin_alpha", alpha}}},
              {"time", {{"dt", dt}, {"steps", 200}, {"theta", 0.6}}}};
}

TEST(EnergyAudit, FreeFallConservesTheAuditedEnergy) {
  json j = falling_box(1e5, 100, 0.005);
  j.erase("ground");
  const Scene scene = parse_scene(j, "fall.json");
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid);
  const double e0 = sim.kinetic_energy(0) + sim.gravitational_energy(0);
  for (int s = 0; s < 40; ++s) sim.step();
  const double e1 = sim.kinetic_energy(0) + sim.gravitational_energy(0) + sim.elastic_energy(0);
  // A rigid fall under the theta-scheme loses (theta - 1/2) g^2 dt^2 m per step of energy at most.
  EXPECT_LE(e1, e0 + 1e-9);
  EXPECT_NEAR(e1, e0, 0.01 * e0);
}

TEST(EnergyAudit, ContactPotentialIsTheForcePotential) {
  // -dU/dd must be the soft-min penalty force -k A softmin(d) (ops/contact.h) at every
  // depth: central differences of Simulation::contact_energy under a rigid vertical shift
  // against the sum of the penalty forces of all contact points.
  json j = falling_box(1e5, 50, 0.005);
  j["ground"] = {{"height", 0}, {"stiffness", 1e5}, {"softmin_alpha", 50}};
  j["object"]["position"] = {0, 0.2, 0};
  const Scene scene = parse_scene(j, "contact.json");
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid);
  auto softmin = [](double d) {
    const double y = -50 * d;
    return -(y > 0 ? y + std::log1p(std::exp(-y)) : std::log1p(std::exp(y))) / 50;
  };
  auto energy_at = [&](double shift) {
    Simulation::State s = sim.state(0);
    for (int i = 0; i < grid.node_count; ++i) s.u[3 * i + 1] = shift;
    sim.set_state(0, s, 0);
    return sim.contact_energy(0);
  };
  for (double shift : {-0.05, -0.1, -0.11, -0.15}) {
    const double h = 1e-6;
    const double force = -(energy_at(shift + h) - energy_at(shift - h)) / (2 * h);
    double expected = 0;
    for (const ContactPoint& c : grid.contact_points) {
      const double y = c.at(grid.node_rest, 1);
      expected += -1e5 * c.area * softmin(y + shift);
    }
    EXPECT_NEAR(force, expected, 1e-5 * std::abs(expected) + 1e-9) << "shift " << shift;
  }
}

TEST(EnergyAudit, StiffContactThatGainsEnergyIsASimulationError) {
  // The case: stiffness 1e9 Pa/m with soft-min 2e4 /m at dt = 1/600 s raised the
  // kinetic energy from 2.4 J to over 1000 J.
  json j = falling_box(1e9, 2e4, 1.0 / 600);
  j["object"]["position"] = {0, 0.3, 0};
  j["object"]["rotation_deg"] = {0, 0, 20};
  j["grid"]["cell_size"] = 0.04;
  const Scene scene = parse_scene(j, "stiff.json");
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid);
  try {
    for (int s = 0; s < 300; ++s) sim.step();
    ADD_FAILURE() << "no SimulationError";
  } catch (const SimulationError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("gained energy"), std::string::npos) << m;
    EXPECT_NE(m.find("time.dt"), std::string::npos) << m;
  }
}

TEST(EnergyAudit, SoftContactPassesAndZeroToleranceTurnsItOff) {
  const Scene soft = parse_scene(falling_box(1e5, 100, 0.005), "soft.json");
  const SimGrid grid = build_body_grid(soft);
  Simulation sim(soft, grid);
  for (int s = 0; s < 150; ++s) sim.step();  // bounces without a word
  json off = falling_box(1e9, 2e4, 1.0 / 600);
  off["solver"] = {{"energy_tolerance", 0}};
  off["time"]["steps"] = 20;
  const Scene scene = parse_scene(off, "off.json");
  const SimGrid g2 = build_body_grid(scene);
  Simulation unchecked(scene, g2);
  for (int s = 0; s < 20; ++s) unchecked.step();
}

TEST(RunChecks, BodyStartingInsideTheGroundIsRefused) {
  json j = falling_box(1e5, 100, 0.005);
  j["object"]["position"] = {0, 0.02, 0};
  const Scene scene = parse_scene(j, "inside.json");
  const SimGrid grid = build_body_grid(scene);
  expect_input_error([&] { Simulation sim(scene, grid); }, {"inside.json", "inside ground plane 0", "object.position"});
  // A fit's start that moves the plane into the body fails that start only.
  j["object"]["position"] = {0, 0.25, 0};
  const Scene ok = parse_scene(j, "ok.json");
  const SimGrid g2 = build_body_grid(ok);
  Simulation sim(ok, g2);
  PhysicalParameters p = sim.parameters(0);
  p.planes[0].height = 0.3;
  EXPECT_THROW(sim.set_parameters(0, p), SimulationError);
}

TEST(RunChecks, ANodeFarBeyondAnyPossibleMotionIsAnExplosion) {
  json j = falling_box(1e5, 100, 0.005);
  j.erase("ground");
  const Scene scene = parse_scene(j, "far.json");
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid);
  sim.step();
  Simulation::State s = sim.state(0);
  s.u[0] = 50;  // 50 m after one step of a 0.2 m box falling at 1.1 m/s
  sim.set_state(0, s, 1);
  EXPECT_THROW(sim.step(), SimulationError);
}

TEST(RunChecks, GridThatLosesMostOfTheBodyIsRefusedAndSomeLossIsAWarning) {
  json j = falling_box(1e5, 100, 0.005);
  j["object"] = {{"primitive", "torus"}, {"major_radius", 0.3}, {"minor_radius", 0.05}, {"position", {0, 0.5, 0}}};
  j["grid"] = {{"cell_size", 0.12}};  // keeps 6 % of the ring's volume
  expect_input_error([&] { build_body_grid(parse_scene(j, "coarse.json")); }, {"coarse.json", "grid.cell_size", "%"});
  clear_warnings();
  j["grid"] = {{"cell_size", 0.04}};
  const SimGrid grid = build_body_grid(parse_scene(j, "torus.json"));
  const double volume = primitive_volume(parse_scene(j, "torus.json").object.primitive);
  if (std::abs(grid.total_volume / volume - 1) > kVolumeLossWarning)
    EXPECT_FALSE(warnings().empty());
  else
    EXPECT_TRUE(warnings().empty());
  clear_warnings();
}

TEST(RunChecks, InvertedCellsAreCounted) {
  const Scene scene = parse_scene(falling_box(1e5, 100, 0.005), "inv.json");
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid);
  EXPECT_EQ(sim.inverted_cell_count(0), 0);
  Simulation::State s = sim.state(0);
  for (int i = 0; i < grid.node_count; ++i) s.u[3 * i + 1] = -2 * (grid.node_rest[3 * i + 1] - 0.25);  // mirror in y
  sim.set_state(0, s, 0);
  EXPECT_EQ(sim.inverted_cell_count(0), grid.cell_count);
}

TEST(MatchCheck, FewMatchesAreAnErrorAndUnsegmentedDepthAWarning) {
  clear_warnings();
  std::vector<FrameCost> frames(3);
  for (FrameCost& f : frames) f.points = 1000, f.matched = 950;
  check_matches(frames, "obs", "the best fit");
  EXPECT_TRUE(warnings().empty());
  for (FrameCost& f : frames) f.matched = 500;  // half of every frame is floor
  check_matches(frames, "obs", "the best fit");
  ASSERT_EQ(warnings().size(), 1u);
  EXPECT_EQ(warnings()[0].code, "unsegmented_depth");
  frames[1].matched = 900;  // one clean frame: the floor is not in every frame
  clear_warnings();
  check_matches(frames, "obs", "the best fit");
  EXPECT_TRUE(warnings().empty());
  for (FrameCost& f : frames) f.matched = 0;
  expect_input_error([&] { check_matches(frames, "obs", "the best fit"); }, {"obs", "0 of 3000", "camera_to_world"});
  for (FrameCost& f : frames) f.points = 0;
  expect_input_error([&] { check_matches(frames, "obs", "x"); }, {"no depth measurement"});
  clear_warnings();
}

// Renders the torus example's first 6 steps with a floor quad at height floor_y into `dir`.
void render_torus_with_floor(const Scene& scene, double floor_y, const std::string& dir) {
  const ObservationSpec spec = parse_observation_spec(scene);
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid);
  const DeformedSurface surface(grid);
  ObservationSet set;
  set.dt = scene.time.dt;
  set.depth_scale = spec.depth_scale;
  set.cameras = spec.cameras;
  for (int f = 0; f <= scene.time.steps; ++f) {
    if (f > 0) sim.step();
    std::vector<Eigen::Vector3d> v = surface.positions(sim.displacement(0));
    std::vector<std::array<int, 3>> t = surface.triangles();
    const int base = int(v.size());
    for (double x : {-6.0, 6.0})
      for (double z : {-6.0, 6.0}) v.emplace_back(x, floor_y, z);
    t.push_back({base, base + 1, base + 3});
    t.push_back({base, base + 3, base + 2});
    const TriangleBvh bvh(v, t);
    std::vector<DepthImage> images;
    for (const DepthCamera& cam : set.cameras) images.push_back(render_depth(cam, bvh, 0.0, 1));
    set.frames.push_back(images);
  }
  set.frame_count = int(set.frames.size());
  write_observations(dir, set);
}

// The case: depth images with the floor left in (not segmented). Rendered here with a
// floor quad under the torus; the cost at the true parameters must not pass silently. A floor
// on the scene's ground plane is refused when the observations are loaded
// (models/sim/plane_points.h); one the scene does not know (30 cm lower) is left to the match
// check.
TEST(MatchCheck, DepthWithTheFloorLeftInIsNotSilent) {
  Sandbox box;
  Scene scene = load_scene(std::string(SSC_SOURCE_DIR) + "/examples/torus.json", {"time.steps=6"});
  render_torus_with_floor(scene, 0.0, box / "floor");
  expect_input_error([&] { load_problem(scene.file, {"time.steps=6"}, box / "floor"); },
                     {"floor", "ground.planes[0]", "segment the body"});
  render_torus_with_floor(scene, -0.3, box / "obs");
  const Problem problem = load_problem(scene.file, {"time.steps=6"}, box / "obs");
  Simulation fit(problem.scene, problem.grid, 1, true);
  const SurfaceConstraintCost cost(problem.grid, problem.phi_max);
  const CostGradient r = evaluate_cost_gradient(fit, cost, problem.frames)[0];
  clear_warnings();
  bool refused = false;
  try {
    check_matches(r.frames, box / "obs", "the true parameters");
  } catch (const InputError& e) {
    refused = std::string(e.what()).find("not segmented") != std::string::npos;
  }
  bool warned = false;
  for (const Warning& w : warnings()) warned |= w.code == "unsegmented_depth";
  EXPECT_TRUE(refused || warned) << "the floor in the depth passed without a word";
  // A fit keeps its best point's frames, which `reconstruct` checks the same way.
  ReconstructionOptions ro;
  ro.fit = {"youngs_modulus"};
  ro.starts = 1;
  ro.optimizer_options.max_iterations = 1;
  const ReconstructionResult fit_result = reconstruct(problem, ro);
  ASSERT_GE(fit_result.best, 0);
  const StartRecord& best = fit_result.starts[fit_result.best];
  ASSERT_EQ(best.frames.size(), problem.frames.size());
  int matched = 0;
  for (const FrameCost& f : best.frames) matched += f.matched;
  EXPECT_EQ(matched, best.matched_points);
  clear_warnings();
  try {
    check_matches(best.frames, box / "obs", "the best fit");
  } catch (const InputError&) {
  }
  warned = refused;
  for (const Warning& w : warnings()) warned |= w.code == "unsegmented_depth";
  EXPECT_TRUE(warned);
  clear_warnings();
}

TEST(ParameterNames, SetTakesTheNamesThatResultJsonWrites) {
  Sandbox box;
  const std::string path = box / "scene.json";
  json j = falling_box(1e5, 100, 0.005);
  j["ground"] = {{"planes", json::array({{{"height", 0}}, {{"height", -1}, {"normal", {0, 1, 0}}}})}};
  spit(path, j.dump());
  const Scene base = load_scene(path);
  const PhysicalParameters p = PhysicalParameters::from_scene(base);
  // Every parameter, set by the argument result.json would list, reads back its value.
  for (const std::string& name : all_parameter_names(p)) {
    double value = get_parameter(p, name) + 0.25;
    if (name.find("polar") != std::string::npos) value = 12.5;
    if (name.find("azimuth") != std::string::npos) value = 30;
    if (name == "poisson_ratio") value = 0.3;
    const std::string arg = parameter_set_argument(p, name, value);
    EXPECT_NEAR(get_parameter(PhysicalParameters::from_scene(load_scene(path, {arg})), name), value, 1e-9) << arg;
  }
  // Scene-key spellings name the same parameter; a name twice is refused.
  EXPECT_EQ(expand_parameter_names({"material.youngs_modulus"}, p), std::vector<std::string>{"youngs_modulus"});
  EXPECT_EQ(expand_parameter_names({"ground.planes[0].height"}, p), std::vector<std::string>{"ground.height"});
  expect_input_error([&] { expand_parameter_names({"youngs_modulus", "material.youngs_modulus"}, p); }, {"twice"});
  expect_input_error([&] { expand_parameter_names({"gravity", "gravity.y"}, p); }, {"gravity.y", "twice"});
  expect_input_error([&] { load_scene(path, {"youngs_modulus=0"}); }, {"scene.json", "youngs_modulus", "positive"});
  expect_input_error([&] { load_scene(path, {"ground.planes[5].height=1"}); }, {"2 ground plane"});
  EXPECT_EQ(parameter_value_error("poisson_ratio", 0.5).empty(), false);
  EXPECT_EQ(parameter_value_error("gravity.y", -20).empty(), true);
}

TEST(ParameterNames, NonFiniteOverridesSaySo) {
  Sandbox box;
  const std::string path = box / "scene.json";
  spit(path, falling_box(1e5, 100, 0.005).dump());
  for (const char* v : {"NaN", "nan", "inf", "-Infinity", "1e400", "-1e999"})
    expect_input_error([&] { load_scene(path, {std::string("material.density=") + v}); }, {"not a finite number", "scene.json"});
  expect_input_error([&] { load_scene(box.path.string()); }, {"is a folder"});
}

}  // namespace
}  // namespace ssc
