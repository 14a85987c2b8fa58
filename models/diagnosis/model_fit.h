// Fitting the diagnosis's models (the base, a candidate, a placebo) on the held-in frames.
//
// A model differs from the base by a ModelSpec: scene overrides, parameters fitted beside the
// base's (with the range their starts are drawn from), values it holds fixed, and a change of
// the loaded problem. Every model gets the base fit's starts for the base parameters and the
// same iterations, and every fitted parameter is bounded by its plausible range
// (models/sim/extensions.h). Models whose extensions have an "off" value share one graph and
// run as one batch (fit_together); the others run as a batch of their own (fit_model), where
// several specs may still share one scene (several proposed planes) when they differ only in
// the values they hold fixed.
#pragma once
#include <functional>
#include <map>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "models/diagnosis/fitted_model.h"

namespace ssc {

// What every fit of one diagnosis shares.
struct DiagnosisContext {
  std::string scene_path;
  std::vector<std::string> overrides;
  std::string observations;
  double phi_max = 0;
  DiagnosisOptions options;
  int heldin = 0;      // held-in frames
  double extent = 1;   // the rest body's largest extent, m
  // Told after every optimiser round of a fit ("base, placebo_3, friction: round 4 of 30, ...");
  // called from the fits' threads; may be empty.
  std::function<void(const std::string& what)> round_progress;
};

struct ModelSpec {
  explicit ModelSpec(std::string model) : name(std::move(model)) {}
  std::string name;
  std::vector<std::string> overrides, extra;
  std::map<std::string, std::pair<double, double>> ranges;  // start ranges per extra parameter
  std::map<std::string, double> magnitudes;                 // typical magnitudes of free extra parameters
  std::map<std::string, double> fixed;  // values this model's starts hold, of parameters it does not fit
  bool log_range = false;               // draw log-uniformly (positive parameters)
  std::function<void(Problem&)> adjust;
  // The scene loads with the extra parameters named (which puts friction's and drag's ops in
  // the model), unless adjust makes what they name (a new plane).
  bool extra_in_load = true;
  std::string note;  // what was proposed, for the report (a proposed plane or interface)
};

// Whether an optimiser's stop reason is a convergence test's (not the iteration limit, not a failure).
bool stopped_converged(const std::string& stop_reason);
// The scene's parameters with names set to v; a measurement's parameter is not the
// simulation's (its correction is in the problem's frames) and is left out.
PhysicalParameters with_values(const Scene& scene, const std::vector<std::string>& names, const Eigen::VectorXd& v);
std::map<std::string, double> values_by_name(const FittedModel& m);
// "52 kPa"-style: the value with its parameter's (or measurement's) unit.
std::string with_unit(const std::string& name, double value);
// The base parameters m's fit moves by 10 % or more from base's: (name, base's value, m's).
std::vector<std::tuple<std::string, double, double>> moved_base(const FittedModel& base, const FittedModel& m);
// Every frame's J_SSC term at p.
std::vector<double> per_frame_costs(const Problem& problem, const PhysicalParameters& p, const std::string& device);
Problem held_in(const Problem& p, int frames);

// The fits of specs that share one scene (the scene with every spec's overrides and
// adjustments) as one batch; each start moves only its own model's parameters, holding the
// others at their extension's off value or the spec's fixed value. With base_starts empty the
// base parameters' starts are drawn as `reconstruct` draws them and stored there; otherwise
// they are taken from there. shared_problem (optional) receives the shared scene's problem.
// competing: only the best of the specs' models will be kept (proposals fitted as one batch;
// ReconstructionOptions::competing_models).
std::vector<FittedModel> fit_together(const std::vector<ModelSpec>& specs, const DiagnosisContext& c,
                                      std::vector<std::map<std::string, double>>& base_starts,
                                      Problem* shared_problem = nullptr, bool competing = false);

}  // namespace ssc
