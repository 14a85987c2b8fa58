// `ssc residuals` and `ssc diagnose` through the command line, as a user runs them:
//  - residuals of a cube thrown onto the ground with friction 0.4: at the true parameters they
//    are the depth noise (1 mm) everywhere; without friction they grow after the landing, and
//    the phases say where;
//  - diagnose names friction hidden in data made with half the fit's time step, and says
//    "none" for clean data made with half the fit's time step (the base model never matches
//    exactly, as with a real recording);
//  - bad input (a missing or malformed --params, an unknown candidate) is an input error that
//    writes nothing;
//  - the identifiability measure (parameter_correlation) finds the classic pair, air drag and
//    mass damping, and not the Young's modulus against either.
// The benchmark of every effect and strength is tools/diagnosis-benchmark.sh (docs/diagnosis.md).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "models/diagnosis/diagnosis.h"
#include "models/diagnosis/measurement_fit.h"
#include "models/diagnosis/model_fit.h"
#include "models/sim/problem.h"
#include "models/sim/parameters.h"
#include "runtime/errors.h"
#include "tests/cli_test_folder.h"
#include "tests/gpu_test_support.h"

namespace ssc {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// A 0.2 m cube thrown from 0.45 m at 1.5 m/s across, landing at about 0.3 s, bouncing and
// tumbling. Its faces are off the grid planes (see docs/diagnosis.md for why that matters).
json cube_scene(double dt, double friction, double youngs, bool observation) {
  json j;
  j["object"] = {{"primitive", "box"}, {"half_extents", {0.1, 0.1, 0.1}}, {"position", {0.013, 0.4512, 0.007}}};
  j["grid"] = {{"cell_size", 0.05}};
  j["material"] = {{"youngs_modulus", youngs}, {"poisson_ratio", 0.3}, {"density", 200}, {"mass_damping", 0.0},
                   {"stiffness_damping", 0.005}};
  j["initial"] = {{"linear_velocity", {1.5, 0.5, 0}}};
  j["ground"] = {{"stiffness", 1e5}, {"softmin_alpha", 300}};
  if (friction > 0) j["ground"]["friction"] = friction;
  j["time"] = {{"dt", dt}, {"steps", int(std::round(0.8 / dt))}, {"theta", 0.6}};
  j["solver"] = {{"contact", "implicit"}};
  if (observation)
    j["observation"] = {{"every", int(std::round(0.04 / dt))},
                        {"noise", 0.001},
                        {"seed", 7},
                        {"cameras",
                         {{{"name", "cam"}, {"width", 64}, {"height", 48}, {"eye", {0.6, 0.6, 1.8}},
                           {"target", {0.6, 0.2, 0}}, {"fov_deg", 55}}}}};
  return j;
}

class DiagnoseCli : public CliTestFolder {
 protected:
  DiagnoseCli() : CliTestFolder("ssc-diagnose-") {}
  void observe(const json& scene, const std::string& name) {
    std::string out, err;
    const std::string path = write(name + ".json", scene);
    ASSERT_EQ(run("observe '" + path + "' --out '" + (dir_ / name).string() + "' --device cpu --quiet", &out, &err), 0)
        << err;
  }
  // cameras.json's fx and fy times `factor`, as a wrong calibration would write them.
  void scale_focal_lengths(const std::string& observations, double factor) {
    const fs::path cameras = dir_ / observations / "cameras.json";
    json c = read_json(cameras);
    for (json& cam : c["cameras"]) cam["fx"] = cam["fx"].get<double>() * factor, cam["fy"] = cam["fy"].get<double>() * factor;
    std::ofstream(cameras) << c.dump(1);
  }
  json diagnose(const json& fit, const std::string& observations, const std::string& out_name) {
    std::string out, err;
    const std::string path = write("fit.json", fit);
    const int code = run("diagnose '" + path + "' --observations '" + (dir_ / observations).string() + "' --out '" +
                             (dir_ / out_name).string() + "' --starts 3 --iterations 15 --device cpu",
                         &out, &err);
    std::printf("%s", out.c_str());
    EXPECT_EQ(code, 0) << err;
    return code == 0 ? read_json(dir_ / out_name / "diagnosis.json") : json();
  }
};

TEST_F(DiagnoseCli, ResidualsAreTheNoiseAtTheTruthAndGrowWhereTheModelMissesFriction) {
  observe(cube_scene(0.01, 0.4, 5e4, true), "obs");
  const std::string truth = write("truth.json", json{{"parameters", {{"ground.friction", 0.4}}},
                                                     {"set", {"ground.friction=0.4"}}});
  const std::string scene = write("scene.json", cube_scene(0.01, 0.0, 5e4, false));
  std::string out, err;
  ASSERT_EQ(run("residuals '" + scene + "' --observations '" + (dir_ / "obs").string() + "' --params '" + truth +
                    "' --out '" + (dir_ / "at_truth").string() + "' --device cpu",
                &out, &err),
            0)
      << err;
  std::printf("%s", out.c_str());
  ASSERT_EQ(run("residuals '" + scene + "' --observations '" + (dir_ / "obs").string() + "' --out '" +
                    (dir_ / "no_friction").string() + "' --device cpu",
                &out, &err),
            0)
      << err;
  std::printf("%s", out.c_str());
  const json truth_summary = read_json(dir_ / "at_truth" / "residuals.json");
  const json wrong = read_json(dir_ / "no_friction" / "residuals.json");
  for (const char* f : {"residuals.csv", "residuals.json", "residual_vs_time.svg", "report.html"})
    EXPECT_TRUE(fs::exists(dir_ / "at_truth" / f)) << f;
  // One CSV row per observed point.
  std::ifstream csv(dir_ / "at_truth" / "residuals.csv");
  int rows = -1;
  for (std::string line; std::getline(csv, line);) ++rows;
  EXPECT_EQ(rows, truth_summary["all"]["points"].get<int>());
  const double rms_truth = truth_summary["all"]["rms_m"], rms_wrong = wrong["all"]["rms_m"];
  std::printf("RMS residual: %.3f mm at the truth, %.3f mm without friction\n", 1e3 * rms_truth, 1e3 * rms_wrong);
  EXPECT_GT(truth_summary["all"]["matched_fraction"].get<double>(), 0.95);
  EXPECT_LT(rms_truth, 0.002);  // the 1 mm depth noise, seen along the surface normal
  EXPECT_GT(rms_wrong, 3 * rms_truth);
  EXPECT_TRUE(truth_summary["by_phase"].contains("flight"));
  EXPECT_TRUE(truth_summary["by_phase"].contains("contact with plane 0"));
  EXPECT_FALSE(truth_summary["contact_times_s"].empty());
  // Without friction the disagreement is in contact, not in flight.
  EXPECT_LT(wrong["by_phase"]["flight"]["rms_m"].get<double>(), 2 * rms_truth);
  EXPECT_GT(wrong["by_phase"]["contact with plane 0"]["rms_m"].get<double>(), 3 * rms_truth);
}

TEST_F(DiagnoseCli, NamesFrictionHiddenInDataFromASmallerTimeStep) {
  observe(cube_scene(0.005, 0.4, 5e4, true), "obs");
  const json d = diagnose(cube_scene(0.01, 0.0, 1.25e5, false), "obs", "diag");
  ASSERT_FALSE(d.is_null());
  EXPECT_EQ(d["cause"], "friction");
  // The identifiability at the friction fit: over the base, friction, the other extensions
  // that share its graph and the mass damping; friction is among the determined parameters.
  const json& id = d["identifiability"];
  EXPECT_EQ(id["failure"], "");
  const std::vector<std::string> determined = id["parameters"];
  EXPECT_NE(std::find(determined.begin(), determined.end(), "ground.friction"), determined.end());
  EXPECT_EQ(id["correlation"].size(), determined.size());
  // Friction's event is the landing, in the held-in frames; after it, friction pays for its
  // parameter (the Akaike difference is negative).
  for (const json& c : d["candidates"])
    if (c["name"] == "friction") {
      EXPECT_GT(c["event"]["frame"].get<int>(), 0);
      EXPECT_LT(c["event"]["frame"].get<int>(), d["heldin_frames"].get<int>());
      EXPECT_LT(c["event"]["aic_difference"].get<double>(), 0);
      EXPECT_GT(c["event"]["heldin_gain"].get<double>(), 0.2);
    }
  // The slices through the friction fit: the base's modulus and friction, each span around its
  // fitted value; the cube lands and slides, so friction is fixed on both sides.
  ASSERT_EQ(d["slices"].size(), 2u);
  for (const json& s : d["slices"]) {
    EXPECT_LE(s["low"].get<double>(), s["fitted"].get<double>()) << s["parameter"];
    EXPECT_GE(s["high"].get<double>(), s["fitted"].get<double>()) << s["parameter"];
    EXPECT_EQ(s["values"].size(), s["costs"].size());
    if (s["parameter"] == "ground.friction") {
      EXPECT_FALSE(s["open_low"] || s["open_high"]);
    }
  }
  const std::string html = [&] {
    std::ifstream in(dir_ / "diag" / "report.html");
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }();
  EXPECT_NE(html.find("friction"), std::string::npos);
  EXPECT_NE(html.find("<svg"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir_ / "diag" / "residuals_friction.csv"));
  // The cause refitted on each control's discretization (half the cell size, half the time
  // step), from its fit: its values there, and a line that says whether they moved.
  for (const char* control : {"finer_grid", "finer_step"}) {
    const json& g = d[std::string("cause_on_") + control];
    ASSERT_TRUE(g.is_object()) << control;
    ASSERT_TRUE(g["fitted"].get<bool>()) << g.dump();
    EXPECT_NE(g["what"].get<std::string>().find(control == std::string("finer_grid") ? "grid.cell_size" : "time.dt"),
              std::string::npos);
    EXPECT_GT(g["parameters"]["ground.friction"].get<double>(), 0);
    EXPECT_GT(g["parameters"]["youngs_modulus"].get<double>(), 0);
    EXPECT_EQ(g["convergence"]["starts"], 1);
    const std::string said = g["moved"].empty() ? "moves no parameter"
                             : control == std::string("finer_grid") ? "depend on the grid"
                                                                    : "depend on the time step";
    bool told = false;  // by the line that names this control's discretization
    for (const json& line : d["lines"]) {
      const std::string l = line.get<std::string>();
      told |= l.find(g["what"].get<std::string>()) != std::string::npos && l.find(said) != std::string::npos;
    }
    EXPECT_TRUE(told) << d["lines"].dump(1);
    for (const json& m : g["moved"])
      EXPECT_GE(std::abs(m[control].get<double>() / m["fit"].get<double>() - 1), 0.1) << m.dump();
  }
}

TEST_F(DiagnoseCli, SaysNoneForCleanDataFromASmallerTimeStep) {
  observe(cube_scene(0.005, 0.0, 5e4, true), "obs");
  const json d = diagnose(cube_scene(0.01, 0.0, 1.25e5, false), "obs", "diag");
  ASSERT_FALSE(d.is_null());
  EXPECT_EQ(d["cause"], "none");
}

// The physics right, the measurement wrong: cameras.json's focal lengths 5 % too large (the
// body looks 5 % smaller). The diagnosis names the camera, fits the factor and, with it
// corrected, the true Young's modulus.
TEST_F(DiagnoseCli, NamesTheCameraWhenItsFocalLengthIsOff) {
  observe(cube_scene(0.01, 0.0, 5e4, true), "obs");
  scale_focal_lengths("obs", 1.05);
  std::string out, err;
  const std::string fit = write("fit.json", cube_scene(0.01, 0.0, 1.25e5, false));
  ASSERT_EQ(run("diagnose '" + fit + "' --observations '" + (dir_ / "obs").string() + "' --out '" +
                    (dir_ / "diag").string() + "' --candidates focal_length,air_drag --starts 2 --iterations 12 --device cpu",
                &out, &err),
            0)
      << err;
  std::printf("%s", out.c_str());
  const json d = read_json(dir_ / "diag" / "diagnosis.json");
  EXPECT_EQ(d["cause"], "focal_length");
  for (const json& m : d["candidates"])
    if (m["name"] == "focal_length") {
      EXPECT_NEAR(m["extra_parameters"]["camera.focal_scale"].get<double>(), 1 / 1.05, 0.005);
      EXPECT_NEAR(m["base_after"]["youngs_modulus"].get<double>(), 5e4, 0.05 * 5e4);
    }
  EXPECT_NE(out.find("focal lengths (fx, fy in cameras.json) look 5."), std::string::npos) << out;
  EXPECT_NE(out.find("% too large; with it corrected: youngs_modulus = "), std::string::npos) << out;
}

// The measurement's bar in the verdict (models/diagnosis/naming.h): a correction fitted with
// another model's physics, here the true one's with a modulus 20 % low (as a model fitted to
// the frames as recorded can be), finds the factor, refits the modulus on the corrected frames
// and removes the error.
TEST_F(DiagnoseCli, AFocalCorrectionFittedWithAModelsPhysicsFindsTheFactorAndRefitsIt) {
  observe(cube_scene(0.01, 0.0, 5e4, true), "obs");
  scale_focal_lengths("obs", 1.05);
  const std::string scene = write("fit.json", cube_scene(0.01, 0.0, 5e4, false));
  FittedModel biased;
  biased.name = "biased";
  biased.problem = load_problem(scene, {}, (dir_ / "obs").string(), 0, {"youngs_modulus"});
  biased.names = {"youngs_modulus"};
  biased.values = Eigen::VectorXd::Constant(1, 4e4);
  DiagnosisContext c;
  c.scene_path = scene;
  c.observations = (dir_ / "obs").string();
  c.heldin = int(0.7 * double(biased.problem.frames.size()));
  c.extent = 0.2;
  c.options.device = "cpu";
  c.options.fit = {"youngs_modulus"};
  const FittedModel corrected = measurement_on(*find_extension("focal_length"), biased, c);
  ASSERT_FALSE(corrected.failed) << corrected.failure;
  EXPECT_TRUE(corrected.note.empty()) << corrected.note;  // refitted, not laid on the biased motion only
  ASSERT_EQ(corrected.names.back(), "camera.focal_scale");
  EXPECT_NEAR(corrected.values[corrected.values.size() - 1], 1 / 1.05, 0.003);
  EXPECT_NEAR(corrected.values[0], 5e4, 0.03 * 5e4);
  const std::vector<double> as_recorded =
      per_frame_costs(biased.problem, with_values(biased.problem.scene, biased.names, biased.values), "cpu");
  double heldout = 0;
  for (size_t f = size_t(c.heldin); f < as_recorded.size(); ++f) heldout += as_recorded[f];
  std::printf("held-out cost as recorded %.4g, corrected %.4g\n", heldout, corrected.heldout_cost);
  EXPECT_LT(corrected.heldout_cost, 0.2 * heldout);
}

TEST_F(DiagnoseCli, BadInputIsAnInputErrorAndWritesNothing) {
  observe(cube_scene(0.01, 0.0, 5e4, true), "obs");
  const std::string scene = write("scene.json", cube_scene(0.01, 0.0, 5e4, false));
  const std::string malformed = write("bad.json", json{{"parameters", 3}});
  std::string out, err;
  for (const std::string& params : {(dir_ / "missing.json").string(), malformed}) {
    EXPECT_EQ(run("residuals '" + scene + "' --observations '" + (dir_ / "obs").string() + "' --params '" + params +
                      "' --out '" + (dir_ / "r").string() + "' --device cpu",
                  &out, &err),
              2)
        << err;
    EXPECT_NE(err.find(params), std::string::npos) << err;
  }
  EXPECT_EQ(run("diagnose '" + scene + "' --observations '" + (dir_ / "obs").string() + "' --candidates frition --out '" +
                    (dir_ / "d").string() + "' --device cpu",
                &out, &err),
            2);
  EXPECT_NE(err.find("unknown candidate 'frition'"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir_ / "r"));
  EXPECT_FALSE(fs::exists(dir_ / "d"));
}

// A cube slowed by a drag no air has (25 kg/m^3, 20 times air's): the air-drag fit runs into
// the end of its plausible range (0 .. 1.5 kg/m^3) and is not named, and the report says what
// it would need; the scene's "plausible" section widens the range, and then the fit is inside.
TEST_F(DiagnoseCli, AirDragThatNeedsAnImplausibleDensityIsNotNamed) {
  json scene = cube_scene(0.01, 0.0, 5e4, true);
  scene["air_drag"] = 25.0;
  observe(scene, "obs");
  json fit = cube_scene(0.01, 0.0, 1.25e5, false);
  auto run_drag = [&](const std::string& out_name) {
    std::string out, err;
    const std::string path = write("fit.json", fit);
    EXPECT_EQ(run("diagnose '" + path + "' --observations '" + (dir_ / "obs").string() + "' --out '" +
                      (dir_ / out_name).string() + "' --candidates air_drag --starts 2 --iterations 12 --device cpu",
                  &out, &err),
              0)
        << err;
    std::printf("%s", out.c_str());
    return std::make_pair(read_json(dir_ / out_name / "diagnosis.json"), out);
  };
  const auto [d, printed] = run_drag("diag");
  ASSERT_EQ(d["candidates"].size(), 1u);
  const json& drag = d["candidates"][0];
  EXPECT_NE(d["cause"], "air_drag");
  ASSERT_FALSE(drag["implausible"].empty()) << drag.dump();
  EXPECT_NE(drag["implausible"][0].get<std::string>().find("upper end of its plausible range"), std::string::npos);
  EXPECT_LE(drag["extra_parameters"]["air_drag"].get<double>(), 1.5);
  fit["plausible"] = {{"air_drag", {0, 100}}};
  const json wide = run_drag("wide").first;
  const json& drag_wide = wide["candidates"][0];
  EXPECT_TRUE(drag_wide["implausible"].empty()) << drag_wide.dump();
  EXPECT_GT(drag_wide["extra_parameters"]["air_drag"].get<double>(), 1.5);
}

TEST_F(DiagnoseCli, AirDragAndMassDampingTradeOffWhereTheYoungsModulusIsDetermined) {
  // The classic pair: quadratic air drag and Rayleigh mass damping both slow the cube along
  // its path; over a 0.8 s throw one stands in for the other. The Young's modulus, which sets
  // the bounce, is not traded against either. The Gauss-Newton matrix of the residuals at the
  // truth.
  json scene = cube_scene(0.01, 0.0, 5e4, true);
  scene["air_drag"] = 10.0;
  scene["material"]["mass_damping"] = 0.2;
  observe(scene, "obs");
  const std::string path = write("scene.json", scene);
  const Problem problem = load_problem(path, {}, (dir_ / "obs").string(), 0, {"air_drag", "mass_damping"});
  const PhysicalParameters truth = PhysicalParameters::from_scene(problem.scene);
  const ParameterCorrelation c =
      parameter_correlation(problem, truth, {"air_drag", "mass_damping", "youngs_modulus"}, {0.01, 0.0002, 50}, "cpu");
  ASSERT_TRUE(c.failure.empty()) << c.failure;
  ASSERT_EQ(c.names.size(), 3u);
  std::printf("correlation: drag-damping %.4f, drag-E %.4f, damping-E %.4f\n", c.correlation(0, 1), c.correlation(0, 2),
              c.correlation(1, 2));
  EXPECT_GT(std::abs(c.correlation(0, 1)), 0.95);
  EXPECT_LT(std::abs(c.correlation(0, 2)), 0.9);
  EXPECT_LT(std::abs(c.correlation(1, 2)), 0.9);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(c.correlation(i, i), 1.0, 1e-12);
  EXPECT_GT(c.gauss_newton(0, 0), 0);
  EXPECT_THROW(parameter_correlation(problem, truth, {"air_drag"}, {}, "cpu"), InputError);
}

// On the GPU, step 3's fits run side by side (four a GPU by default) with the likely cause's
// refits on the controls' discretizations queued behind them; one a GPU runs them one after
// another and refits the cause after the verdict. The diagnosis is the same.
class GpuDiagnoseCli : public DiagnoseCli {};

TEST_F(GpuDiagnoseCli, FitsSideBySideGiveTheDiagnosisOfOneAtATime) {
  SKIP_WITHOUT_GPU();
  observe(cube_scene(0.005, 0.4, 5e4, true), "obs");
  const std::string fit = write("fit.json", cube_scene(0.01, 0.0, 1.25e5, false));
  json d[2];
  std::string said[2];
  const char* prefix[2] = {"SSC_FITS_PER_GPU=1", ""};  // one GPU either way: --gpus 1
  for (int k = 0; k < 2; ++k) {
    std::string out, err;
    const std::string name = k == 0 ? "one" : "side_by_side";
    const int code = run_with_prefix(prefix[k],
                                     "diagnose '" + fit + "' --observations '" + (dir_ / "obs").string() + "' --out '" +
                                         (dir_ / name).string() + "' --starts 3 --iterations 15 --device cuda --gpus 1",
                                     &out, &err);
    ASSERT_EQ(code, 0) << err;
    d[k] = read_json(dir_ / name / "diagnosis.json");
    said[k] = out + err;
  }
  EXPECT_EQ(d[0]["cause"], "friction");
  EXPECT_EQ(d[1]["cause"], d[0]["cause"]);
  EXPECT_EQ(said[0].find("ahead (the likely cause)"), std::string::npos);
  EXPECT_NE(said[1].find("ahead (the likely cause)"), std::string::npos) << said[1];
  for (const char* control : {"cause_on_finer_grid", "cause_on_finer_step"}) {
    ASSERT_TRUE(d[0][control].is_object() && d[1][control].is_object()) << control;
    for (const auto& [name, value] : d[0][control]["parameters"].items())
      EXPECT_NEAR(d[1][control]["parameters"][name].get<double>(), value.get<double>(),
                  1e-9 * std::abs(value.get<double>()))
          << control << " " << name;
  }
  for (const auto& [name, value] : d[0]["base"]["parameters"].items())
    EXPECT_NEAR(d[1]["base"]["parameters"][name].get<double>(), value.get<double>(), 1e-9 * std::abs(value.get<double>()))
        << name;
}

}  // namespace
}  // namespace ssc
