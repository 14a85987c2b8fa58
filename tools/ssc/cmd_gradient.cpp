// `ssc gradient SCENE --observations DIR`: the cost J_SSC and its exact gradient with
// respect to the physical parameters, as JSON; --check-fd adds central differences.
#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "models/sim/parameters.h"
#include "models/sim/problem.h"
#include "tools/ssc/commands.h"
#include "tools/ssc/device_option.h"
#include "tools/ssc/progress.h"
#include "models/io/run_record.h"
#include "models/sim/match_check.h"

namespace ssc {
namespace {

double fd_step(const std::string& name, double value) {
  if (name.find("_deg") != std::string::npos) return 1e-4;
  return 1e-6 * std::max(std::abs(value), 1.0);
}

}  // namespace

Command register_gradient(CLI::App& app) {
  struct Options {
    std::string device = "auto";
    std::string scene, observations;
    std::vector<std::string> overrides, params;
    bool check_fd = false;
    double phi_max = 0;
    ProgressMode progress = ProgressMode::Auto;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand("gradient", "Cost and exact adjoint gradient of the sparse surface constraint");
  sub->add_option("scene", o->scene, "Scene file (the model whose cost is evaluated)")->required();
  sub->add_option("--observations", o->observations, "Observation folder (docs/observation-format.md)")->required();
  sub->add_option("--set", o->overrides, "Override a scene key: dotted.key=JSON, repeatable");
  add_device_option(sub, &o->device);
  sub->add_option("--params", o->params, "Parameters to report (default: all), comma-separated")->delimiter(',');
  sub->add_option("--phi-max", o->phi_max, "Cost threshold in metres (default: the scene's, else 2 cells)");
  sub->add_flag("--check-fd", o->check_fd, "Also compute central finite differences (tightens the solver tolerances)");
  add_progress_options(sub, &o->progress);
  return [o] {
    std::vector<std::string> overrides = o->overrides;
    if (o->check_fd) {
      overrides.push_back("solver.tolerance=1e-12");
      overrides.push_back("solver.extension_tolerance=1e-13");
    }
    // Without --params every parameter is listed, friction's too: it is modelled (at the
    // scene's mu, 0 by default, which changes no result) so that its gradient is true.
    const Problem problem = load_problem(o->scene, overrides, o->observations, o->phi_max,
                                         o->params.empty() ? std::vector<std::string>{"ground.friction"} : o->params);
    Simulation sim(problem.scene, problem.grid, 1, true);
    place_simulation(sim, o->device);
    const SurfaceConstraintCost cost(problem.grid, problem.phi_max);
    const PhysicalParameters base = sim.parameters(0);
    const std::vector<std::string> names =
        expand_parameter_names(o->params.empty() ? all_parameter_names(base) : o->params, base);
    const CostGradient r = evaluate_cost_gradient(sim, cost, problem.frames)[0];
    nlohmann::json out;
    out["cost"] = r.cost;
    out["phi_max"] = problem.phi_max;
    int points = 0, matched = 0;
    for (const FrameCost& f : r.frames) points += f.points, matched += f.matched;
    out["observed_points"] = points;
    out["matched_points"] = matched;
    check_matches(r.frames, o->observations, "the scene's parameters");
    Progress progress("finite differences: parameter", int(names.size()), o->progress);
    nlohmann::json params = nlohmann::json::object();
    GradientOptions cost_only;
    cost_only.gradient = false;
    for (size_t i = 0; i < names.size(); ++i) {
      const std::string& n = names[i];
      nlohmann::json e;
      e["value"] = get_parameter(base, n);
      e["unit"] = parameter_unit(n);
      e["gradient"] = parameter_gradient(r.gradient, base, n);
      if (o->check_fd) {
        const double h = fd_step(n, e["value"].get<double>());
        PhysicalParameters plus = base, minus = base;
        set_parameter(plus, n, get_parameter(base, n) + h);
        set_parameter(minus, n, get_parameter(base, n) - h);
        sim.set_parameters(0, plus);
        const double cp = evaluate_cost_gradient(sim, cost, problem.frames, cost_only)[0].cost;
        sim.set_parameters(0, minus);
        const double cm = evaluate_cost_gradient(sim, cost, problem.frames, cost_only)[0].cost;
        const double fd = (cp - cm) / (2 * h);
        const double g = e["gradient"].get<double>();
        e["finite_difference"] = fd;
        e["fd_step"] = h;
        e["relative_error"] = std::abs(g - fd) / std::max(std::abs(fd), 1e-300);
        progress.update(int(i) + 1, n);
      }
      params[n] = e;
    }
    progress.finish();
    out["parameters"] = params;
    out["warnings"] = warnings_json();
    std::printf("%s\n", out.dump(2).c_str());
    return 0;
  };
}

}  // namespace ssc
