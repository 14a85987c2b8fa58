// `ssc sweep SCENE --observations DIR --param NAME=LO:HI:N [--log]`: cost and gradient
// along one parameter, as CSV and an SVG plot (the paper's figures 6 and 13).
#include <fmt/format.h>

#include <cmath>
#include <fstream>

#include "models/cost/baselines.h"
#include "models/io/byte_record.h"
#include "models/io/folder_hash.h"
#include "models/io/output_dir.h"
#include "models/io/svg_plot.h"
#include "models/io/text_file.h"
#include "models/sim/batch_workers.h"
#include "models/sim/compute_device.h"
#include "models/sim/match_check.h"
#include "models/sim/parameters.h"
#include "models/sim/problem.h"
#include "models/sim/simulation.h"
#include "runtime/errors.h"
#include "tools/ssc/commands.h"
#include "tools/ssc/device_option.h"
#include "tools/ssc/progress.h"

namespace ssc {
namespace {

struct SweepRange {
  std::string name;
  double lo = 0, hi = 0;
  int count = 0;
};

constexpr long long kMaxSamples = 10000;  // each sample is a whole simulation and its adjoint

SweepRange parse_range(const std::string& text) {
  SweepRange r;
  const size_t eq = text.find('=');
  char c1 = 0, c2 = 0;
  long long count = 0;
  int end = 0;
  if (eq != std::string::npos) {
    r.name = text.substr(0, eq);
    if (std::sscanf(text.c_str() + eq + 1, "%lf%c%lf%c%lld%n", &r.lo, &c1, &r.hi, &c2, &count, &end) == 5 && c1 == ':' &&
        c2 == ':' && text[eq + 1 + size_t(end)] == 0 && count >= 2) {
      if (count > kMaxSamples)
        throw InputError(fmt::format("--param {}: N = {} samples is above the limit of {} (each sample is a whole "
                                     "simulation and its adjoint); sample fewer points, or sweep a narrower range",
                                     text, count, kMaxSamples));
      r.count = int(count);
      return r;
    }
  }
  throw InputError(fmt::format("--param {}: expected NAME=LO:HI:N with 2 <= N <= {}, e.g. youngs_modulus=1250:20000:31",
                               text, kMaxSamples));
}

}  // namespace

Command register_sweep(CLI::App& app) {
  struct Options {
    std::string device = "auto";
    std::string scene, observations, param, out, cost = "ssc";
    std::vector<std::string> overrides;
    bool log = false;
    double phi_max = 0, truth = std::nan("");
    ProgressMode progress = ProgressMode::Auto;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand("sweep", "Cost and gradient along one parameter (CSV and SVG plot)");
  sub->add_option("scene", o->scene, "Scene file")->required();
  sub->add_option("--observations", o->observations, "Observation folder")->required();
  sub->add_option("--param", o->param, "NAME=LO:HI:N")->required();
  sub->add_option("--out", o->out, "Output folder (sweep.csv, sweep.svg)")->required();
  sub->add_option("--set", o->overrides, "Override a scene key: dotted.key=JSON, repeatable");
  add_device_option(sub, &o->device, true);
  sub->add_option("--phi-max", o->phi_max, "Cost threshold in metres");
  sub->add_option("--truth", o->truth, "Value to mark in the plot (e.g. the ground truth)");
  sub->add_flag("--log", o->log, "Sample logarithmically");
  sub->add_option("--cost", o->cost, "ssc (default), or the baselines disp (known correspondences) and sdf (full SDF "
                                     "difference), which simulate the truth from --truth")
      ->check(CLI::IsMember({"ssc", "disp", "sdf"}));
  add_progress_options(sub, &o->progress);
  return [o] {
    SweepRange range = parse_range(o->param);
    if (o->log && (range.lo <= 0 || range.hi <= 0)) throw InputError("--log needs positive LO and HI");
    const Problem problem = load_problem(o->scene, o->overrides, o->observations, o->phi_max, {range.name});
    OutputDir out(o->out, {o->scene, o->observations, problem.scene.object.path});
    out.manifest()["scene"] = {{"file", o->scene}, {"resolved", problem.scene.resolved}};
    out.manifest()["observations"] = folder_fingerprint(o->observations);
    const std::string device = choose_device(o->device);
    out.manifest()["device"] = describe_device(device);
    const SurfaceConstraintCost cost(problem.grid, problem.phi_max);
    const PhysicalParameters base = PhysicalParameters::from_scene(problem.scene);
    const std::vector<std::string> expanded = expand_parameter_names({range.name}, base);
    if (expanded.size() != 1)
      throw InputError(fmt::format("--param {}: '{}' is a vector; sweep one component at a time ({}, {} or {})", o->param,
                                   range.name, expanded[0], expanded[1], expanded[2]));
    range.name = expanded[0];
    for (double end : {range.lo, range.hi})
      if (const std::string why = parameter_value_error(range.name, end); !why.empty())
        throw InputError(fmt::format("--param {}: {} {}", o->param, range.name, why));
    std::vector<int> steps;
    for (const ObservedFrame& f : problem.frames) steps.push_back(f.step);
    FrameCostFunction frame_cost = [&](size_t f, int, const double* u, const double* band, double* ub, double* bb) {
      return cost.evaluate(problem.frames[f].points, problem.frames[f].weight, u, band, ub, bb);
    };
    TrueTrajectory truth;
    if (o->cost != "ssc") {
      if (!std::isfinite(o->truth)) throw InputError("--cost " + o->cost + " needs --truth VALUE (it simulates the true trajectory)");
      PhysicalParameters true_params = base;
      set_parameter(true_params, range.name, o->truth);
      truth = simulate_truth(problem.scene, problem.grid, true_params, steps, cost);
      frame_cost = o->cost == "disp" ? displacement_cost(truth) : sdf_difference_cost(truth, cost);
    }
    std::vector<double> xs, costs, grads;
    for (int i = 0; i < range.count; ++i) {
      const double t = double(i) / (range.count - 1);
      xs.push_back(o->log ? range.lo * std::pow(range.hi / range.lo, t) : range.lo + t * (range.hi - range.lo));
    }
    Progress progress("sweep: sample", range.count, o->progress);
    // The samples are shared among the GPUs and MPI ranks (models/sim/batch_workers.h), each
    // worker running its own one after another.
    const std::vector<std::string> samples = run_shared(range.count, device, [&](const BatchShare& share) {
      Simulation sim(problem.scene, problem.grid, 1, true);
      place_on(sim, share.device);
      std::vector<std::string> done;
      for (int i = share.begin; i < share.end; ++i) {
        PhysicalParameters p = base;
        set_parameter(p, range.name, xs[size_t(i)]);
        sim.set_parameters(0, p);
        const CostGradient r = evaluate_trajectory_gradient(sim, steps, frame_cost)[0];
        ByteWriter w;
        w.put(r.cost);
        w.put(parameter_gradient(r.gradient, p, range.name));
        w.put_vector(r.frames);
        done.push_back(w.bytes());
        if (share.reports)
          progress.update(int(double(i + 1 - share.begin) * range.count / (share.end - share.begin)),
                          fmt::format("{} = {:.4g}", range.name, xs[size_t(i)]));
      }
      return done;
    });
    std::vector<FrameCost> best_matches;
    int best_matched = -1;
    std::string csv = fmt::format("{},cost,gradient,matched_points,observed_points\n", range.name);
    for (int i = 0; i < range.count; ++i) {
      ByteReader r(samples[size_t(i)]);
      costs.push_back(r.get<double>());
      grads.push_back(r.get<double>());
      const std::vector<FrameCost> frames = r.get_vector<FrameCost>();
      int points = 0, matched = 0;
      for (const FrameCost& f : frames) points += f.points, matched += f.matched;
      if (matched > best_matched) best_matched = matched, best_matches = frames;
      csv += fmt::format("{:.10g},{:.10g},{:.10g},{},{}\n", xs[size_t(i)], costs.back(), grads.back(), matched, points);
    }
    progress.finish();
    if (o->cost == "ssc") check_matches(best_matches, o->observations, "the sweep's best-matching sample");
    write_text_file(out.file("sweep.csv"), csv);
    const std::string unit = parameter_unit(range.name);
    const std::string cost_name = o->cost == "ssc" ? "J_SSC" : o->cost == "disp" ? "J_disp" : "J_SDF";
    PlotPanel cost_panel{"cost " + cost_name, fmt::format("{} [{}]", range.name, unit), "cost", o->log, false, false, {}, {}};
    PlotPanel grad_panel{"dJ/d" + range.name, fmt::format("{} [{}]", range.name, unit), "gradient", o->log, false, true, {}, {}};
    if (std::isfinite(o->truth)) cost_panel.vertical_lines = grad_panel.vertical_lines = {o->truth};
    cost_panel.series.push_back({"", xs, costs, plot_color(0), 1.5, true});
    grad_panel.series.push_back({"", xs, grads, plot_color(1), 1.5, true});
    write_svg_plot(out.file("sweep.svg"), {cost_panel, grad_panel});
    out.commit();
    std::printf("wrote %s/sweep.csv and %s/sweep.svg (%d samples)\n", o->out.c_str(), o->out.c_str(), range.count);
    return 0;
  };
}

}  // namespace ssc
