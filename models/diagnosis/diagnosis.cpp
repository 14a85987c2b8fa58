// `ssc diagnose` (see diagnosis.h).
#include "models/diagnosis/diagnosis.h"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <set>

#include "models/cost/surface_constraint.h"
#include "models/diagnosis/residuals.h"
#include "models/optim/reconstruction.h"
#include "models/sim/parameters.h"
#include "runtime/errors.h"

namespace ssc {
namespace {

// Typical amounts of an effect: the score test's predicted decrease and the identifiability's
// steps at off are taken at these.
constexpr double kTypicalFriction = 0.3, kTypicalAirDrag = 10;  // 1, kg/m^3

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// How a model differs from the base: scene overrides, parameters to fit beside the base's
// (with the range their starts are drawn from), and a change of the loaded problem.
struct ModelSpec {
  explicit ModelSpec(std::string model) : name(std::move(model)) {}
  std::string name;
  std::vector<std::string> overrides, extra;
  std::map<std::string, std::pair<double, double>> ranges;  // per extra parameter
  std::map<std::string, double> magnitudes;                 // typical magnitudes of free extra parameters
  bool log_range = false;                                   // draw log-uniformly (positive parameters)
  std::function<void(Problem&)> adjust;
  // The scene loads with the extra parameters named (which puts friction's and drag's ops in
  // the model), unless adjust makes what they name (a new plane).
  bool extra_in_load = true;
};

PhysicalParameters with_values(const Scene& scene, const std::vector<std::string>& names, const Eigen::VectorXd& v) {
  PhysicalParameters p = PhysicalParameters::from_scene(scene);
  for (size_t i = 0; i < names.size(); ++i) set_parameter(p, names[i], v[Eigen::Index(i)]);
  return p;
}

std::vector<double> per_frame_costs(const Problem& problem, const PhysicalParameters& p, const std::string& device) {
  Simulation sim(problem.scene, problem.grid, 1, true);
  if (device == "cuda") sim.use_gpu();
  sim.set_parameters(0, p);
  const SurfaceConstraintCost cost(problem.grid, problem.phi_max);
  GradientOptions o;
  o.gradient = false;
  const CostGradient r = evaluate_cost_gradient(sim, cost, problem.frames, o)[0];
  std::vector<double> out;
  for (const FrameCost& f : r.frames) out.push_back(f.cost);
  return out;
}

Problem held_in(const Problem& p, int frames) {
  Problem q = p;
  q.frames.resize(size_t(frames));
  return q;
}

// The fit of one model on the held-in frames. With base_starts (the base fit's start values,
// one map per start), every start takes the base parameters' values from there and draws the
// extension's from their ranges: every model gets the same budget from the same points.
FittedModel fit_model(const ModelSpec& spec, const std::string& scene_path, const std::vector<std::string>& overrides,
                      const std::string& observations, double phi_max, const DiagnosisOptions& o, int heldin,
                      const std::vector<std::map<std::string, double>>* base_starts,
                      std::vector<std::map<std::string, double>>* starts_used = nullptr) {
  const auto t0 = std::chrono::steady_clock::now();
  FittedModel m;
  m.name = spec.name;
  std::vector<std::string> all_overrides = overrides;
  all_overrides.insert(all_overrides.end(), spec.overrides.begin(), spec.overrides.end());
  std::vector<std::string> fit = o.fit;
  if (spec.extra_in_load) fit.insert(fit.end(), spec.extra.begin(), spec.extra.end());
  m.problem = load_problem(scene_path, all_overrides, observations, phi_max, fit);
  if (spec.adjust) spec.adjust(m.problem);
  if (!spec.extra_in_load) fit.insert(fit.end(), spec.extra.begin(), spec.extra.end());
  m.names = expand_parameter_names(fit, PhysicalParameters::from_scene(m.problem.scene));
  m.extra = spec.extra;
  ReconstructionOptions ro;
  ro.fit = fit;
  ro.starts = o.starts;
  ro.optimizer = o.optimizer;
  ro.optimizer_options.max_iterations = o.iterations;
  ro.seed = o.seed;
  ro.device = o.device;
  ro.typical_magnitudes = spec.magnitudes;
  if (base_starts) {
    std::mt19937_64 rng(o.seed * 7919 + std::hash<std::string>{}(spec.name));
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (const std::map<std::string, double>& base_values : *base_starts) {
      Eigen::VectorXd x(Eigen::Index(m.names.size()));
      for (size_t i = 0; i < m.names.size(); ++i) {
        if (const auto b = base_values.find(m.names[i]); b != base_values.end()) {
          x[Eigen::Index(i)] = b->second;
          continue;
        }
        const auto r = spec.ranges.at(m.names[i]);
        const double u = unit(rng);
        x[Eigen::Index(i)] = spec.log_range ? r.first * std::pow(r.second / r.first, u) : r.first + u * (r.second - r.first);
      }
      ro.initial_values.push_back(x);
    }
  }
  const ReconstructionResult r = reconstruct(held_in(m.problem, heldin), ro);
  if (starts_used)
    for (const StartRecord& start : r.starts) {
      std::map<std::string, double> v;
      for (size_t i = 0; i < r.names.size(); ++i) v[r.names[i]] = start.initial[Eigen::Index(i)];
      starts_used->push_back(v);
    }
  m.seconds = seconds_since(t0);
  if (r.best < 0) {
    m.failed = true;
    m.failure = r.starts.empty() ? "no start" : r.starts[0].failure;
    return m;
  }
  m.values = r.starts[size_t(r.best)].final;
  if (r.starts[size_t(r.best)].stop_reason == "iteration limit")
    m.note = fmt::format("the fit stopped at the iteration limit ({} iterations)", o.iterations);
  m.frame_costs = per_frame_costs(m.problem, with_values(m.problem.scene, m.names, m.values), o.device);
  for (size_t f = 0; f < m.frame_costs.size(); ++f) (int(f) < heldin ? m.heldin_cost : m.heldout_cost) += m.frame_costs[f];
  m.seconds = seconds_since(t0);
  return m;
}

// The extension a parameter belongs to ("mass_damping" and the base's own for the others).
std::string owner(const std::string& parameter) {
  if (parameter.find("friction") != std::string::npos) return "friction";
  if (parameter == "air_drag") return "air_drag";
  if (parameter.find("stiffness_gradient") != std::string::npos) return "heterogeneous_stiffness";
  if (parameter.rfind("ground.planes[", 0) == 0 && parameter.find(".height") != std::string::npos) return "second_plane";
  return parameter;
}

// The value a parameter of the shared graph keeps in a model that does not fit it: an
// extension's "off" value, or the scene's.
double off_value(const std::string& name, const PhysicalParameters& scene_values) {
  const std::string o = owner(name);
  if (o == "friction" || o == "air_drag" || o == "heterogeneous_stiffness") return 0.0;
  return get_parameter(scene_values, name);
}

// Models that share one graph (the base, its placebos, and the extensions with an "off"
// value: friction, air drag, a stiffness gradient), fitted as one batch of starts: the
// scene with every extension's ops, each model's starts moving only its own parameters and
// holding the others at off. Every model gets the base fit's starts for the base
// parameters (drawn as `reconstruct` draws them) and its own drawn from its ranges, and the
// same iterations. The first spec is the base; base_starts receives its start values.
std::vector<FittedModel> fit_together(const std::vector<ModelSpec>& specs, const std::string& scene_path,
                                      const std::vector<std::string>& overrides, const std::string& observations,
                                      double phi_max, const DiagnosisOptions& o, int heldin,
                                      std::vector<std::map<std::string, double>>* base_starts, Problem* shared_problem) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::string> all_overrides = overrides, fit = o.fit;
  for (const ModelSpec& spec : specs) {
    all_overrides.insert(all_overrides.end(), spec.overrides.begin(), spec.overrides.end());
    for (const std::string& e : spec.extra)  // the placebos share components
      if (std::find(fit.begin(), fit.end(), e) == fit.end()) fit.push_back(e);
  }
  Problem shared = load_problem(scene_path, all_overrides, observations, phi_max, fit);
  for (const ModelSpec& spec : specs)
    if (spec.adjust) spec.adjust(shared);
  const PhysicalParameters nominal = PhysicalParameters::from_scene(shared.scene);
  const std::vector<std::string> names = expand_parameter_names(fit, nominal);
  auto index_of = [&](const std::string& name) {
    return int(std::find(names.begin(), names.end(), name) - names.begin());
  };

