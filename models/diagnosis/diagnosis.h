// `ssc diagnose`: which effect is the fitted model missing?
//
// The observed frames are split in time: the first part is held in (fitted), the rest held
// out (leave-future-out). The base model (the scene, the --fit parameters) is fitted on the
// held-in frames; so is each candidate extension of the extension table
// (models/sim/extensions.h: the base parameters plus the extension's own; the same starts for
// the base parameters, the same iterations), and a placebo of the same number of extra
// parameters that stand for no missing effect. Every fitted parameter stays within its
// plausible range. The steps, each in its own file:
//   model_fit.h        the fits, as few batches as the models' graphs allow
//   candidates.h       the candidates' and placebos' models, and the proposals from the data
//                      (planes where the fitted body goes and the observations do not; a
//                      material interface across the fitted stiffness gradient)
//   measurement_fit.h  the measurement candidates: cameras.json's focal lengths, depth unit
//                      or clock corrected against the base fit's motion, then refitted
//   score_test.h       a ranking of the candidates with an "off" value from one backward pass
//   held_out.h         the gain on the held-out frames with a bootstrap interval; the event
//   identifiability.h  which parameters trade one for the other at the cause's fit
//   parameter_slices.h the span of each of the cause's parameters that fits as well, and
//                      which of them the data fix only from one side
// A candidate is named when its held-out gain is at least `min_gain`, its interval's lower end
// beats by `margin` both its placebo's gain and the discretization controls' (the base model
// on half the cell size and on half the time step: what the model's own discretization
// explains), and its fit stays inside every plausible range (a fit
// at a range's end needs a value no physical object has: reported, not named); a switch of the
// model with no parameter of its own can instead clear the same bars on the held-in frames,
// where the held-out ones do not speak against it (naming.h). A measurement
// candidate stands for nothing the discretization could: instead of the controls' gain, its
// correction laid onto the finest control's fit must gain as much over that fit. The cause is
// a named measurement candidate if there is one (a physical candidate that passed beside it
// was fitted to uncorrected frames: reported as unjudged), else the named candidate with the
// largest gain, or "none". Two named candidates whose gains differ
// by less than their difference's interval are reported as confounded, and of such a pair
// with the first the one with fewer degrees of freedom is the cause. A candidate that fits
// the held-in and the held-out frames as well as the base (both gains' intervals contain 0)
// while it moves a base parameter is reported as undecided: these data cannot tell the two
// models apart, and the base parameter depends on which is right. A physical cause is refitted
// on the grid control's finer grid from its fit; a parameter that moves by 10 % or more there
// depends on the grid, and the user is told to refit on the finer grid.
#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <tuple>
#include <vector>

#include "models/diagnosis/fitted_model.h"
#include "models/diagnosis/identifiability.h"
#include "models/diagnosis/naming.h"
#include "models/diagnosis/parameter_slices.h"
#include "models/sim/extensions.h"
#include "models/sim/problem.h"

namespace ssc {

struct Diagnosis {
  int heldin_frames = 0, heldout_frames = 0;
  double heldout_from = 0;  // time of the first held-out frame, s
  FittedModel base;
  std::vector<FittedModel> candidates, placebos;  // a placebo per count of extra parameters (1..3) a candidate has
  std::vector<CandidateVerdict> verdicts;         // one per candidate, in the order fitted
  // The discretization controls (the base on half the cell size, on half the time step), in
  // the order of discretization_controls(): failed with the reason where not run.
  struct Control {
    FittedModel fit;
    double gain = 0, gain_low = 0, gain_high = 0;
  };
  std::vector<Control> controls;
  // The cause refitted on each control's discretization (half the cell size, half the time
  // step), from its fit: the controls refit the base model only, and a cause's values can
  // depend on the discretization where the base's do not. Run where the cause is a physical
  // extension, for each control that ran, in the order of discretization_controls().
  std::vector<DiscretizationCheck> cause_on_controls;
  std::string cause = "none";
  // Physical candidates that passed beside a measurement cause: fitted to the frames as
  // recorded, they are judged once the recording is corrected.
  std::vector<std::string> unjudged;
  std::vector<std::pair<std::string, std::string>> confounded;
  // Where the cause is a simpler candidate the data cannot tell from the one with the largest
  // gain: the line that says so (empty otherwise).
  std::string simpler_than;
  ParameterCorrelation identifiability;  // at the cause's fit (empty names: not assessed)
  // Pairs of parameters whose correlation there is at least 0.95 in size, with it.
  std::vector<std::tuple<std::string, std::string, double>> indistinguishable;
  // Candidates the data cannot tell from the base model, with the base parameters that differ
  // between the two by more than 10 %: (candidate, "youngs_modulus 8.1 kPa with the base model,
  // 5.2 kPa with nonlinear_material").
  std::vector<std::pair<std::string, std::string>> undecided;
  // The held-in cost along each of the cause's parameters (the base's included) out to its
  // plausible range's ends (parameter_slices.h): a span open at one end means the data fix
  // only a bound.
  std::vector<ParameterSlice> slices;
  std::vector<std::string> lines;  // what to tell the user
  double seconds = 0;
};

using DiagnosisProgress = std::function<void(const std::string& what)>;

// problem: the scene and observations as loaded for the base fit (load_problem with
// options.fit); scene_path and overrides: to reload the scene with each extension's keys.
Diagnosis diagnose(const std::string& scene_path, const std::vector<std::string>& overrides,
                   const std::string& observations, double phi_max, const DiagnosisOptions& options,
                   const DiagnosisProgress& progress = {});

nlohmann::json diagnosis_json(const Diagnosis& d);

// The candidate of that name; nullptr where there is none (a confounded pair from the
// identifiability check can hold a base parameter such as mass_damping).
const FittedModel* candidate_named(const Diagnosis& d, const std::string& name);

}  // namespace ssc
