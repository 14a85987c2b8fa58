// `ssc diagnose SCENE --observations DIR --out OUT [--fit LIST] [--candidates LIST]
// [--starts N] [--iterations K] [--holdout F] [--device ...]`: fits the base model and each
// candidate extension on the first frames, scores them on the held-out rest
// (models/diagnosis/diagnosis.h), and writes diagnosis.json, report.html and the residuals of
// the base fit and of the named extension's.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "models/diagnosis/diagnosis.h"
#include "models/diagnosis/goodness_of_fit.h"
#include "models/diagnosis/model_fit.h"
#include "models/diagnosis/report_data.h"
#include "models/diagnosis/report_html.h"
#include "models/diagnosis/residuals.h"
#include "models/io/folder_hash.h"
#include "models/io/output_dir.h"
#include "models/io/run_record.h"
#include "models/io/text_file.h"
#include "models/sim/compute_device.h"
#include "models/sim/parameters.h"
#include "models/sim/problem.h"
#include "runtime/cuda_runtime.h"
#include "runtime/errors.h"
#include "tools/ssc/commands.h"
#include "tools/ssc/device_option.h"
#include "tools/ssc/progress.h"

namespace ssc {
namespace {

PhysicalParameters fitted_parameters(const FittedModel& m) { return with_values(m.problem.scene, m.names, m.values); }

// A model's residuals over every frame. A fit of the held-in frames may fail the energy audit
// over all of them (a wrong measurement can drive the base's modulus to hundreds of MPa): then
// a warning says so and the residuals are those of the run with the audit off.
Residuals model_residuals(const FittedModel& m, const std::string& device) {
  try {
    return compute_residuals(m.problem, fitted_parameters(m), device);
  } catch (const SimulationError& e) {
    warn("audit_off", fmt::format("the {} model's fit fails over all frames ({}); its residuals and goodness of fit "
                                  "are of the run with the energy audit off",
                                  m.name, e.what()));
    Problem p = m.problem;
    p.scene.solver.energy_tolerance = 0;
    return compute_residuals(p, fitted_parameters(m), device);
  }
}

nlohmann::json report_data(const Diagnosis& d, const nlohmann::json& dj, const std::string& scene,
                           const std::string& observations, const std::string& device) {
  nlohmann::json data;
  data["title"] = "ssc diagnose: " + scene;
  data["cause"] = d.cause;
  data["summary_lines"] = d.lines;
  data["provenance"] = {{"scene", scene}, {"observations", observations}, {"device", device}};
  data["candidates"] = dj["candidates"];
  data["confounded"] = dj["confounded"];
  data["confounded_base"] = dj["confounded_base"];
  data["discretization_controls"] = dj["discretization_controls"];
  data["base_convergence"] = dj["base"]["convergence"];
  nlohmann::json units = nlohmann::json::object(), base = dj["base"]["parameters"], winner = nlohmann::json::object();
  for (const auto& [name, value] : base.items()) units[name] = parameter_or_measurement_unit(name);
  for (const FittedModel& m : d.candidates)
    if (m.name == d.cause)
      for (size_t i = 0; i < m.names.size(); ++i) {
        winner[m.names[i]] = m.values[Eigen::Index(i)];
        units[m.names[i]] = parameter_or_measurement_unit(m.names[i]);
      }
  data["parameters"] = {{"units", units}, {"base", base}, {"winner", winner}};
  return data;
}

// The candidate whose own parameter `name` (canonical) is, "" for none: friction's
// coefficients, the air drag, the stiffness gradient.
std::string candidate_of(const std::string& name) {
  const std::string friction = ".friction";
  if (name.size() > friction.size() && name.compare(name.size() - friction.size(), friction.size(), friction) == 0)
    return "friction";
  if (name == "air_drag") return "air_drag";
  if (name.rfind("material.stiffness_gradient", 0) == 0) return "heterogeneous_stiffness";
  return "";
}

// What diagnose() would refuse only after its first fits, or accept and then trip over: a
// base parameter that a candidate fits, and a split that leaves fewer than 3 frames held in
// (counted as diagnose() counts them).
void check_options(const std::string& scene, const std::vector<std::string>& overrides, const std::string& observations,
                   double phi_max, const DiagnosisOptions& opt) {
  const Problem problem = load_problem(scene, overrides, observations, phi_max, opt.fit);
  for (const std::string& name : expand_parameter_names(opt.fit, PhysicalParameters::from_scene(problem.scene))) {
    const std::string candidate = candidate_of(name);
    if (!candidate.empty() && std::find(opt.candidates.begin(), opt.candidates.end(), candidate) != opt.candidates.end())
      throw InputError(fmt::format("--fit {}: {} is a candidate of the diagnosis (--candidates), which fits {} itself "
                                   "and measures what it adds to the base model, so it cannot also be a base "
                                   "parameter; leave {} out of --fit, or leave {} out of --candidates to fit it in "
                                   "the base model",
                                   name, candidate, name, name, candidate));
  }
  if (!(opt.holdout > 0 && opt.holdout < 1)) return;  // diagnose() says what is wrong
  const int n = int(problem.frames.size());
  const int held_in = std::max(2, int(std::ceil((1 - opt.holdout) * n)));
  if (held_in < 3)
    throw InputError(fmt::format("{}: --holdout {} leaves {} of the {} observed frames to fit on; the fits need at least "
                                 "3 (and 2 to hold out): {}",
                                 observations, opt.holdout, held_in, n,
                                 n >= 5 ? fmt::format("lower --holdout to at most {:.2f}", std::floor(100.0 * (1 - 3.0 / n)) / 100)
                                        : std::string("observe at least 5 frames")));
}

}  // namespace

Command register_diagnose(CLI::App& app) {
  struct Options {
    std::string scene, observations, out, device = "auto";
    std::vector<std::string> overrides;
    DiagnosisOptions d;
    double phi_max = 0;
    ProgressMode progress = ProgressMode::Auto;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand("diagnose", "Name the effect the fitted model misses, fit it, measure the gain");
  sub->add_option("scene", o->scene, "Scene file (what is known)")->required();
  sub->add_option("--observations", o->observations, "Observation folder")->required();
  sub->add_option("--out", o->out, "Output folder (replaced atomically)")->required();
  sub->add_option("--fit", o->d.fit, "The base model's parameters to fit, comma-separated (default youngs_modulus)")
      ->delimiter(',');
  sub->add_option("--candidates", o->d.candidates, "Extensions to try, comma-separated (default: " + extension_list() + ")")
      ->delimiter(',');
  sub->add_option("--starts", o->d.starts, "Starts per fit")->check(CLI::Range(1, 1000));
  sub->add_option("--optimizer", o->d.optimizer, "Optimiser of every fit: lm (default), rprop, rprop-paper, gd, lbfgs");
  sub->add_option("--iterations", o->d.iterations, "Iterations per start")->check(CLI::Range(1, 100000));
  sub->add_option("--holdout", o->d.holdout, "Fraction of the frames held out at the end (default 0.3)");
  sub->add_option("--seed", o->d.seed, "Seed of the starts and the bootstrap");
  sub->add_option("--phi-max", o->phi_max, "Cost threshold in metres");
  sub->add_option("--set", o->overrides, "Override a scene key: dotted.key=JSON, repeatable");
  sub->add_flag("--no-discretization-controls",
                "Skip the discretization controls (the base model refitted on half the cell size and on half the "
                "time step, bars every candidate must beat)")
      ->each([o](const std::string&) { o->d.discretization_controls = false; });
  add_device_option(sub, &o->device, true);
  add_progress_options(sub, &o->progress);
  return [o] {
    DiagnosisOptions opt = o->d;
    check_options(o->scene, o->overrides, o->observations, o->phi_max, opt);
    opt.device = choose_device(o->device);
    OutputDir out(o->out, {o->scene, o->observations});
    out.manifest()["scene"] = {{"file", o->scene}};
    out.manifest()["observations"] = folder_fingerprint(o->observations);
    const std::string device = describe_device(opt.device);
    out.manifest()["device"] = device;
    Progress progress("diagnose", 0, o->progress);
    const Diagnosis d = diagnose(o->scene, o->overrides, o->observations, o->phi_max, opt,
                                 [&](const std::string& what) { progress.stage(what); });
    for (const CandidateVerdict& v : d.verdicts)  // recorded in diagnosis.json's candidates; printed at the end
      for (const std::string& w : v.warnings) warn("candidate", v.name + ": " + w);
    nlohmann::json dj = diagnosis_json(d);
    dj["device"] = device;
    dj["options"] = {{"fit", opt.fit},           {"candidates", opt.candidates}, {"starts", opt.starts}, {"optimizer", opt.optimizer},
                     {"iterations", opt.iterations}, {"holdout", opt.holdout},   {"seed", opt.seed},
                     {"min_gain", opt.min_gain}, {"margin", opt.margin}};
    // Residuals of the base fit, and of the named extension's (else of none).
    const Residuals before = model_residuals(d.base, opt.device);
    const FittedModel* winner = nullptr;
    for (const FittedModel& m : d.candidates)
      if (m.name == d.cause && !m.failed) winner = &m;
    Residuals after;
    if (winner) after = model_residuals(*winner, opt.device);
    write_text_file(out.file("residuals_base.csv"), residuals_csv(before));
    dj["residuals_base"] = residual_summary(before);
    // How far the final model (the named extension's, else the base) is above the noise.
    const GoodnessOfFit fit_base = goodness_of_fit(d.base.problem, before);
    dj["base"]["goodness_of_fit"] = goodness_json(fit_base);
    GoodnessOfFit fit_final = fit_base;
    if (winner) {
      write_text_file(out.file("residuals_" + d.cause + ".csv"), residuals_csv(after));
      dj["residuals_" + d.cause] = residual_summary(after);
      fit_final = goodness_of_fit(winner->problem, after);
      for (nlohmann::json& c : dj["candidates"])
        if (c["name"] == d.cause) c["goodness_of_fit"] = goodness_json(fit_final);
    }
    warn_if_above_noise(fit_final);
    dj["warnings"] = warnings_json();
    nlohmann::json data = report_data(d, dj, o->scene, o->observations, device);
    add_residual_report_data(data, d.base.problem, before, winner ? &after : nullptr);
    data["residual_vs_time"]["heldout_from"] = d.heldout_from;
    write_text_file(out.file("diagnosis.json"), dj.dump(2) + "\n");
    write_report_html(out.file("report.html"), data);
    out.commit();
    std::printf("%-24s %10s %22s %9s %9s %16s\n", "candidate", "gain", "90 % interval", "placebo", "score",
                "after event: AIC");
    for (const CandidateVerdict& v : d.verdicts)
      std::printf("%-24s %9.1f%% %9.1f%% .. %6.1f%% %8.1f%% %9.3g %16.4g%s\n", v.name.c_str(), 100 * v.gain,
                  100 * v.gain_low, 100 * v.gain_high, 100 * v.placebo_gain, v.score, v.event_aic,
                  v.passes ? "  named" : "");
    for (const std::string& line : d.lines) std::printf("%s\n", line.c_str());
    std::printf("%s%s\n", (winner ? "with " + d.cause + ", " : std::string("the base model, ")).c_str(),
                goodness_line(fit_final).c_str());
    std::printf("wrote %s: diagnosis.json, report.html, residuals (%.1f s)\n", o->out.c_str(), d.seconds);
    return 0;
  };
}

}  // namespace ssc
