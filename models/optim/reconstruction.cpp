// Batched multi-start reconstruction (see reconstruction.h).
#include "models/optim/reconstruction.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <memory>
#include <numeric>
#include <random>

#include "runtime/errors.h"
#include "models/optim/batch_evaluation.h"
#include "models/optim/levenberg_marquardt.h"
#include "models/optim/surface_residuals.h"
#include "models/sim/parameters.h"

namespace ssc {
namespace {

PhysicalParameters with_values(PhysicalParameters p, const std::vector<std::string>& names, const Eigen::VectorXd& x) {
  for (size_t i = 0; i < names.size(); ++i) set_parameter(p, names[i], x[i]);
  return p;
}

// The cost's gradient by the fitted names at the physical point x.
Eigen::VectorXd gradient_by_name(const ParameterGradient& g, const PhysicalParameters& base,
                                 const std::vector<std::string>& names, const Eigen::VectorXd& x) {
  const PhysicalParameters at = with_values(base, names, x);
  Eigen::VectorXd out(Eigen::Index(names.size()));
  for (size_t i = 0; i < names.size(); ++i) out[Eigen::Index(i)] = parameter_gradient(g, at, names[i]);
  return out;
}

// The coordinates one start's optimiser moves in: the parameters it fits (all, unless
// ReconstructionOptions::start_free says otherwise), the rest held at their initial values.
class StartSpace {
 public:
  StartSpace(const std::vector<ParameterAxis>& axes, const Eigen::VectorXd& initial, std::vector<int> free)
      : free_(std::move(free)), space_(select(axes, free_)), held_(initial) {}
  const ParameterSpace& space() const { return space_; }
  Eigen::VectorXd to_internal(const Eigen::VectorXd& x) const { return space_.to_internal(take(x)); }
  Eigen::VectorXd to_physical(const Eigen::VectorXd& z) const {
    Eigen::VectorXd x = held_;
    const Eigen::VectorXd moved = space_.to_physical(z);
    for (size_t i = 0; i < free_.size(); ++i) x[free_[i]] = moved[Eigen::Index(i)];
    return x;
  }
  Eigen::VectorXd gradient_to_internal(const Eigen::VectorXd& z, const Eigen::VectorXd& dJ_dx) const {
    return space_.gradient_to_internal(z, take(dJ_dx));
  }

