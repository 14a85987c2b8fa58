// Fitting the diagnosis's models (see model_fit.h).
#include "models/diagnosis/model_fit.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <random>

#include "models/cost/surface_constraint.h"
#include "models/optim/reconstruction.h"
#include "models/sim/compute_device.h"
#include "models/sim/extensions.h"
#include "models/sim/parameters.h"
#include "runtime/errors.h"

namespace ssc {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The value a parameter keeps in a model that does not fit it: the spec's fixed value, its
// extension's off value, or the scene's.
double held_value(const ModelSpec& spec, const std::string& name, const PhysicalParameters& scene_values) {
  if (const auto f = spec.fixed.find(name); f != spec.fixed.end()) return f->second;
  const ExtensionRow* row = find_extension(owner(name));
  if (row && row->fit == ExtensionRow::Fit::OffValue) return row->off_value;
  return get_parameter(scene_values, name);
}

void add_unique(std::vector<std::string>& list, const std::string& name) {
  if (std::find(list.begin(), list.end(), name) == list.end()) list.push_back(name);
}

// The base parameters' starts, as reconstruct draws them for the base model alone.
std::vector<std::map<std::string, double>> draw_base_starts(const Problem& shared, const DiagnosisContext& c) {
  const DiagnosisOptions& o = c.options;
  const PhysicalParameters nominal = PhysicalParameters::from_scene(shared.scene);
  const std::vector<std::string> base_names = expand_parameter_names(o.fit, nominal);
  std::vector<ParameterAxis> axes;
  Eigen::VectorXd base_nominal(Eigen::Index(base_names.size()));
  for (size_t i = 0; i < base_names.size(); ++i) {
    base_nominal[Eigen::Index(i)] = get_parameter(nominal, base_names[i]);
    axes.push_back(default_axis(base_names[i], base_nominal[Eigen::Index(i)]));
  }
  ReconstructionOptions sampling;
  sampling.starts = o.starts;
  sampling.seed = o.seed;
  sampling.start_ranges = scene_start_ranges(shared.scene);
  std::vector<std::map<std::string, double>> starts;
  for (const Eigen::VectorXd& x : sample_starts(ParameterSpace(axes), base_nominal, sampling)) {
    std::map<std::string, double> v;
    for (size_t i = 0; i < base_names.size(); ++i) v[base_names[i]] = x[Eigen::Index(i)];
    starts.push_back(v);
  }
  return starts;
}

}  // namespace

bool stopped_converged(const std::string& stop_reason) {
  return stop_reason == "gradient below tolerance" || stop_reason == "cost change below tolerance" ||
         stop_reason.rfind("converged", 0) == 0;
}

PhysicalParameters with_values(const Scene& scene, const std::vector<std::string>& names, const Eigen::VectorXd& v) {
  PhysicalParameters p = PhysicalParameters::from_scene(scene);
  for (size_t i = 0; i < names.size(); ++i)
    if (!is_measurement_parameter(names[i])) set_parameter(p, names[i], v[Eigen::Index(i)]);
  return p;
}

std::map<std::string, double> values_by_name(const FittedModel& m) {
  std::map<std::string, double> v;
  for (size_t i = 0; i < m.names.size() && i < size_t(m.values.size()); ++i) v[m.names[i]] = m.values[Eigen::Index(i)];
  return v;
}

std::vector<double> per_frame_costs(const Problem& problem, const PhysicalParameters& p, const std::string& device) {
  Simulation sim(problem.scene, problem.grid, 1, true);
  place_on(sim, device);
  sim.set_parameters(0, p);
  const SurfaceConstraintCost cost(problem.grid, problem.phi_max);
  GradientOptions o;
  o.gradient = false;
  const CostGradient r = evaluate_cost_gradient(sim, cost, problem.frames, o)[0];
  std::vector<double> out;
  for (const FrameCost& f : r.frames) out.push_back(f.cost);
  return out;
}

std::string with_unit(const std::string& name, double value) {
  const std::string unit = parameter_or_measurement_unit(name);
  return fmt::format("{:.4g}{}", value, unit == "1" ? "" : " " + unit);
}

// A base parameter that moves by more than this fraction once a candidate is modelled is reported.
constexpr double kBaseChange = 0.1;

