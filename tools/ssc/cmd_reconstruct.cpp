// `ssc reconstruct SCENE --observations DIR --fit LIST --starts N --iterations K --out OUT`:
// fits the named parameters from N perturbed starts (one batch), writes result.json,
// history.csv, convergence plots and renders of the observed points over the best fit, and
// judges the best fit against the depth noise (models/diagnosis/goodness_of_fit.h).
#include <fmt/format.h>

#include <chrono>

#include <cmath>

#include <fstream>
#include <map>
#include <regex>
#include <nlohmann/json.hpp>

#include "runtime/errors.h"
#include "models/diagnosis/goodness_of_fit.h"
#include "models/io/text_file.h"
#include "models/io/output_dir.h"
#include "models/io/svg_plot.h"
#include "models/optim/reconstruction.h"
#include "models/sim/compute_device.h"
#include "models/sim/extensions.h"
#include "models/sim/parameters.h"
#include "models/sim/problem.h"
#include "models/sim/units.h"
#include "runtime/cuda_runtime.h"
#include "tools/ssc/commands.h"
#include "tools/ssc/device_option.h"
#include "tools/ssc/fit_renders.h"
#include "tools/ssc/progress.h"
#include "models/io/folder_hash.h"
#include "models/io/run_record.h"
#include "models/sim/match_check.h"