  // The base parameters' starts, as reconstruct draws them for the base model alone.
  const std::vector<std::string> base_names = expand_parameter_names(o.fit, nominal);
  std::vector<ParameterAxis> base_axes;
  Eigen::VectorXd base_nominal(Eigen::Index(base_names.size()));
  for (size_t i = 0; i < base_names.size(); ++i) {
    base_nominal[Eigen::Index(i)] = get_parameter(nominal, base_names[i]);
    base_axes.push_back(default_axis(base_names[i], base_nominal[Eigen::Index(i)]));
  }
  ReconstructionOptions sampling;
  sampling.starts = o.starts;
  sampling.seed = o.seed;
  sampling.start_ranges = scene_start_ranges(shared.scene);
  const std::vector<Eigen::VectorXd> drawn = sample_starts(ParameterSpace(base_axes), base_nominal, sampling);
  for (const Eigen::VectorXd& x : drawn) {
    std::map<std::string, double> v;
    for (size_t i = 0; i < base_names.size(); ++i) v[base_names[i]] = x[Eigen::Index(i)];
    base_starts->push_back(v);
  }

  ReconstructionOptions ro;
  ro.fit = fit;
  ro.optimizer = o.optimizer;
  ro.optimizer_options.max_iterations = o.iterations;
  ro.seed = o.seed;
  ro.device = o.device;
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
    for (const std::map<std::string, double>& base_values : *base_starts) {
      Eigen::VectorXd x(Eigen::Index(names.size()));
      for (size_t i = 0; i < names.size(); ++i) x[Eigen::Index(i)] = off_value(names[i], nominal);
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
    }
  }
  const ReconstructionResult r = reconstruct(held_in(shared, heldin), ro);
  const double batch_seconds = seconds_since(t0);
  *shared_problem = shared;

  std::vector<FittedModel> models;
  const size_t S = base_starts->size();
  for (size_t m = 0; m < specs.size(); ++m) {
    const ModelSpec& spec = specs[m];
    FittedModel fm;
    fm.name = spec.name;
    fm.extra = spec.extra;
    fm.names = model_names[m];
    std::vector<std::string> own_overrides = overrides, own_fit = o.fit;
    own_overrides.insert(own_overrides.end(), spec.overrides.begin(), spec.overrides.end());
    own_fit.insert(own_fit.end(), spec.extra.begin(), spec.extra.end());
    fm.problem = load_problem(scene_path, own_overrides, observations, phi_max, own_fit);
    if (spec.adjust) spec.adjust(fm.problem);
    int best = -1;
    for (size_t s = m * S; s < (m + 1) * S; ++s)
      if (!r.starts[s].failed && r.starts[s].final.size() > 0 &&
          (best < 0 || r.starts[s].final_cost < r.starts[size_t(best)].final_cost))
        best = int(s);
    fm.seconds = batch_seconds;
    if (best < 0) {
      fm.failed = true;
      fm.failure = r.starts[m * S].failure.empty() ? "no start" : r.starts[m * S].failure;
      models.push_back(std::move(fm));
      continue;
    }
    const StartRecord& start = r.starts[size_t(best)];
    fm.values.resize(Eigen::Index(fm.names.size()));
    for (size_t i = 0; i < fm.names.size(); ++i) fm.values[Eigen::Index(i)] = start.final[index_of(fm.names[i])];
    if (start.stop_reason == "iteration limit")
      fm.note = fmt::format("the fit stopped at the iteration limit ({} iterations)", o.iterations);
    fm.frame_costs = per_frame_costs(fm.problem, with_values(fm.problem.scene, fm.names, fm.values), o.device);
    for (size_t f = 0; f < fm.frame_costs.size(); ++f)
      (int(f) < heldin ? fm.heldin_cost : fm.heldout_cost) += fm.frame_costs[f];
    models.push_back(std::move(fm));
  }
  return models;
}

std::map<std::string, double> values_by_name(const FittedModel& m) {
  std::map<std::string, double> v;
  for (size_t i = 0; i < m.names.size(); ++i) v[m.names[i]] = m.values[Eigen::Index(i)];
  return v;
}

