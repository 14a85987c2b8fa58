// `ssc reconstruct SCENE --observations DIR --fit LIST --starts N --iterations K --out OUT`:
// fits the named parameters from N perturbed starts (one batch), writes result.json,
// history.csv, convergence plots and renders of the observed points over the best fit.
#include <fmt/format.h>

#include <cmath>
#include <unistd.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "models/io/errors.h"
#include "models/io/output_dir.h"
#include "models/io/svg_plot.h"
#include "models/optim/reconstruction.h"
#include "models/sim/parameters.h"
#include "models/sim/problem.h"
#include "models/sim/units.h"
#include "runtime/cuda_runtime.h"
#include "tools/ssc/commands.h"
#include "tools/ssc/device_option.h"
#include "tools/ssc/fit_renders.h"
#include "tools/ssc/progress.h"

namespace ssc {
namespace {

nlohmann::json named(const std::vector<std::string>& names, const Eigen::VectorXd& v) {
  nlohmann::json j = nlohmann::json::object();
  for (size_t i = 0; i < names.size() && i < size_t(v.size()); ++i) j[names[i]] = v[i];
  return j;
}

void write_text(const OutputDir& out, const std::string& name, const std::string& text) {
  std::ofstream f(out.file(name));
  f << text;
  if (!f) throw InputError(fmt::format("cannot write {}", out.file(name)));
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
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand("reconstruct", "Fit physical parameters to observations from perturbed starts");
  sub->add_option("scene", o->scene, "Scene file (what is known; the fitted values are the nominal ones)")->required();
  sub->add_option("--observations", o->observations, "Observation folder")->required();
  sub->add_option("--fit", o->fit, "Parameters to fit, comma-separated (e.g. youngs_modulus,stiffness_damping)")->required()->delimiter(',');
  sub->add_option("--starts", o->starts, "Number of perturbed starts")->check(CLI::Range(1, 1000));
  sub->add_option("--iterations", o->iterations, "Iterations per start")->check(CLI::Range(1, 100000));
  sub->add_option("--optimizer", o->optimizer, "rprop, rprop-paper, gd or lbfgs");
  sub->add_option("--seed", o->seed, "Seed of the start sampling");
  sub->add_option("--gradient", o->gradient, "adjoint (default) or fd: central differences, for comparison")
      ->check(CLI::IsMember({"adjoint", "fd"}));
  sub->add_option("--phi-max", o->phi_max, "Cost threshold in metres");
  sub->add_option("--out", o->out, "Output folder (replaced atomically)")->required();
  sub->add_option("--set", o->overrides, "Override a scene key: dotted.key=JSON, repeatable");
  add_device_option(sub, &o->device);
  return [o] {
    const std::string device = choose_device(o->device);
    const Problem problem = load_problem(o->scene, o->overrides, o->observations, o->phi_max);
    const UnitScales scales = unit_scales(problem.scene, problem.grid);  // checked before the long run
    ReconstructionOptions ro;
    ro.fit = o->fit;
    ro.starts = o->starts;
    ro.optimizer = o->optimizer;
    ro.optimizer_options.max_iterations = o->iterations;
    ro.seed = o->seed;
    ro.finite_differences = o->gradient == "fd";
    ro.device = device;
    make_optimizer(ro.optimizer, Eigen::VectorXd::Zero(1), ro.optimizer_options);  // reject unknown names early
    const std::vector<std::string> names = expand_parameter_names(ro.fit, PhysicalParameters::from_scene(problem.scene));
    OutputDir out(o->out);
    const bool tty = isatty(fileno(stderr));
    const ReconstructionResult r = reconstruct(problem, ro, [&](int it, int active, double best, const Eigen::VectorXd& x) {
      if (!tty) return;
      std::string values;
      for (int i = 0; i < x.size(); ++i) values += fmt::format(" {}={:.5g}", names[i], x[i]);
      std::fprintf(stderr, "\rround %d: %d starts running, best cost %.6g,%s\033[K", it, active, best, values.c_str());
    });
    if (tty) std::fprintf(stderr, "\n");
    if (r.best < 0) throw SimulationError("every start's simulation failed; see the failures with fewer starts or a smaller time.dt");

    nlohmann::json j;
    j["parameters"] = named(r.names, r.starts[r.best].final);
    j["units"] = nlohmann::json::object();
    for (size_t i = 0; i < r.names.size(); ++i) j["units"][r.names[i]] = r.units[i];
    if (!scales.identity()) {
      // The scene is in its own units: report SI values too (models/sim/units.h).
      nlohmann::json si = nlohmann::json::object();
      for (size_t i = 0; i < r.names.size(); ++i) si[r.names[i]] = to_si(r.names[i], r.starts[r.best].final[i], scales);
      j["parameters_si"] = si;
      j["unit_scales"] = {{"length", scales.length}, {"mass", scales.mass}, {"time", scales.time}};
    }
    j["cost"] = r.starts[r.best].final_cost;
    j["best_start"] = r.best;
    j["nominal"] = named(r.names, r.nominal);
    j["optimizer"] = ro.optimizer;
    j["gradient"] = o->gradient;
    j["seed"] = ro.seed;
    j["evaluations"] = r.evaluations;
    j["wall_seconds"] = r.wall_seconds;
    j["device"] = device == "cuda" ? gpu_description() : "cpu";
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
    write_text(out, "result.json", j.dump(2) + "\n");
    write_text(out, "history.csv", csv);
    write_convergence_plots(out, r);
    const std::vector<std::string> renders = write_fit_renders(out, problem, r.names, r.starts[r.best].final);
    out.commit();
    std::printf("best start %d of %zu: cost %.6g\n", r.best, r.starts.size(), r.starts[r.best].final_cost);
    for (size_t i = 0; i < r.names.size(); ++i)
      std::printf("  %s = %.6g %s (nominal %.6g)\n", r.names[i].c_str(), r.starts[r.best].final[i], r.units[i].c_str(), r.nominal[i]);
    std::printf("wrote %s: result.json, history.csv, convergence.svg, %zu renders (%.1f s)\n", o->out.c_str(), renders.size(),
                r.wall_seconds);
    return 0;
  };
}

}  // namespace ssc