namespace ssc {
namespace {

nlohmann::json named(const std::vector<std::string>& names, const Eigen::VectorXd& v) {
  nlohmann::json j = nlohmann::json::object();
  for (size_t i = 0; i < names.size() && i < size_t(v.size()); ++i) j[names[i]] = v[i];
  return j;
}

void write_convergence_plots(const OutputDir& out, const ReconstructionResult& r) {
  std::vector<PlotPanel> panels;
  auto add_panel = [&](const std::string& title, const std::string& ylabel, bool log_y, auto value) {
    PlotPanel p{title, "iteration", ylabel, false, log_y, false, {}, {}};
    for (size_t s = 0; s < r.starts.size(); ++s) {
      const StartRecord& rec = r.starts[s];
      PlotSeries series;
      series.color = int(s) == r.best ? "#d62728" : "#9aa7b8";
      series.width = int(s) == r.best ? 3.0 : 1.0;
      series.label = int(s) == r.best ? fmt::format("best (start {})", s) : "";
      for (size_t k = 0; k < rec.cost_history.size(); ++k) {
        series.x.push_back(double(k));
        series.y.push_back(value(rec, k));
      }
      if (int(s) == r.best)
        p.series.push_back(series);
      else
        p.series.insert(p.series.begin(), series);
    }
    panels.push_back(p);
  };
  add_panel("cost J_SSC, all starts", "cost", true, [](const StartRecord& rec, size_t k) { return rec.cost_history[k]; });
  for (size_t i = 0; i < r.names.size(); ++i)
    add_panel(r.names[i], fmt::format("{} [{}]", r.names[i], r.units[i]), false,
              [i](const StartRecord& rec, size_t k) { return rec.parameter_history[k][i]; });
  write_svg_plot(out.file("convergence.svg"), panels, 720, 260);
}


// Why every start failed, grouped by reason (numbers left out), the first message of each.
std::string failure_summary(const ReconstructionResult& r) {
  std::map<std::string, std::vector<size_t>> groups;
  std::map<std::string, std::string> first;
  for (size_t s = 0; s < r.starts.size(); ++s) {
    std::string key = std::regex_replace(r.starts[s].failure, std::regex("[-+]?[0-9][0-9.eE+-]*"), "#");
    groups[key].push_back(s);
    first.emplace(key, r.starts[s].failure);
  }
  std::string text = fmt::format("every start's simulation failed ({} of {}):", r.starts.size(), r.starts.size());
  for (const auto& [key, starts] : groups) {
    std::string list;
    for (size_t k = 0; k < starts.size() && k < 8; ++k) list += (k ? ", " : "") + std::to_string(starts[k]);
    if (starts.size() > 8) list += ", ...";
    text += fmt::format("\n  {} start(s) ({}): {}", starts.size(), list, first[key]);
  }
  return text;
}

// The best fit must rest on matched points and a gradient that is not identically zero;
// a best start that never moved is worth a warning.
void check_fit(const ReconstructionResult& r, const std::string& observations) {
  const StartRecord& best = r.starts[r.best];
  check_matches(best.frames, observations, "the best fit");
  bool all_zero = true;
  for (const StartRecord& s : r.starts) all_zero &= s.failed || s.initial_gradient_norm == 0;
  if (all_zero)
    throw InputError(fmt::format("{}: the cost's gradient is exactly zero at every start: the fitted parameters do not "
                                 "change the cost (no observed point reacts to them). Check that the observations show "
                                 "the body while it moves, and that --fit names parameters the data depends on",
                                 observations));
  if (best.final == best.initial)
    warn("fit_did_not_move", "the best start ended where it started: the optimiser found no better point; the result is "
                             "its start value, not a fit. Try more --starts or --iterations, or check the observations");
  if (best.stop_reason == "iteration limit")
    warn("not_converged", fmt::format("the best start stopped at the iteration limit ({} iterations) with gradient norm "
                                      "{:.3g}: the fit is not converged; raise --iterations",
                                      best.iterations, best.final_gradient_norm));
  else if (!best.converged)
    warn("not_converged", fmt::format("the best start stopped with '{}' after {} iterations, gradient norm {:.3g}: the fit "
                                      "is not converged; try another --optimizer or more --starts",
                                      best.stop_reason, best.iterations, best.final_gradient_norm));
}

// How many starts reached the best cost (within 1 %) and how far their parameters spread.
nlohmann::json convergence_summary(const ReconstructionResult& r) {
  const double best_cost = r.starts[r.best].final_cost;
  nlohmann::json j;
  int failed = 0, reached = 0;
  std::map<std::string, int> reasons;
  std::vector<Eigen::VectorXd> close;
  for (const StartRecord& s : r.starts) {
    failed += s.failed;
    ++reasons[s.stop_reason];
    if (!s.failed && s.final_cost <= best_cost + 0.01 * std::abs(best_cost)) close.push_back(s.final), ++reached;
  }
  j["starts"] = r.starts.size();
  j["failed_starts"] = failed;
  j["starts_within_1_percent_of_best_cost"] = reached;
  j["stop_reasons"] = reasons;
  nlohmann::json spread = nlohmann::json::object();
  for (size_t i = 0; i < r.names.size(); ++i) {
    double lo = close[0][i], hi = close[0][i];
    for (const Eigen::VectorXd& x : close) lo = std::min(lo, x[i]), hi = std::max(hi, x[i]);
    spread[r.names[i]] = {{"min", lo}, {"max", hi}};
  }
  j["spread_of_starts_within_1_percent"] = spread;
  j["converged"] = r.starts[r.best].converged;
  return j;
}

void print_report(const ReconstructionResult& r, const nlohmann::json& convergence) {
  const StartRecord& best = r.starts[r.best];
  std::printf("%-6s %-13s %-38s %10s %8s\n", "start", "final cost", "stopped by", "|grad|", "matched");
  for (size_t s = 0; s < r.starts.size(); ++s) {
    const StartRecord& rec = r.starts[s];
    if (rec.failed) {
      std::printf("%-6zu failed: %s\n", s, rec.failure.substr(0, 100).c_str());
      continue;
    }
    std::printf("%-6zu %-13.6g %-38s %10.3g %7.1f%%%s\n", s, rec.final_cost, rec.stop_reason.c_str(), rec.final_gradient_norm,
                rec.observed_points ? 100.0 * rec.matched_points / rec.observed_points : 0.0, int(s) == r.best ? "  <- best" : "");
  }
  std::printf("best start %d of %zu: cost %.6g, %d of %d observed points matched; %d start(s) within 1 %% of the best cost\n",
              r.best, r.starts.size(), best.final_cost, best.matched_points, best.observed_points,
              convergence["starts_within_1_percent_of_best_cost"].get<int>());
  for (size_t i = 0; i < r.names.size(); ++i) {
    const nlohmann::json& sp = convergence["spread_of_starts_within_1_percent"][r.names[i]];
    const std::string unit = r.units[i] == "1" ? "" : " " + r.units[i];  // dimensionless: no unit
    std::printf("  %s = %.6g%s (nominal %.6g; starts within 1 %%: %.6g .. %.6g)\n", r.names[i].c_str(), best.final[i],
                unit.c_str(), r.nominal[i], sp["min"].get<double>(), sp["max"].get<double>());
  }
  if (!convergence["converged"].get<bool>())
    std::printf("NOT CONVERGED: the best start stopped by '%s'%s\n", best.stop_reason.c_str(),
                best.stop_reason == "iteration limit" ? "; raise --iterations" : "");
}

}  // namespace

Command register_reconstruct(CLI::App& app) {
  struct Options {
    std::string device = "auto";
    std::string scene, observations, out, optimizer = "rprop";
    std::vector<std::string> overrides, fit;
    int starts = 20, iterations = 50;
    std::string gradient = "adjoint";
    std::uint64_t seed = 1;
    double phi_max = 0;
    ProgressMode progress = ProgressMode::Auto;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand("reconstruct", "Fit physical parameters to observations from perturbed starts");
  sub->add_option("scene", o->scene, "Scene file (what is known; the fitted values are the nominal ones)")->required();
  sub->add_option("--observations", o->observations, "Observation folder")->required();
  sub->add_option("--fit", o->fit, "Parameters to fit, comma-separated (e.g. youngs_modulus,stiffness_damping)")->required()->delimiter(',');
  sub->add_option("--starts", o->starts, "Number of perturbed starts")->check(CLI::Range(1, 1000));
  sub->add_option("--iterations", o->iterations, "Iterations per start")->check(CLI::Range(1, 100000));
  sub->add_option("--optimizer", o->optimizer, "rprop, rprop-paper, gd, lbfgs or lm (Levenberg-Marquardt)");
  sub->add_option("--seed", o->seed, "Seed of the start sampling");
  sub->add_option("--gradient", o->gradient, "adjoint (default) or fd: central differences, for comparison")
      ->check(CLI::IsMember({"adjoint", "fd"}));
  sub->add_option("--phi-max", o->phi_max, "Cost threshold in metres");
  sub->add_option("--out", o->out, "Output folder (replaced atomically)")->required();
  sub->add_option("--set", o->overrides, "Override a scene key: dotted.key=JSON, repeatable");
  add_device_option(sub, &o->device, true);
  add_progress_options(sub, &o->progress);
  return [o] {
    const std::string device = choose_device(o->device);
    const Problem problem = load_problem(o->scene, o->overrides, o->observations, o->phi_max, o->fit);
    const UnitScales scales = unit_scales(problem.scene, problem.grid);  // checked before the long run
    ReconstructionOptions ro;
    ro.fit = o->fit;
    ro.starts = o->starts;
    ro.optimizer = o->optimizer;
    ro.optimizer_options.max_iterations = o->iterations;
    ro.seed = o->seed;
    ro.finite_differences = o->gradient == "fd";
    ro.device = device;
    check_optimizer_name(ro.optimizer);  // reject unknown names early
    const PhysicalParameters nominal = PhysicalParameters::from_scene(problem.scene);
    const std::vector<std::string> names = expand_parameter_names(ro.fit, nominal);
    OutputDir out(o->out, {o->scene, o->observations, problem.scene.object.path});
    out.manifest()["scene"] = {{"file", o->scene}, {"resolved", problem.scene.resolved}};
    out.manifest()["observations"] = folder_fingerprint(o->observations);
    out.manifest()["device"] = describe_device(device);
    Progress progress("reconstruct: round", o->iterations, o->progress, 0.0);
    // Within a round: a line every 2 s of a long evaluation, with the steps done and an
    // estimate of the evaluation's rest (a round of 1000 starts runs for tens of seconds).
    int rounds_done = 0;
    using Clock = std::chrono::steady_clock;
    Clock::time_point evaluation_start = Clock::now(), last_line = evaluation_start;
    ro.evaluation_progress = [&](int done, int total) {
      const Clock::time_point now = Clock::now();
      if (done <= 1) evaluation_start = now;
      const double running = std::chrono::duration<double>(now - evaluation_start).count();
      if (running < 2 || std::chrono::duration<double>(now - last_line).count() < 2 || done >= total) return;
      last_line = now;
      progress.update(std::min(rounds_done, o->iterations),
                      fmt::format("round {} evaluating: step {} of {} ({:.0f} s, about {:.0f} s left in it)",
                                  rounds_done + 1, done, total, running, running * (total - done) / std::max(done, 1)));
    };
    const ReconstructionResult r = reconstruct(problem, ro, [&](int round, int active, double best, const Eigen::VectorXd& x) {
      rounds_done = round;
      std::string values;
      for (int i = 0; i < x.size(); ++i) values += fmt::format(" {}={:.5g}", names[i], x[i]);
      progress.update(std::min(round, o->iterations), fmt::format("{} starts running, best cost {:.6g},{}", active, best, values));
    });
    progress.finish();
    if (r.best < 0) throw SimulationError(failure_summary(r));
    const StartRecord& best = r.starts[r.best];
    check_fit(r, o->observations);
    PhysicalParameters fitted = nominal;
    for (size_t i = 0; i < r.names.size(); ++i) {
      set_parameter(fitted, r.names[i], best.final[i]);
      if (const std::string why = implausibility(problem.scene, r.names[i], best.final[i], rest_extent(problem.grid));
          !why.empty())
        warn("implausible_value", why);
    }
    const GoodnessOfFit fit = goodness_of_fit(problem, fitted, device);
    warn_if_above_noise(fit);

    nlohmann::json j;
    j["parameters"] = named(r.names, best.final);
    j["units"] = nlohmann::json::object();
    for (size_t i = 0; i < r.names.size(); ++i) j["units"][r.names[i]] = r.units[i];
    j["set"] = nlohmann::json::array();
    for (size_t i = 0; i < r.names.size(); ++i) j["set"].push_back(parameter_set_argument(nominal, r.names[i], best.final[i]));
    if (!scales.identity()) {
      // The scene is in its own units: report SI values too (models/sim/units.h).
      nlohmann::json si = nlohmann::json::object();
      for (size_t i = 0; i < r.names.size(); ++i) si[r.names[i]] = to_si(r.names[i], best.final[i], scales);
      j["parameters_si"] = si;
      j["unit_scales"] = {{"length", scales.length}, {"mass", scales.mass}, {"time", scales.time}};
    }
    j["cost"] = best.final_cost;
    j["best_start"] = r.best;
    j["matched_points"] = best.matched_points;
    j["observed_points"] = best.observed_points;
    j["nominal"] = named(r.names, r.nominal);
    j["convergence"] = convergence_summary(r);
    j["goodness_of_fit"] = goodness_json(fit);
    j["optimizer"] = ro.optimizer;
    j["gradient"] = ro.optimizer == "lm" ? "residual forward differences" : o->gradient;
    j["seed"] = ro.seed;
    j["evaluations"] = r.evaluations;
    j["batches"] = r.batches;
    j["wall_seconds"] = r.wall_seconds;
    j["device"] = describe_device(device);
    nlohmann::json starts = nlohmann::json::array();
    std::string csv = "start,iteration,cost";
    for (const std::string& n : r.names) csv += "," + n;
    csv += "\n";
    for (size_t s = 0; s < r.starts.size(); ++s) {
      const StartRecord& rec = r.starts[s];
      nlohmann::json e;
      e["initial"] = named(r.names, rec.initial);
      e["final"] = rec.failed ? nlohmann::json(nullptr) : named(r.names, rec.final);
      e["final_cost"] = rec.failed ? nlohmann::json(nullptr) : nlohmann::json(rec.final_cost);
      e["iterations"] = rec.iterations;
      e["stop_reason"] = rec.stop_reason;
      e["converged"] = rec.converged;
      if (rec.restarts > 0) e["restarts_after_a_stall"] = rec.restarts;
      if (rec.rounds > 0) e["rounds"] = rec.rounds;
      if (!rec.failed) {
        e["final_gradient_norm"] = rec.final_gradient_norm;
        e["matched_points"] = rec.matched_points;
        e["observed_points"] = rec.observed_points;
      }
      if (rec.failed) e["failure"] = rec.failure;
      nlohmann::json hist = nlohmann::json::array();
      for (size_t k = 0; k < rec.cost_history.size(); ++k) {
        hist.push_back({{"cost", rec.cost_history[k]}, {"parameters", named(r.names, rec.parameter_history[k])}});
        csv += fmt::format("{},{},{:.10g}", s, k, rec.cost_history[k]);
        for (int i = 0; i < rec.parameter_history[k].size(); ++i) csv += fmt::format(",{:.10g}", rec.parameter_history[k][i]);
        csv += "\n";
      }
      e["history"] = hist;
      starts.push_back(e);
    }
    j["starts"] = starts;
    write_convergence_plots(out, r);
    const std::vector<std::string> renders = write_fit_renders(out, problem, r.names, best.final);
    j["warnings"] = warnings_json();  // all of the run's, the renders' included
    write_text_file(out.file("result.json"), j.dump(2) + "\n");
    write_text_file(out.file("history.csv"), csv);
    out.commit();
    print_report(r, j["convergence"]);
    std::printf("%s\n", goodness_line(fit).c_str());
    std::printf("wrote %s: result.json, history.csv, convergence.svg, %zu renders (%.1f s)\n", o->out.c_str(), renders.size(),
                r.wall_seconds);
    return 0;
  };
}

}  // namespace ssc