std::string plane_parameter(int k, const std::string& key) {
  return k == 0 ? "ground." + key : fmt::format("ground.planes[{}].{}", k, key);
}

// The plane the data ask for: the direction (of 8 horizontal ones and up) along which the
// base fit's simulated body went furthest beyond every observed point of the held-in frames.
// Empty when it never did by more than half a cell.
struct PlaneProposal {
  bool found = false;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitY();
  double height = 0, overshoot = 0;
};

PlaneProposal propose_plane(const FittedModel& base, int heldin) {
  const Problem& p = base.problem;
  const PhysicalParameters params = with_values(p.scene, base.names, base.values);
  const Eigen::Vector3d up = -params.gravity.normalized();
  Eigen::Vector3d e1 = up.unitOrthogonal(), e2 = up.cross(e1);
  std::vector<Eigen::Vector3d> directions;
  for (int a = 0; a < 8; ++a) directions.push_back(std::cos(a * M_PI / 4) * e1 + std::sin(a * M_PI / 4) * e2);
  directions.push_back(up);
  std::vector<double> observed(directions.size(), -1e300), simulated(directions.size(), -1e300);
  Simulation sim(p.scene, p.grid, 1, false);
  sim.set_parameters(0, params);
  int step = 0;
  for (int f = 0; f < heldin; ++f) {
    const ObservedFrame& frame = p.frames[size_t(f)];
    while (step < frame.step) sim.step(), ++step;
    const double* u = sim.displacement(0);
    for (size_t d = 0; d < directions.size(); ++d) {
      for (const Eigen::Vector3d& x : frame.points) observed[d] = std::max(observed[d], x.dot(directions[d]));
      if (frame.points.empty()) continue;
      for (int i = 0; i < p.grid.node_count; ++i) {
        const Eigen::Vector3d x =
            p.grid.sdf.node_position(p.grid.node_grid[size_t(i)]) + Eigen::Vector3d(u[3 * i], u[3 * i + 1], u[3 * i + 2]);
        simulated[d] = std::max(simulated[d], x.dot(directions[d]));
      }
    }
  }
  PlaneProposal best;
  for (size_t d = 0; d < directions.size(); ++d) {
    const double over = simulated[d] - observed[d];
    if (over > 0.5 * p.grid.h && over > best.overshoot) {
      best.found = true;
      best.overshoot = over;
      best.normal = -directions[d];
      best.height = -observed[d];  // n . x >= height keeps the body on the observed side
    }
  }
  return best;
}

// Fraction of the base's held-out cost a model removes, and its moving-block bootstrap
// interval (5 %, 95 %) over the held-out frames.
struct Gain {
  double value = 0, low = 0, high = 0;
};

Gain held_out_gain(const std::vector<double>& base, const std::vector<double>& model, int heldin, int resamples,
                   std::uint64_t seed) {
  const int n = int(base.size()) - heldin;
  Gain g;
  if (n <= 0 || model.size() != base.size()) return g;
  auto gain_of = [&](const std::vector<int>& frames) {
    double b = 0, m = 0;
    for (int f : frames) b += base[size_t(heldin + f)], m += model[size_t(heldin + f)];
    return b > 0 ? 1 - m / b : 0.0;
  };
  std::vector<int> all(static_cast<size_t>(n));
  for (int f = 0; f < n; ++f) all[size_t(f)] = f;
  g.value = gain_of(all);
  const int block = std::max(1, n / 4), blocks = (n + block - 1) / block;
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> start(0, n - block);
  std::vector<double> samples;
  for (int r = 0; r < resamples; ++r) {
    std::vector<int> frames;
    for (int b = 0; b < blocks; ++b) {
      const int s = start(rng);
      for (int k = 0; k < block; ++k) frames.push_back(s + k);
    }
    samples.push_back(gain_of(frames));
  }
  std::sort(samples.begin(), samples.end());
  g.low = samples[size_t(0.05 * (samples.size() - 1))];
  g.high = samples[size_t(0.95 * (samples.size() - 1))];
  return g;
}

// The score test: d (held-in cost) / d (the extension's parameters) at the base fit with
// every extension off, as the relative decrease a typical amount would bring (friction 0.3,
// air drag 10 kg/m^3: one-sided, they cannot go below 0; a stiffness gradient of 2 1/m in
// its best direction).
std::map<std::string, double> score_test(const FittedModel& base, const std::string& scene_path,
                                         const std::vector<std::string>& overrides, const std::string& observations,
                                         double phi_max, const DiagnosisOptions& o, int heldin) {
  std::vector<std::string> over = overrides;
  over.push_back("air_drag=1");
  std::vector<std::string> fit = o.fit;
  const int planes = int(base.problem.scene.planes.size());
  for (int k = 0; k < planes; ++k) fit.push_back(plane_parameter(k, "friction"));
  fit.push_back("material.stiffness_gradient");
  Problem p = load_problem(scene_path, over, observations, phi_max, fit);
  p.frames.resize(size_t(heldin));
  PhysicalParameters params = PhysicalParameters::from_scene(p.scene);
  for (const auto& [name, value] : values_by_name(base)) set_parameter(params, name, value);
  for (PlaneSpec& plane : params.planes) plane.friction = 0;
  params.air_drag = 0;
  params.stiffness_gradient.setZero();
  Simulation sim(p.scene, p.grid, 1, true);
  if (o.device == "cuda") sim.use_gpu();
  sim.set_parameters(0, params);
  const SurfaceConstraintCost cost(p.grid, p.phi_max);
  const CostGradient r = evaluate_cost_gradient(sim, cost, p.frames, {})[0];
  std::map<std::string, double> score;
  if (!(r.cost > 0)) return score;
  double friction = 0;
  for (int k = 0; k < planes; ++k) friction += parameter_gradient(r.gradient, params, plane_parameter(k, "friction"));
  score["friction"] = std::max(0.0, -kTypicalFriction * friction) / r.cost;
  score["air_drag"] = std::max(0.0, -kTypicalAirDrag * parameter_gradient(r.gradient, params, "air_drag")) / r.cost;
  Eigen::Vector3d g;
  for (int a = 0; a < 3; ++a)
    g[a] = parameter_gradient(r.gradient, params, std::string("material.stiffness_gradient.") + "xyz"[a]);
  score["heterogeneous_stiffness"] = 2.0 * g.norm() / r.cost;
  return score;
}