 private:
  static std::vector<ParameterAxis> select(const std::vector<ParameterAxis>& axes, const std::vector<int>& free) {
    std::vector<ParameterAxis> out;
    for (int i : free) out.push_back(axes.at(size_t(i)));
    return out;
  }
  Eigen::VectorXd take(const Eigen::VectorXd& x) const {
    Eigen::VectorXd out(Eigen::Index(free_.size()));
    for (size_t i = 0; i < free_.size(); ++i) out[Eigen::Index(i)] = x[free_[i]];
    return out;
  }
  std::vector<int> free_;
  ParameterSpace space_;
  Eigen::VectorXd held_;
};

}  // namespace

std::map<std::string, std::pair<double, double>> scene_start_ranges(const Scene& scene) {
  std::map<std::string, std::pair<double, double>> ranges;
  for (size_t k = 0; k < scene.planes.size(); ++k)
    if (scene.planes[k].height_range_key)
      ranges[k == 0 ? "ground.height" : fmt::format("ground.planes[{}].height", k)] = scene.planes[k].height_range;
  return ranges;
}

namespace {

// Whether explicit bounds changed the axis (with_bounds leaves it as it is for an open end).
bool narrowed(const ParameterAxis& before, const ParameterAxis& after) {
  return after.kind != before.kind || after.lower != before.lower || after.upper != before.upper;
}

// A bounded axis's range less 2 % at each end (of the log range for a logarithmic axis).
std::pair<double, double> inner_range(const ParameterAxis& a) {
  if (!a.logarithmic) {
    const double margin = 0.02 * (a.upper - a.lower);
    return {a.lower + margin, a.upper - margin};
  }
  const double margin = std::pow(a.upper / a.lower, 0.02);
  return {a.lower * margin, a.upper / margin};
}

}  // namespace

std::vector<Eigen::VectorXd> sample_starts(const ParameterSpace& space, const Eigen::VectorXd& nominal,
                                           const ReconstructionOptions& o) {
  if (!o.initial_values.empty()) return o.initial_values;
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto draw = [&](const ParameterAxis& a, int i, double u) {
    if (const auto r = o.start_ranges.find(a.name); r != o.start_ranges.end())
      return r->second.first + u * (r->second.second - r->second.first);
    switch (a.kind) {
      case ParameterAxis::Kind::Positive:
        return nominal[i] * std::exp(std::log(o.low) + u * (std::log(o.high) - std::log(o.low)));
      case ParameterAxis::Kind::Bounded: {
        const double margin = 0.02 * (a.upper - a.lower);
        return a.lower + margin + u * (a.upper - a.lower - 2 * margin);
      }
      case ParameterAxis::Kind::Free:
        break;
    }
    return nominal[i] + (2 * u - 1) * o.spread * std::max(std::abs(nominal[i]), 1.0);
  };
  std::vector<Eigen::VectorXd> starts;
  for (int s = 0; s < o.starts; ++s) {
    Eigen::VectorXd x(space.size());
    for (int i = 0; i < space.size(); ++i) {
      const ParameterAxis& a = space.axes()[i];
      const double u = unit(rng);
      const auto b = o.bounds.find(a.name);
      if (b == o.bounds.end()) {
        x[i] = draw(a, i, u);
        continue;
      }
      // Within the bounds: the part of the usual range that lies inside them, else all of them.
      const ParameterAxis bounded = with_bounds(a, b->second.first, b->second.second);
      const auto [inner_lo, inner_hi] = inner_range(bounded);
      double lo = std::min(draw(a, i, 0), draw(a, i, 1)), hi = std::max(draw(a, i, 0), draw(a, i, 1));
      if (!narrowed(a, bounded) || (lo >= inner_lo && hi <= inner_hi)) {
        x[i] = draw(a, i, u);
        continue;
      }
      lo = std::max(lo, inner_lo), hi = std::min(hi, inner_hi);
      if (!(lo < hi)) lo = inner_lo, hi = inner_hi;
      x[i] = bounded.logarithmic ? std::exp(std::log(lo) + u * (std::log(hi) - std::log(lo))) : lo + u * (hi - lo);
    }
    starts.push_back(x);
  }
  return starts;
}

void check_optimizer_name(const std::string& name) {
  if (name == "lm") return;
  for (const std::string& n : optimizer_names())
    if (n == name) return;
  throw InputError(fmt::format("unknown optimizer '{}'; choose one of rprop, rprop-paper, gd, lbfgs, lm", name));
}

namespace {

// The start's record once its optimiser has stopped.
void finish_start(StartRecord& rec, const StartSpace& space, int iterations, const std::string& reason,
                  const Eigen::VectorXd& best_point, double best_cost) {
  rec.iterations = iterations;
  rec.stop_reason = reason;
  rec.converged = rec.stop_reason.rfind("converged", 0) == 0;
  if (rec.failed || best_point.size() == 0) return;
  rec.final = space.to_physical(best_point);
  rec.final_cost = best_cost;
}

// A convergence claim of `lm` on a rough cost: the contact set and the line search's step choice
// make the cost jump on the scale of the forward-difference step, the Jacobian then misses a
// fall that the exact gradient sees, and the damping shrinks the step to nothing (the CalculiX
// friction cube, docs/diagnosis.md). Each start that claims convergence is probed kStallProbe
// (in the optimiser's coordinates) down its exact (adjoint) gradient; a cost lower there by
// more than kStallDrop of its own is a stall, not a minimum: the start goes on from the probe
// with the iterations it has left (a fresh optimiser there: its damping and secant term are of
// the point it left), at most kStallRestarts times; a stall after that, or with no iteration
// left, ends the start at the probe (its `final`) with a stop reason that says so. Returns the
// stalled starts.
constexpr double kStallProbe = 0.05;
constexpr double kStallDrop = 0.01;
constexpr int kStallRestarts = 2;

std::vector<int> check_convergence_claims(const PhysicalParameters& base, const SurfaceConstraintCost& cost,
                                          BatchSimulations& sims, const std::vector<StartSpace>& spaces,
                                          ReconstructionResult& result, const std::vector<LevenbergMarquardt>& lm,
                                          const std::vector<char>& ran, std::vector<std::string>& reasons,
                                          std::vector<Eigen::VectorXd>& points, std::vector<double>& costs) {
  std::vector<int> claimed, stalled;
  std::vector<Eigen::VectorXd> at;
  for (int s = 0; s < int(lm.size()); ++s)
    if (ran[size_t(s)] && lm[s].converged() && lm[s].best_point().size() > 0 && !result.starts[s].cost_history.empty()) {
      claimed.push_back(s);
      at.push_back(spaces[s].to_physical(lm[s].best_point()));
    }
  if (claimed.empty()) return stalled;
  const std::vector<PointEvaluation> e = evaluate_batch(sims, cost, base, result.names, at, true, nullptr, {});
  result.evaluations += int(at.size());
  ++result.batches;
  std::vector<int> probed;
  std::vector<Eigen::VectorXd> probes, probe_z;
  for (size_t k = 0; k < claimed.size(); ++k) {
    if (!e[k].ok) continue;
    const int s = claimed[k];
    const Eigen::VectorXd gz = spaces[s].gradient_to_internal(
        lm[s].best_point(), gradient_by_name(e[k].value.gradient, base, result.names, at[k]));
    if (!(gz.norm() > 0) || !gz.allFinite()) continue;
    const Eigen::VectorXd z = lm[s].best_point() - (kStallProbe / gz.norm()) * gz;
    probed.push_back(s);
    probe_z.push_back(z);
    probes.push_back(spaces[s].to_physical(z));
  }
  if (probes.empty()) return stalled;
  const std::vector<PointEvaluation> p = evaluate_batch(sims, cost, base, result.names, probes, false, nullptr, {});
  result.evaluations += int(probes.size());
  ++result.batches;
  for (size_t k = 0; k < probed.size(); ++k) {
    const int s = probed[k];
    const double before = lm[s].best_cost();
    if (!p[k].ok || !(p[k].value.cost < (1 - kStallDrop) * before)) continue;
    stalled.push_back(s);
    reasons[size_t(s)] = fmt::format(
        "stalled: after '{}', the cost is {:.1f} % lower a step of {:g} down the exact gradient: a rough cost "
        "whose fall the forward differences missed",
        lm[s].stop_reason(), 100 * (1 - p[k].value.cost / before), kStallProbe);
    points[size_t(s)] = probe_z[k];
    costs[size_t(s)] = p[k].value.cost;
    StartRecord& rec = result.starts[size_t(s)];
    rec.frames = p[k].value.frames;
    rec.matched_points = rec.observed_points = 0;
    for (const FrameCost& f : rec.frames) rec.matched_points += f.matched, rec.observed_points += f.points;
  }
  return stalled;
}

// ReconstructionOptions::lm_lookahead, where -1 takes SSC_LM_LOOKAHEAD=N if set (docs/cli.md).
int lm_lookahead(const ReconstructionOptions& o) {
  if (o.lm_lookahead >= 0) return o.lm_lookahead;
  const char* env = std::getenv("SSC_LM_LOOKAHEAD");
  return env ? std::max(0, std::atoi(env)) : 0;
}

// Levenberg-Marquardt starts (levenberg_marquardt.h): each round, every running start's trial
// point and its probes, n + 1 points per start, as one batch of forward simulations whose
// residual vectors are taken at the observed frames; until every start is done. Where the batch
// is narrower than the pass's first round (starts have stopped), a start also brings the trials
// of up to `lookahead` more rejections, with their probes, those whose last trial was rejected
// first: on the GPU a round costs about the same however few points it holds, and the steps
// are the same.
void run_rounds(std::vector<LevenbergMarquardt>& lm, const SurfaceResiduals& residuals, const ReconstructionOptions& o,
                const PhysicalParameters& base, const SurfaceConstraintCost& cost, BatchSimulations& sims,
                const std::vector<StartSpace>& spaces, ReconstructionResult& result,
                const ReconstructionProgress& progress, int& round) {
  const int S = int(spaces.size());
  const int lookahead = lm_lookahead(o);
  size_t width = 0;  // the pass's first round
  std::vector<char> rejected(size_t(S), 0);
  for (;; ++round) {
    std::vector<int> active;
    for (int s = 0; s < S; ++s)
      if (!lm[s].done()) active.push_back(s);
    if (active.empty()) return;
    // Per active start, its trials (internal coordinates): the one asked, then the lookahead's.
    std::vector<std::vector<Eigen::VectorXd>> trials(active.size());
    size_t points_asked = 0;
    for (size_t k = 0; k < active.size(); ++k) {
      trials[k].push_back(lm[active[k]].trial());
      points_asked += size_t(spaces[active[k]].space().size()) + 1;
    }
    if (width == 0) width = points_asked;
    for (const bool after_rejection : {true, false})  // where the batch has room: rejected starts first
      for (size_t k = 0; k < active.size() && lookahead > 0; ++k) {
        const int s = active[k];
        if (bool(rejected[size_t(s)]) != after_rejection) continue;
        const size_t per = size_t(spaces[s].space().size()) + 1;
        for (const Eigen::VectorXd& z : lm[s].lookahead(lookahead)) {
          if (points_asked + per > width) break;
          trials[k].push_back(z);
          points_asked += per;
        }
      }
    std::vector<Eigen::VectorXd> points;
    std::vector<std::vector<size_t>> first(active.size());  // per start, per trial: its index in points
    for (size_t k = 0; k < active.size(); ++k) {
      const int s = active[k];
      for (const Eigen::VectorXd& trial : trials[k]) {
        first[k].push_back(points.size());
        for (const Eigen::VectorXd& z : lm[s].points_for(trial)) points.push_back(spaces[s].to_physical(z));
      }
    }
    std::vector<PointEvaluation> e =
        evaluate_batch(sims, cost, base, result.names, points, false, &residuals, o.evaluation_progress);
    result.evaluations += int(points.size());
    ++result.batches;
    for (size_t k = 0; k < active.size(); ++k) {
      const int s = active[k];
      ++result.starts[s].rounds;
      const size_t n = size_t(spaces[s].space().size()) + 1;
      std::vector<std::vector<ResidualVector>> groups(trials[k].size());
      std::vector<std::string> failures(trials[k].size());
      for (size_t t = 0; t < trials[k].size(); ++t)
        for (size_t i = first[k][t]; i < first[k][t] + n; ++i) {
          if (!e[i].ok && failures[t].empty()) failures[t] = e[i].failure;
          groups[t].push_back(std::move(e[i].residuals));
        }
      const int taken = lm[s].tell_in_order(groups, failures, trials[k]);
      rejected[size_t(s)] = taken < 0;
      if (taken < 0) continue;
      const size_t a = first[k][size_t(taken)];
      StartRecord& rec = result.starts[s];
      rec.cost_history.push_back(lm[s].best_cost());
      rec.parameter_history.push_back(points[a]);
      rec.frames = e[a].value.frames;
      rec.matched_points = rec.observed_points = 0;
      for (const FrameCost& f : rec.frames) rec.matched_points += f.matched, rec.observed_points += f.points;
      rec.final_gradient_norm = lm[s].gradient_norm();
      if (rec.initial_gradient_norm < 0) rec.initial_gradient_norm = rec.final_gradient_norm;
    }
    if (progress) {
      int best = -1;
      for (int s = 0; s < S; ++s)
        if (!result.starts[s].cost_history.empty() && (best < 0 || lm[s].best_cost() < lm[best].best_cost())) best = s;
      if (best >= 0) progress(round + 1, int(active.size()), lm[best].best_cost(), spaces[best].to_physical(lm[best].best_point()));
    }
  }
}

// The `lm` starts run to their stops; each convergence claim is checked, and a start that
// stalled goes on from the probe (check_convergence_claims).
void fit_least_squares(const Problem& problem, const ReconstructionOptions& o, const PhysicalParameters& base,
                       const SurfaceConstraintCost& cost, BatchSimulations& sims, const std::vector<StartSpace>& spaces,
                       ReconstructionResult& result, const ReconstructionProgress& progress) {
  const SurfaceResiduals residuals(cost, problem.frames);
  const int S = int(spaces.size());
  const size_t starts = spaces.size();
  std::vector<LevenbergMarquardt> lm;
  std::vector<std::vector<char>> bounded(starts);
  for (int s = 0; s < S; ++s) {
    for (const ParameterAxis& a : spaces[s].space().axes()) bounded[size_t(s)].push_back(a.kind == ParameterAxis::Kind::Bounded);
    lm.emplace_back(spaces[s].to_internal(result.starts[s].initial), o.optimizer_options, o.fd_step, bounded[size_t(s)]);
  }
  std::vector<int> spent(starts, 0), restarts(starts, 0);  // iterations of the passes before; restarts
  std::vector<char> ran(starts, 1);                        // the starts that ran in this pass
  std::vector<std::string> reasons(starts);
  std::vector<Eigen::VectorXd> finals(starts);
  std::vector<double> final_costs(starts);
  for (int round = 0;;) {  // passes: all starts, then those that went on from a stall
    run_rounds(lm, residuals, o, base, cost, sims, spaces, result, progress, round);
    for (int s = 0; s < S; ++s)
      if (ran[size_t(s)]) {
        reasons[size_t(s)] = lm[s].stop_reason();
        finals[size_t(s)] = lm[s].best_point();
        final_costs[size_t(s)] = lm[s].best_cost();
      }
    const std::vector<int> stalled =
        check_convergence_claims(base, cost, sims, spaces, result, lm, ran, reasons, finals, final_costs);
    std::fill(ran.begin(), ran.end(), 0);
    // A stalled start of a model out of contention stays stalled: only the best model is kept.
    std::vector<double> reached(starts, std::numeric_limits<double>::infinity());
    for (size_t s = 0; s < starts; ++s)
      if (!result.starts[s].cost_history.empty()) reached[s] = final_costs[s];
    const std::vector<char> contending = o.competing_models.size() == starts
                                             ? in_contention(o.competing_models, reached)
                                             : std::vector<char>(starts, 1);
    for (int s : stalled) {
      const int left = o.optimizer_options.max_iterations - spent[size_t(s)] - lm[s].iterations();
      if (restarts[size_t(s)] >= kStallRestarts || left <= 0 || !contending[size_t(s)]) continue;
      spent[size_t(s)] += lm[s].iterations();
      ++restarts[size_t(s)];
      OptimizerOptions rest = o.optimizer_options;
      rest.max_iterations = left;
      lm[s] = LevenbergMarquardt(finals[size_t(s)], rest, o.fd_step, bounded[size_t(s)]);
      ran[size_t(s)] = 1;
    }
    if (std::find(ran.begin(), ran.end(), 1) == ran.end()) break;
  }
  for (int s = 0; s < S; ++s) {
    StartRecord& rec = result.starts[s];
    rec.failed = rec.cost_history.empty();  // its start point could not be evaluated
    if (rec.failed) rec.failure = lm[s].failure().empty() ? lm[s].stop_reason() : lm[s].failure();
    rec.restarts = restarts[size_t(s)];
    finish_start(rec, spaces[s], spent[size_t(s)] + lm[s].iterations(), reasons[size_t(s)], finals[size_t(s)],
                 final_costs[size_t(s)]);
  }
}

}  // namespace

std::vector<char> in_contention(const std::vector<int>& model, const std::vector<double>& cost) {
  std::map<int, double> best;  // per model
  for (size_t s = 0; s < model.size() && s < cost.size(); ++s)
    if (std::isfinite(cost[s]) && (!best.count(model[s]) || cost[s] < best[model[s]])) best[model[s]] = cost[s];
  double lowest = std::numeric_limits<double>::infinity();
  for (const auto& [m, c] : best) lowest = std::min(lowest, c);
  std::vector<char> out(model.size(), 0);
  for (size_t s = 0; s < model.size(); ++s)
    out[s] = best.count(model[s]) && best[model[s]] <= (1 + kCompetingMargin) * lowest;
  return out;
}

ReconstructionResult reconstruct(const Problem& problem, const ReconstructionOptions& o,
                                 const ReconstructionProgress& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  check_optimizer_name(o.optimizer);
  if (o.optimizer == "lm" && o.finite_differences)
    throw InputError("--gradient fd: the lm optimizer takes forward differences of the residuals itself; leave --gradient out");
  const PhysicalParameters base = PhysicalParameters::from_scene(problem.scene);
  ReconstructionResult result;
  result.names = expand_parameter_names(o.fit, base);
  if (result.names.empty()) throw InputError("--fit: name at least one parameter to fit");
  std::vector<ParameterAxis> axes;
  std::vector<bool> bounded(result.names.size(), false);  // by explicit bounds
  result.nominal.resize(int(result.names.size()));
  for (size_t i = 0; i < result.names.size(); ++i) {
    result.nominal[i] = get_parameter(base, result.names[i]);
    axes.push_back(default_axis(result.names[i], result.nominal[i]));
    if (const auto m = o.typical_magnitudes.find(result.names[i]);
        m != o.typical_magnitudes.end() && axes.back().kind == ParameterAxis::Kind::Free)
      axes.back().scale = std::max(std::abs(result.nominal[i]), m->second);
    if (const auto b = o.bounds.find(result.names[i]); b != o.bounds.end())
      bounded[i] = narrowed(axes.back(), with_bounds(axes.back(), b->second.first, b->second.second));
    if (axes.back().kind == ParameterAxis::Kind::Positive && !bounded[i] && !(result.nominal[i] > 0))
      throw InputError(fmt::format("{}: --fit {}: its value in the scene is {:g}; the starts of a positive parameter are "
                                   "drawn from 0.1 to 10 times it, so give the scene a nominal value above 0 (e.g. "
                                   "--set {}=VALUE)",
                                   problem.scene.file, result.names[i], result.nominal[i], result.names[i]));
    result.units.push_back(parameter_unit(result.names[i]));
  }
  ReconstructionOptions sampling = o;  // the scene's plane height ranges, unless given
  for (const auto& [name, range] : scene_start_ranges(problem.scene)) sampling.start_ranges.emplace(name, range);
  std::vector<Eigen::VectorXd> initial = sample_starts(ParameterSpace(axes), result.nominal, sampling);
  for (size_t i = 0; i < axes.size(); ++i)
    if (bounded[i]) axes[i] = with_bounds(axes[i], o.bounds.at(axes[i].name).first, o.bounds.at(axes[i].name).second);
  const ParameterSpace space(axes);
  const SurfaceConstraintCost cost(problem.grid, problem.phi_max);
  BatchSimulations sims(problem, o.device);

  const int S = int(initial.size());
  if (!o.start_free.empty() && o.start_free.size() != initial.size())
    throw InputError("reconstruct: start_free needs one entry per start");
  std::vector<StartSpace> spaces;
  std::vector<std::unique_ptr<Optimizer>> opt;
  result.starts.resize(S);
  for (int s = 0; s < S; ++s) {
    std::vector<int> free;
    if (o.start_free.empty())
      for (int i = 0; i < space.size(); ++i) free.push_back(i);
    else
      free = o.start_free[size_t(s)];
    for (int i : free)
      if (i < 0 || i >= space.size()) throw InputError("reconstruct: a start_free index is out of range");
    for (int i : free)  // a start on or beyond an explicit bound starts 2 % inside it
      if (const ParameterAxis& a = axes[size_t(i)]; bounded[size_t(i)]) {
        const auto [lo, hi] = inner_range(a);
        if (initial[s][i] <= a.lower) initial[s][i] = lo;
        if (initial[s][i] >= a.upper) initial[s][i] = hi;
      }
    spaces.emplace_back(space.axes(), initial[s], free);
    result.starts[s].initial = initial[s];
    if (o.optimizer == "lm")
      spaces.back().to_internal(initial[s]);  // checks the start values
    else
      opt.push_back(make_optimizer(o.optimizer, spaces[s].to_internal(initial[s]), o.optimizer_options));
  }
  if (o.optimizer == "lm") {
    fit_least_squares(problem, o, base, cost, sims, spaces, result, progress);
  } else {
    for (int round = 0;; ++round) {
      std::vector<int> active;
      for (int s = 0; s < S; ++s)
        if (!opt[s]->done() && !result.starts[s].failed) active.push_back(s);
      if (active.empty()) break;
      std::vector<Eigen::VectorXd> points;
      for (int s : active) points.push_back(spaces[s].to_physical(opt[s]->ask()));
      const std::vector<PointEvaluation> e =
          evaluate_batch(sims, cost, base, result.names, points, !o.finite_differences, nullptr, o.evaluation_progress);
      result.evaluations += int(active.size());
      ++result.batches;
      for (int s : active) ++result.starts[s].rounds;
      // The comparison the paper makes: central differences in the optimiser's coordinates
      // instead of the adjoint, all 2 x parameters x starts probes as one batch.
      std::vector<Eigen::VectorXd> fd_gradient(active.size());
      std::vector<std::string> fd_failure(active.size());
      if (o.finite_differences) {
        std::vector<Eigen::VectorXd> probes;
        for (int s : active)
          for (int i = 0; i < spaces[s].space().size(); ++i)
            for (double sign : {1.0, -1.0}) {
              Eigen::VectorXd z = opt[s]->ask();
              z[i] += sign * o.fd_step;
              probes.push_back(spaces[s].to_physical(z));
            }
        const std::vector<PointEvaluation> pe = evaluate_batch(sims, cost, base, result.names, probes, false);
        result.evaluations += int(probes.size());
        ++result.batches;
        size_t a = 0;
        for (size_t k = 0; k < active.size(); ++k) {
          const int n = spaces[active[k]].space().size();
          fd_gradient[k].resize(n);
          for (int i = 0; i < n; ++i, a += 2) {
            fd_gradient[k][i] = (pe[a].value.cost - pe[a + 1].value.cost) / (2 * o.fd_step);
            if (!pe[a].ok || !pe[a + 1].ok)
              fd_failure[k] = "a finite-difference probe failed: " + pe[pe[a].ok ? a + 1 : a].failure;
          }
        }
      }
      for (size_t k = 0; k < active.size(); ++k) {
        StartRecord& rec = result.starts[active[k]];
        if (!e[k].ok || !fd_failure[k].empty()) {
          rec.failed = true;
          rec.failure = e[k].ok ? fd_failure[k] : e[k].failure;
          continue;
        }
        const CostGradient& value = e[k].value;
        const Eigen::VectorXd g = gradient_by_name(value.gradient, base, result.names, points[k]);
        const int before = opt[active[k]]->iterations();
        const Eigen::VectorXd internal_gradient =
            o.finite_differences ? fd_gradient[k] : spaces[active[k]].gradient_to_internal(opt[active[k]]->ask(), g);
        if (rec.initial_gradient_norm < 0) rec.initial_gradient_norm = internal_gradient.norm();
        if (value.cost < opt[active[k]]->best_cost()) {
          rec.frames = value.frames;
          rec.matched_points = rec.observed_points = 0;
          for (const FrameCost& f : rec.frames) rec.matched_points += f.matched, rec.observed_points += f.points;
          rec.final_gradient_norm = internal_gradient.norm();
        }
        opt[active[k]]->tell(value.cost, internal_gradient);
        if (opt[active[k]]->iterations() != before || rec.cost_history.empty()) {
          rec.cost_history.push_back(value.cost);
          rec.parameter_history.push_back(points[k]);
        }
      }
      if (progress) {
        int best = -1;
        for (int s = 0; s < S; ++s)
          if (!result.starts[s].failed && (best < 0 || opt[s]->best_cost() < opt[best]->best_cost())) best = s;
        if (best >= 0) progress(round + 1, int(active.size()), opt[best]->best_cost(), spaces[best].to_physical(opt[best]->best_point()));
      }
    }
    for (int s = 0; s < S; ++s)
      finish_start(result.starts[s], spaces[s], opt[s]->iterations(),
                   result.starts[s].failed ? "failed: simulation" : opt[s]->stop_reason(), opt[s]->best_point(),
                   opt[s]->best_cost());
  }
  for (int s = 0; s < S; ++s) {
    const StartRecord& rec = result.starts[s];
    if (rec.final.size() == 0) continue;
    if (result.best < 0 || rec.final_cost < result.starts[result.best].final_cost) result.best = s;
  }
  result.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace ssc