std::vector<std::tuple<std::string, double, double>> moved_base(const FittedModel& base, const FittedModel& m) {
  const std::map<std::string, double> before = values_by_name(base);
  std::vector<std::tuple<std::string, double, double>> out;
  for (size_t k = 0; k < m.names.size(); ++k) {
    const auto b = before.find(m.names[k]);
    if (b == before.end() || b->second == 0) continue;
    const double after = m.values[Eigen::Index(k)];
    if (std::abs(after / b->second - 1) >= kBaseChange) out.emplace_back(m.names[k], b->second, after);
  }
  return out;
}

Problem held_in(const Problem& p, int frames) {
  Problem q = p;
  q.frames.resize(size_t(frames));
  return q;
}

std::vector<FittedModel> fit_together(const std::vector<ModelSpec>& specs, const DiagnosisContext& c,
                                      std::vector<std::map<std::string, double>>& base_starts,
                                      Problem* shared_problem, bool competing) {
  const auto t0 = std::chrono::steady_clock::now();
  const DiagnosisOptions& o = c.options;
  std::vector<std::string> all_overrides = c.overrides, fit = o.fit;
  for (const ModelSpec& spec : specs) {
    all_overrides.insert(all_overrides.end(), spec.overrides.begin(), spec.overrides.end());
    for (const std::string& e : spec.extra)  // the placebos share components
      if (spec.extra_in_load) add_unique(fit, e);
  }
  Problem shared = load_problem(c.scene_path, all_overrides, c.observations, c.phi_max, fit);
  for (const ModelSpec& spec : specs) {
    if (spec.adjust) spec.adjust(shared);
    for (const std::string& e : spec.extra) add_unique(fit, e);
    for (const auto& [name, value] : spec.fixed) add_unique(fit, name);
  }
  if (base_starts.empty()) base_starts = draw_base_starts(shared, c);
  const PhysicalParameters nominal = PhysicalParameters::from_scene(shared.scene);
  const std::vector<std::string> names = expand_parameter_names(fit, nominal);
  auto index_of = [&](const std::string& name) {
    return int(std::find(names.begin(), names.end(), name) - names.begin());
  };

  ReconstructionOptions ro;
  ro.fit = fit;
  ro.optimizer = o.optimizer;
  ro.optimizer_options.max_iterations = o.iterations;
  ro.seed = o.seed;
  ro.device = o.device;
  for (const std::string& n : names)
    if (const auto range = plausible_range(shared.scene, n, c.extent); std::isfinite(range.second))
      ro.bounds[n] = range;
  for (const ModelSpec& spec : specs) ro.typical_magnitudes.insert(spec.magnitudes.begin(), spec.magnitudes.end());
  std::vector<std::vector<std::string>> model_names;
  for (const ModelSpec& spec : specs) {
    std::vector<std::string> own = o.fit;
    own.insert(own.end(), spec.extra.begin(), spec.extra.end());
    model_names.push_back(expand_parameter_names(own, nominal));
    std::vector<int> free;
    for (const std::string& n : model_names.back()) free.push_back(index_of(n));
    std::mt19937_64 rng(o.seed * 7919 + std::hash<std::string>{}(spec.name));
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (const std::map<std::string, double>& base_values : base_starts) {
      Eigen::VectorXd x(Eigen::Index(names.size()));
      for (size_t i = 0; i < names.size(); ++i) x[Eigen::Index(i)] = held_value(spec, names[i], nominal);
      for (const std::string& n : model_names.back()) {
        double& xi = x[index_of(n)];
        if (const auto b = base_values.find(n); b != base_values.end()) {
          xi = b->second;
          continue;
        }
        const auto r = spec.ranges.at(n);
        const double u = unit(rng);
        xi = spec.log_range ? r.first * std::pow(r.second / r.first, u) : r.first + u * (r.second - r.first);
      }
      ro.initial_values.push_back(x);
      ro.start_free.push_back(free);
      if (competing) ro.competing_models.push_back(int(model_names.size()) - 1);
    }
  }
  ReconstructionProgress told;
  if (c.round_progress) {
    const std::string fits = specs.size() == 1 ? specs[0].name
                                               : fmt::format("{} and {} more", specs[0].name, specs.size() - 1);
    told = [&c, fits, iterations = o.iterations](int round, int active, double best, const Eigen::VectorXd&) {
      c.round_progress(fmt::format("{}: evaluation round {} (each start at most {} iterations), {} starts going on, "
                                   "best held-in cost {:.4g}",
                                   fits, round, iterations, active, best));
    };
  }
  const ReconstructionResult r = reconstruct(held_in(shared, c.heldin), ro, told);
  const double batch_seconds = seconds_since(t0);

  std::vector<FittedModel> models(specs.size());
  const size_t S = base_starts.size();
  // Each model's own problem and its cost over every frame, at its best start; side by side on GPUs.
  auto evaluate = [&](size_t m, const std::string& device) {
    const ModelSpec& spec = specs[m];
    FittedModel& fm = models[m];
    fm.name = spec.name;
    fm.spec = std::make_shared<const ModelSpec>(spec);
    fm.extra = spec.extra;
    fm.names = model_names[m];
    std::vector<std::string> own_overrides = c.overrides, own_fit = o.fit;
    own_overrides.insert(own_overrides.end(), spec.overrides.begin(), spec.overrides.end());
    if (spec.extra_in_load) own_fit.insert(own_fit.end(), spec.extra.begin(), spec.extra.end());
    fm.problem = load_problem(c.scene_path, own_overrides, c.observations, c.phi_max, own_fit);
    if (spec.adjust) spec.adjust(fm.problem);
    PhysicalParameters held = PhysicalParameters::from_scene(fm.problem.scene);
    for (const auto& [name, value] : spec.fixed) set_parameter(held, name, value);
    std::vector<size_t> ranked;  // the starts that finished, lowest held-in cost first
    for (size_t s = m * S; s < (m + 1) * S; ++s)
      if (!r.starts[s].failed && r.starts[s].final.size() > 0) ranked.push_back(s);
    std::stable_sort(ranked.begin(), ranked.end(),
                     [&](size_t a, size_t b) { return r.starts[a].final_cost < r.starts[b].final_cost; });
    fm.seconds = batch_seconds;
    fm.batches = r.batches;
    for (size_t s = m * S; s < (m + 1) * S; ++s) {
      fm.converged_starts += stopped_converged(r.starts[s].stop_reason);
      fm.per_start.push_back({r.starts[s].stop_reason, r.starts[s].iterations, r.starts[s].cost_history,
                              r.starts[s].restarts, r.starts[s].rounds});
    }
    fm.starts = int(S);
    // The fit is the best start whose parameters also simulate the frames held out: a start
    // can fit the held-in frames and then blow up after them (a soft body's spin, say).
    std::string blew_up;
    int tried = 0;
    for (size_t s : ranked) {
      const StartRecord& start = r.starts[s];
      fm.values.resize(Eigen::Index(fm.names.size()));
      for (size_t i = 0; i < fm.names.size(); ++i) fm.values[Eigen::Index(i)] = start.final[index_of(fm.names[i])];
      PhysicalParameters at = held;
      for (size_t i = 0; i < fm.names.size(); ++i) set_parameter(at, fm.names[i], fm.values[Eigen::Index(i)]);
      ++tried;
      try {
        fm.frame_costs = per_frame_costs(fm.problem, at, device);
      } catch (const SimulationError& e) {
        if (blew_up.empty()) blew_up = e.what();
        continue;
      }
      fm.stop_reason = start.stop_reason;
      if (start.stop_reason == "iteration limit")
        fm.note = fmt::format("the fit stopped at the iteration limit ({} iterations)", o.iterations);
      if (tried > 1)
        fm.note += fmt::format("{}the {} start(s) with a lower held-in cost failed on the frames held out ({}); the "
                               "next best is the fit",
                               fm.note.empty() ? "" : "; ", tried - 1, blew_up);
      for (size_t f = 0; f < fm.frame_costs.size(); ++f)
        (int(f) < c.heldin ? fm.heldin_cost : fm.heldout_cost) += fm.frame_costs[f];
      return;
    }
    fm.failed = true;
    fm.values.resize(0);
    if (!blew_up.empty())
      fm.failure = "every start's fit failed on the frames held out: " + blew_up;
    else
      fm.failure = r.starts[m * S].failure.empty() ? "no start" : r.starts[m * S].failure;
  };
  side_by_side(specs.size(), o.device, evaluate);
  if (shared_problem) *shared_problem = std::move(shared);
  return models;
}

}  // namespace ssc