// The placebo's parameters: initial velocity components that the base fit leaves alone,
// those along which the scene's body does not move first (the horizontal linear components
// it gives as 0, then the spin's), those of its motion last (the other horizontal ones,
// slowest first, then the vertical). Freedom to fit the held-in frames that no missing
// effect stands behind. The components of the motion come last because they are not
// without meaning: a slower throw mimics air drag, as a constant force mimics friction.
std::vector<std::string> placebo_parameters(const Scene& scene, const std::vector<std::string>& base_fit) {
  const PhysicalParameters p = PhysicalParameters::from_scene(scene);
  const std::vector<std::string> fitted = expand_parameter_names(base_fit, p);
  const Eigen::Vector3d g = p.gravity.cwiseAbs();
  int along = 0;
  for (int a = 1; a < 3; ++a)
    if (g[a] > g[along]) along = a;
  auto linear = [](int a) { return std::string("initial.linear_velocity.") + "xyz"[a]; };
  std::vector<int> still, moving;
  for (int a = 0; a < 3; ++a)
    if (a != along) (get_parameter(p, linear(a)) == 0 ? still : moving).push_back(a);
  std::stable_sort(moving.begin(), moving.end(), [&](int a, int b) {
    return std::abs(get_parameter(p, linear(a))) < std::abs(get_parameter(p, linear(b)));
  });
  std::vector<std::string> order;
  for (int a : still) order.push_back(linear(a));
  for (int a = 0; a < 3; ++a) order.push_back(std::string("initial.angular_velocity.") + "xyz"[a]);
  for (int a : moving) order.push_back(linear(a));
  order.push_back(linear(along));
  std::vector<std::string> out;
  for (const std::string& name : order)
    if (std::find(fitted.begin(), fitted.end(), name) == fitted.end()) out.push_back(name);
  return out;
}

// The largest extent of the rest body (m).
double body_extent(const SimGrid& grid) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (int i = 0; i < grid.node_count; ++i) {
    const Eigen::Vector3d x = grid.sdf.node_position(grid.node_grid[size_t(i)]);
    lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
  }
  return grid.node_count > 0 ? (hi - lo).maxCoeff() : 1.0;
}

// A candidate's model, except where it needs the base fit (second_plane's plane). extent:
// the body's (m); a stiffness gradient's typical magnitude is 2 / extent (the modulus
// changes by e^2 across the body), its starts within half that.
ModelSpec candidate_spec(const std::string& name, int planes, double extent) {
  ModelSpec spec{name};
  if (name == "friction") {
    for (int k = 0; k < planes; ++k) {
      spec.extra.push_back(plane_parameter(k, "friction"));
      spec.ranges[spec.extra.back()] = {0.02, 1.0};
    }
    spec.log_range = true;
    spec.adjust = [planes](Problem& p) {  // a positive nominal value (the starts are drawn anyway)
      for (int k = 0; k < planes; ++k) p.scene.planes[size_t(k)].friction = 0.1;
    };
  } else if (name == "air_drag") {
    spec.overrides = {"air_drag=1"};
    spec.extra = {"air_drag"};
    spec.ranges["air_drag"] = {0.5, 50};
    spec.log_range = true;
  } else if (name == "heterogeneous_stiffness") {
    spec.overrides = {"material.stiffness_gradient=[0,0,0]"};
    spec.extra = {"material.stiffness_gradient"};
    for (const char* a : {"x", "y", "z"}) {
      const std::string component = std::string("material.stiffness_gradient.") + a;
      spec.ranges[component] = {-1 / extent, 1 / extent};
      spec.magnitudes[component] = 2 / extent;
    }
  } else if (name == "nonlinear_material") {
    spec.overrides = {"material.model=\"neo_hookean\""};
  }
  return spec;
}

// The first frame from which an extension acts in its fit (see CandidateVerdict), -1 if never.
int event_frame(const FittedModel& m, const std::string& device) {
  if (m.name == "air_drag") return 0;
  const Residuals r = compute_residuals(m.problem, with_values(m.problem.scene, m.names, m.values), device);
  const int added = m.name == "second_plane" ? int(m.problem.scene.planes.size()) - 1 : -1;
  for (const FrameResiduals& f : r.frames)
    if (f.phase == "contact" && (added < 0 || f.plane == added)) return f.frame;
  return -1;
}

// Twice the summed point costs of frames [from, to): the residual sum of squares for small
// residuals (surface_constraint.h), and the number of observed points there.
std::pair<double, double> residual_sum(const std::vector<double>& frame_costs, const Problem& p, int from, int to) {
  double rss = 0, n = 0;
  for (int f = std::max(0, from); f < to && f < int(frame_costs.size()); ++f) {
    const ObservedFrame& frame = p.frames[size_t(f)];
    if (frame.points.empty() || !(frame.weight > 0)) continue;
    rss += 2 * frame_costs[size_t(f)] * double(frame.points.size()) / frame.weight;
    n += double(frame.points.size());
  }
  return {rss, n};
}

std::string percent(double x) { return fmt::format("{:.0f} %", 100 * x); }

// Fills d.identifiability and d.indistinguishable at the fit m of the cause: over m's
// parameters, the mass damping, and (shared: the graph m was fitted in, with every extension
// that has an off value) the other candidates' parameters at off. Steps: 1e-3 of a value, 1e-2
// of a typical amount at 0 (forward, so that friction and drag stay valid).
void identifiability_at(Diagnosis& d, const FittedModel& m, const Problem* shared, const std::string& device,
                        double extent) {
  const Problem& problem = shared ? *shared : m.problem;
  PhysicalParameters at = PhysicalParameters::from_scene(problem.scene);
  std::vector<std::string> names = m.names;
  if (shared) {
    for (const std::string& n : expand_parameter_names({"air_drag", "material.stiffness_gradient"}, at))
      if (std::find(names.begin(), names.end(), n) == names.end()) names.push_back(n);
    for (size_t k = 0; k < problem.scene.planes.size(); ++k)
      if (const std::string n = plane_parameter(int(k), "friction"); std::find(names.begin(), names.end(), n) == names.end())
        names.push_back(n);
    for (const std::string& n : names) set_parameter(at, n, off_value(n, at));
  }
  for (size_t i = 0; i < m.names.size(); ++i) set_parameter(at, m.names[i], m.values[Eigen::Index(i)]);
  if (std::find(names.begin(), names.end(), "mass_damping") == names.end()) names.push_back("mass_damping");
  std::vector<double> steps;
  for (const std::string& n : names) {
    const double v = get_parameter(at, n);
    const std::string o = owner(n);
    const double typical = o == "friction"                  ? kTypicalFriction
                           : o == "air_drag"                ? kTypicalAirDrag
                           : o == "heterogeneous_stiffness" ? 2 / extent
                                                            : 1.0;
    steps.push_back(v != 0 ? 1e-3 * std::abs(v) : 1e-2 * typical);
  }
  Problem heldin = problem;
  heldin.frames.resize(size_t(d.heldin_frames));
  d.identifiability = parameter_correlation(heldin, at, names, steps, device);
  if (!d.identifiability.failure.empty()) return;
  names = d.identifiability.names;
  for (size_t i = 0; i < names.size(); ++i)
    for (size_t j = i + 1; j < names.size(); ++j) {
      const double r = d.identifiability.correlation(Eigen::Index(i), Eigen::Index(j));
      if (std::abs(r) < 0.95) continue;
      d.indistinguishable.emplace_back(names[i], names[j], r);
      const std::string a = owner(names[i]), b = owner(names[j]);
      if (a == b || (a != m.name && b != m.name)) continue;
      const std::string other = a == m.name ? b : a;
      const bool listed = std::any_of(d.confounded.begin(), d.confounded.end(), [&](const auto& p) {
        return (p.first == m.name && p.second == other) || (p.first == other && p.second == m.name);
      });
      const auto& candidates = diagnosis_candidate_names();
      if (!listed && (other == "mass_damping" || std::find(candidates.begin(), candidates.end(), other) != candidates.end()))
        d.confounded.push_back({m.name, other});
    }
}

}  // namespace

ParameterCorrelation parameter_correlation(const Problem& problem, const PhysicalParameters& at,
                                           const std::vector<std::string>& names, const std::vector<double>& steps,
                                           const std::string& device) {
  ParameterCorrelation c;
  const int n = int(names.size());
  if (n == 0 || steps.size() != names.size()) throw InputError("parameter_correlation: one step per parameter");
  Simulation sim(problem.scene, problem.grid, n + 1, true);
  if (device == "cuda") sim.use_gpu();
  sim.set_parameters(0, at);
  for (int j = 0; j < n; ++j) {
    PhysicalParameters p = at;
    set_parameter(p, names[size_t(j)], get_parameter(at, names[size_t(j)]) + steps[size_t(j)]);
    sim.set_parameters(j + 1, p);
  }
  // Each point's residual r, its cost term r^2 / 2 (surface_constraint.h): r = sign(phi) phi_max
  // sqrt(1 - exp(-phi^2 / phi_max^2)) sqrt(weight / N), phi_max sqrt(weight / N) unmatched.
  const SurfaceConstraintCost cost(problem.grid, problem.phi_max);
  const double phi_max = problem.phi_max;
  std::vector<std::vector<double>> r(size_t(n + 1));
  int step = 0;
  for (const ObservedFrame& frame : problem.frames) {
    while (step < frame.step) sim.step(), ++step;
    if (frame.points.empty()) continue;
    const double scale = std::sqrt(frame.weight / double(frame.points.size()));
    for (int item = 0; item <= n; ++item)
      for (const SurfaceConstraintCost::PointResidual& p :
           cost.point_residuals(frame.points, sim.displacement(item), sim.band_displacement(item)))
        r[size_t(item)].push_back(
            scale * (p.matched() ? std::copysign(phi_max * std::sqrt(-std::expm1(-p.phi * p.phi / (phi_max * phi_max))), p.phi)
                                 : phi_max));
  }
  Eigen::MatrixXd J(Eigen::Index(r[0].size()), n);
  const Eigen::Map<const Eigen::VectorXd> r0(r[0].data(), Eigen::Index(r[0].size()));
  for (int j = 0; j < n; ++j)
    J.col(j) = (Eigen::Map<const Eigen::VectorXd>(r[size_t(j + 1)].data(), Eigen::Index(r[0].size())) - r0) /
               steps[size_t(j)];
  const Eigen::MatrixXd gn = J.transpose() * J;
  std::vector<int> kept;  // the parameters whose step moved the residuals beyond rounding
  for (int i = 0; i < n; ++i)
    (std::abs(steps[size_t(i)]) * J.col(i).norm() > 1e-9 * r0.norm() ? kept.push_back(i) : c.flat.push_back(names[size_t(i)]));
  for (int i : kept) c.names.push_back(names[size_t(i)]);
  const Eigen::Index k = Eigen::Index(kept.size());
  c.gauss_newton.resize(k, k);
  for (Eigen::Index i = 0; i < k; ++i)
    for (Eigen::Index m = 0; m < k; ++m) c.gauss_newton(i, m) = gn(kept[size_t(i)], kept[size_t(m)]);
  if (k < 2) {
    c.failure = "fewer than 2 parameters change the residuals";
    return c;
  }
  // The covariance (up to a factor), scaled to a unit diagonal; an exactly confounded pair
  // (a zero eigenvalue) comes out with correlation +-1.
  const Eigen::VectorXd s = c.gauss_newton.diagonal().cwiseSqrt().cwiseInverse();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(s.asDiagonal() * c.gauss_newton * s.asDiagonal());
  const Eigen::VectorXd inverse =
      eig.eigenvalues().cwiseMax(1e-9 * eig.eigenvalues().maxCoeff()).cwiseInverse();
  const Eigen::MatrixXd covariance = eig.eigenvectors() * inverse.asDiagonal() * eig.eigenvectors().transpose();
  const Eigen::VectorXd t = covariance.diagonal().cwiseSqrt().cwiseInverse();
  c.correlation = t.asDiagonal() * covariance * t.asDiagonal();
  return c;
}

Diagnosis diagnose(const std::string& scene_path, const std::vector<std::string>& overrides,
                   const std::string& observations, double phi_max, const DiagnosisOptions& o,
                   const DiagnosisProgress& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  auto say = [&](const std::string& s) {
    if (progress) progress(s);
  };
  for (const std::string& c : o.candidates)
    if (std::find(diagnosis_candidate_names().begin(), diagnosis_candidate_names().end(), c) ==
        diagnosis_candidate_names().end())
      throw InputError(fmt::format("--candidates: unknown candidate '{}'; known: friction, heterogeneous_stiffness, "
                                   "second_plane, nonlinear_material, air_drag",
                                   c));
  if (!(o.holdout > 0 && o.holdout < 1)) throw InputError("--holdout must be in (0, 1)");
  Diagnosis d;
  Scene probe_scene;
  double extent = 1;
  {
    const Problem probe = load_problem(scene_path, overrides, observations, phi_max, o.fit);
    const int n = int(probe.frames.size());
    d.heldin_frames = std::max(2, int(std::ceil((1 - o.holdout) * n)));
    d.heldout_frames = n - d.heldin_frames;
    if (d.heldout_frames < 2)
      throw InputError(fmt::format("{}: {} observed frames leave fewer than 2 to hold out at --holdout {}; observe more "
                                   "frames or raise --holdout",
                                   observations, n, o.holdout));
    d.heldout_from = probe.frames[size_t(d.heldin_frames)].step * probe.scene.time.dt;
    probe_scene = probe.scene;
    extent = body_extent(probe.grid);
  }
  const int planes = int(probe_scene.planes.size());
  std::vector<ModelSpec> shared = {ModelSpec{"base"}};
  // A placebo for each count of extra parameters a candidate has (more than 3: the 3-parameter
  // placebo's gain, scaled).
  const std::vector<std::string> spare = placebo_parameters(probe_scene, o.fit);
  const int most = std::min(3, int(spare.size()));
  std::set<int> counts;
  for (const std::string& name : o.candidates) {
    const int extra = name == "friction" ? planes : name == "heterogeneous_stiffness" ? 3 : name == "nonlinear_material" ? 0 : 1;
    if (extra > 0 && most > 0) counts.insert(std::min(extra, most));
  }
  for (int k : counts) {
    ModelSpec placebo{fmt::format("placebo_{}", k)};
    for (int i = 0; i < k; ++i) {
      placebo.extra.push_back(spare[size_t(i)]);
      const double v0 = get_parameter(PhysicalParameters::from_scene(probe_scene), spare[size_t(i)]);
      placebo.ranges[spare[size_t(i)]] = {v0 - 0.2, v0 + 0.2};  // m/s (rad/s for a spin)
    }
    shared.push_back(placebo);
  }
  const size_t placebo_count = shared.size() - 1;
  std::map<std::string, std::string> skipped;
  for (const std::string& name : o.candidates)
    if (name == "friction" && planes == 0)
      skipped[name] = "the scene has no ground plane";
    else if (name == "friction" || name == "air_drag" || name == "heterogeneous_stiffness")
      shared.push_back(candidate_spec(name, planes, extent));
  std::string together;
  for (size_t i = 1; i < shared.size(); ++i) together += (i > 1 ? ", " : "") + shared[i].name;
  say(fmt::format("fitting the base model with {} as one batch of {} starts", together, shared.size() * size_t(o.starts)));
  std::vector<std::map<std::string, double>> base_starts;
  Problem shared_problem;
  std::vector<FittedModel> fitted =
      fit_together(shared, scene_path, overrides, observations, phi_max, o, d.heldin_frames, &base_starts, &shared_problem);
  d.base = std::move(fitted[0]);
  if (d.base.failed) throw SimulationError("the base model's fit failed at every start: " + d.base.failure);
  for (size_t k = 0; k < placebo_count; ++k) d.placebos.push_back(std::move(fitted[1 + k]));
  std::map<std::string, FittedModel> shared_fits;
  for (size_t i = 1 + placebo_count; i < fitted.size(); ++i) shared_fits[fitted[i].name] = std::move(fitted[i]);
  const std::map<std::string, double> base_values = values_by_name(d.base);

  say("the score test");
  std::map<std::string, double> score;
  try {
    score = score_test(d.base, scene_path, overrides, observations, phi_max, o, d.heldin_frames);
  } catch (const std::exception& e) {
    d.lines.push_back(std::string("the score test failed: ") + e.what());
  }
  std::vector<std::string> order = o.candidates;  // by score, the untestable ones last
  std::stable_sort(order.begin(), order.end(), [&](const std::string& a, const std::string& b) {
    const double sa = score.count(a) ? score.at(a) : -1, sb = score.count(b) ? score.at(b) : -1;
    return sa > sb;
  });

  for (const std::string& name : order) {
    CandidateVerdict v;
    v.name = name;
    if (score.count(name)) v.score = score.at(name);
    FittedModel m;
    m.name = name;
    if (const auto f = shared_fits.find(name); f != shared_fits.end()) {
      m = std::move(f->second);
    } else {
      ModelSpec spec = candidate_spec(name, planes, extent);
      if (name == "second_plane") {
        const PlaneProposal plane = propose_plane(d.base, d.heldin_frames);
        if (!plane.found) {
          skipped[name] = "the fitted body never went beyond the observed points by half a cell: no plane to propose";
        } else {
          const PlaneSpec first = planes > 0 ? d.base.problem.scene.planes[0] : PlaneSpec{};
          const std::string height = plane_parameter(planes, "height");
          spec.extra = {height};
          spec.extra_in_load = false;
          const double h = d.base.problem.grid.h;
          spec.ranges[height] = {plane.height - 2 * h, plane.height + 2 * h};
          spec.adjust = [plane, first](Problem& p) {
            PlaneSpec s = first;
            s.normal = plane.normal;
            s.height = plane.height;
            s.friction = 0;
            p.scene.planes.push_back(s);
          };
        }
      }
      if (!skipped.count(name)) {
        say("fitting " + name);
        try {
          m = fit_model(spec, scene_path, overrides, observations, phi_max, o, d.heldin_frames, &base_starts);
        } catch (const std::exception& e) {
          m.failed = true;
          m.failure = e.what();
        }
      }
    }
    if (skipped.count(name)) {
      m.failed = true;
      m.failure = skipped.at(name);
      v.warnings.push_back("not fitted: " + m.failure);
    } else if (m.failed) {
      v.warnings.push_back("the fit failed: " + m.failure);
    }
    if (!m.note.empty()) v.warnings.push_back(m.note);
    d.candidates.push_back(std::move(m));
    d.verdicts.push_back(v);
  }

  // Verdicts against the placebos.
  auto placebo_gain = [&](size_t extra) {
    if (extra == 0) return 0.0;
    for (const FittedModel& p : d.placebos)
      if (p.extra.size() == std::min<size_t>(extra, size_t(most))) {
        if (p.failed) return 0.0;
        const double g = held_out_gain(d.base.frame_costs, p.frame_costs, d.heldin_frames, 1, o.seed).value;
        return g * double(extra) / double(p.extra.size());
      }
    return 0.0;
  };
  std::vector<size_t> named;
  for (size_t i = 0; i < d.candidates.size(); ++i) {
    FittedModel& m = d.candidates[i];
    CandidateVerdict& v = d.verdicts[i];
    if (m.failed) continue;
    size_t extra = 0;
    for (const std::string& e : m.extra) extra += expand_parameter_names({e}, PhysicalParameters::from_scene(m.problem.scene)).size();
    const Gain g = held_out_gain(d.base.frame_costs, m.frame_costs, d.heldin_frames, o.bootstrap, o.seed + i);
    v.gain = g.value, v.gain_low = g.low, v.gain_high = g.high;
    v.placebo_gain = std::max(0.0, placebo_gain(extra));
    v.passes = v.gain >= o.min_gain && v.gain_low > v.placebo_gain + o.margin;
    if (v.passes) named.push_back(i);
    try {
      v.event_frame = event_frame(m, o.device);
    } catch (const std::exception& e) {
      v.warnings.push_back(std::string("the event's frame was not found: ") + e.what());
    }
    if (v.event_frame >= 0 && v.event_frame < d.heldin_frames) {
      const auto [rss_base, n] = residual_sum(d.base.frame_costs, m.problem, v.event_frame, d.heldin_frames);
      const double rss = residual_sum(m.frame_costs, m.problem, v.event_frame, d.heldin_frames).first;
      if (rss_base > 0 && rss > 0) {
        v.event_gain = 1 - rss / rss_base;
        v.event_aic = n * std::log(rss / rss_base) + 2.0 * double(extra);
      }
    }
  }
  std::sort(named.begin(), named.end(), [&](size_t a, size_t b) { return d.verdicts[a].gain > d.verdicts[b].gain; });
  if (!named.empty()) d.cause = d.verdicts[named[0]].name;
  for (size_t a = 0; a < named.size(); ++a)
    for (size_t b = a + 1; b < named.size(); ++b) {
      // Indistinguishable: the gain of one over the other has an interval containing 0.
      const Gain diff = held_out_gain(d.candidates[named[b]].frame_costs, d.candidates[named[a]].frame_costs,
                                      d.heldin_frames, o.bootstrap, o.seed + 99);
      if (diff.low <= 0) d.confounded.push_back({d.verdicts[named[a]].name, d.verdicts[named[b]].name});
    }

  // Identifiability at the cause's fit.
  if (!named.empty()) {
    const FittedModel& m = d.candidates[named[0]];
    try {
      identifiability_at(d, m, shared_fits.count(m.name) ? &shared_problem : nullptr, o.device, extent);
    } catch (const std::exception& e) {
      d.identifiability.failure = e.what();
    }
  }

  // What to tell the user.
  if (named.empty()) {
    size_t best = d.verdicts.size();
    for (size_t i = 0; i < d.verdicts.size(); ++i)
      if (!d.candidates[i].failed && (best == d.verdicts.size() || d.verdicts[i].gain > d.verdicts[best].gain)) best = i;
    d.lines.push_back(fmt::format("cause: none. No candidate removes {} of the held-out residual and beats its placebo "
                                  "by {} points{}",
                                  percent(o.min_gain), 100 * o.margin,
                                  best < d.verdicts.size()
                                      ? fmt::format(" (the best, {}, removes {}, interval {} .. {})", d.verdicts[best].name,
                                                    percent(d.verdicts[best].gain), percent(d.verdicts[best].gain_low),
                                                    percent(d.verdicts[best].gain_high))
                                      : ""));
  } else {
    const CandidateVerdict& v = d.verdicts[named[0]];
    const FittedModel& m = d.candidates[named[0]];
    d.lines.push_back(fmt::format("cause: {}. Modelling it removes {} of the held-out residual (90 % interval {} .. {}; "
                                  "a placebo of as many parameters: {})",
                                  v.name, percent(v.gain), percent(v.gain_low), percent(v.gain_high),
                                  percent(v.placebo_gain)));
    std::string extras;
    for (size_t i = 0; i < m.names.size(); ++i)
      if (!base_values.count(m.names[i]))
        extras += fmt::format("{}{} = {:.4g}{}", extras.empty() ? "" : ", ", m.names[i], m.values[Eigen::Index(i)],
                              parameter_unit(m.names[i]) == "1" ? "" : " " + parameter_unit(m.names[i]));
    if (!extras.empty()) d.lines.push_back("fitted: " + extras);
  }
  for (const auto& [a, b] : d.confounded)
    d.lines.push_back(fmt::format("{} or {}: indistinguishable with this data", a, b));
  for (const auto& [a, b, r] : d.indistinguishable)
    if (owner(a) == d.cause || owner(b) == d.cause)
      d.lines.push_back(fmt::format("{} and {}: correlation {:+.3f} at the fit (Gauss-Newton): the data fix a "
                                  "combination of them, not each",
                                  a, b, r));
  if (!named.empty() && !d.identifiability.failure.empty())
    d.lines.push_back("identifiability not assessed: " + d.identifiability.failure);
  if (d.confounded.empty() && d.identifiability.correlation.rows() >= 2) {
    // The cause's parameter with the largest correlation with another, when none is near +-1.
    const Eigen::MatrixXd& c = d.identifiability.correlation;
    const std::vector<std::string>& n = d.identifiability.names;
    Eigen::Index bi = -1, bj = -1;
    for (Eigen::Index i = 0; i < c.rows(); ++i)
      for (Eigen::Index j = i + 1; j < c.cols(); ++j)
        if ((owner(n[size_t(i)]) == d.cause || owner(n[size_t(j)]) == d.cause) &&
            (bi < 0 || std::abs(c(i, j)) > std::abs(c(bi, bj))))
          bi = i, bj = j;
    if (bi >= 0)
      d.lines.push_back(fmt::format("identifiability (Gauss-Newton, at the fit): nothing trades off against {} (its "
                                    "largest correlation: {} and {}, {:+.2f})",
                                    d.cause, n[size_t(bi)], n[size_t(bj)], c(bi, bj)));
  }
  std::string flat;
  for (const std::string& f : d.identifiability.flat)
    if (owner(f) == d.cause || base_values.count(f)) flat += (flat.empty() ? "" : ", ") + f;
  if (!flat.empty()) d.lines.push_back("the held-in frames do not depend on " + flat + " at the fit: not determined");
  for (size_t i = 0; i < d.candidates.size(); ++i) {
    const FittedModel& m = d.candidates[i];
    if (m.failed) continue;
    for (size_t k = 0; k < m.names.size(); ++k) {
      const auto b = base_values.find(m.names[k]);
      if (b == base_values.end() || b->second == 0) continue;
      const double after = m.values[Eigen::Index(k)], change = after / b->second - 1;
      if (std::abs(change) < 0.1) continue;
      const std::string w = fmt::format("{} moves from {:.4g} to {:.4g} {} ({:+.0f} %) once {} is modelled", m.names[k],
                                        b->second, after, parameter_unit(m.names[k]), 100 * change, m.name);
      d.verdicts[i].warnings.push_back(w);
      if (d.cause == m.name) d.lines.push_back(w);
    }
  }
  d.seconds = seconds_since(t0);
  return d;
}

nlohmann::json diagnosis_json(const Diagnosis& d) {
  auto named = [](const FittedModel& m, bool extra_only, const std::map<std::string, double>* base) {
    nlohmann::json j = nlohmann::json::object();
    for (size_t i = 0; i < m.names.size() && i < size_t(m.values.size()); ++i)
      if (!extra_only || !base->count(m.names[i])) j[m.names[i]] = m.values[Eigen::Index(i)];
    return j;
  };
  const std::map<std::string, double> base = values_by_name(d.base);
  nlohmann::json j;
  j["cause"] = d.cause;
  j["heldin_frames"] = d.heldin_frames;
  j["heldout_frames"] = d.heldout_frames;
  j["heldout_from_s"] = d.heldout_from;
  j["base"] = {{"parameters", named(d.base, false, nullptr)},
               {"heldin_cost", d.base.heldin_cost},
               {"heldout_cost", d.base.heldout_cost},
               {"seconds", d.base.seconds}};
  nlohmann::json candidates = nlohmann::json::array();
  for (size_t i = 0; i < d.candidates.size(); ++i) {
    const FittedModel& m = d.candidates[i];
    const CandidateVerdict& v = d.verdicts[i];
    nlohmann::json c;
    c["name"] = v.name;
    c["fitted"] = !m.failed;
    if (!m.failed) {
      c["heldout_before"] = d.base.heldout_cost;
      c["heldout_after"] = m.heldout_cost;
      c["heldin_after"] = m.heldin_cost;
      c["gain"] = v.gain;
      c["gain_low"] = v.gain_low;
      c["gain_high"] = v.gain_high;
      c["placebo_gain"] = v.placebo_gain;
      c["passes"] = v.passes;
      c["extra_parameters"] = named(m, true, &base);
      nlohmann::json before = nlohmann::json::object(), after = nlohmann::json::object();
      for (size_t k = 0; k < m.names.size(); ++k)
        if (base.count(m.names[k])) before[m.names[k]] = base.at(m.names[k]), after[m.names[k]] = m.values[Eigen::Index(k)];
      c["base_before"] = before;
      c["base_after"] = after;
      c["seconds"] = m.seconds;
    } else {
      c["passes"] = false;
    }
    c["score"] = std::isnan(v.score) ? nlohmann::json(nullptr) : nlohmann::json(v.score);
    auto number = [](double x) { return std::isnan(x) ? nlohmann::json(nullptr) : nlohmann::json(x); };
    c["event"] = {{"frame", v.event_frame},
                  {"time_s", v.event_frame >= 0 && !m.failed ? nlohmann::json(m.problem.frames[size_t(v.event_frame)].step *
                                                                              m.problem.scene.time.dt)
                                                             : nlohmann::json(nullptr)},
                  {"heldin_gain", number(v.event_gain)},
                  {"aic_difference", number(v.event_aic)}};
    c["warnings"] = v.warnings;
    candidates.push_back(c);
  }
  j["candidates"] = candidates;
  nlohmann::json placebos = nlohmann::json::array();
  for (const FittedModel& p : d.placebos)
    placebos.push_back({{"name", p.name},
                        {"parameters", named(p, true, &base)},
                        {"heldout_cost", p.failed ? nlohmann::json(nullptr) : nlohmann::json(p.heldout_cost)}});
  j["placebos"] = placebos;
  j["confounded"] = nlohmann::json::array();
  for (const auto& [a, b] : d.confounded) j["confounded"].push_back({a, b});
  nlohmann::json id;
  id["parameters"] = d.identifiability.names;
  id["failure"] = d.identifiability.failure;
  id["flat"] = d.identifiability.flat;
  id["correlation"] = nlohmann::json::array();
  for (Eigen::Index i = 0; i < d.identifiability.correlation.rows(); ++i) {
    std::vector<double> row;
    for (Eigen::Index k = 0; k < d.identifiability.correlation.cols(); ++k) row.push_back(d.identifiability.correlation(i, k));
    id["correlation"].push_back(row);
  }
  id["indistinguishable"] = nlohmann::json::array();
  for (const auto& [a, b, r] : d.indistinguishable) id["indistinguishable"].push_back({{"a", a}, {"b", b}, {"correlation", r}});
  j["identifiability"] = id;
  j["lines"] = d.lines;
  j["seconds"] = d.seconds;
  return j;
}

}  // namespace ssc
