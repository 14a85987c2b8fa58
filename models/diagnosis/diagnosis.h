// `ssc diagnose`: which effect is the fitted model missing?
//
// The observed frames are split in time: the first part is held in (fitted), the rest held
// out (leave-future-out). The base model (the scene, the --fit parameters) is fitted on the
// held-in frames; so is each candidate extension (the base parameters plus the extension's
// own; the same starts for the base parameters, the same iterations), and a placebo of the
// same number of extra parameters that stand for no missing effect (initial velocity
// components the base leaves alone, those the body's motion does not use first). The base,
// the placebos and the extensions with an "off" value (friction, air drag, a stiffness
// gradient) share one graph and are fitted as one batch, each start moving only its own
// model's parameters; the Neo-Hookean material and a second plane (proposed from where the
// base fit overshoots the data) are batches of their own.
// Each fitted model then predicts the held-out frames; a candidate's gain is the fraction of
// the base model's held-out cost (J_SSC) it removes, with a moving-block bootstrap interval
// over the held-out frames. A candidate is named when its gain is at least `min_gain` and its
// interval's lower end beats its placebo's gain by `margin`; the cause is the named candidate
// with the largest gain, or "none". Two named candidates whose gains differ by less than their
// difference's interval are reported as confounded. Each candidate is also scored, in-sample
// with an Akaike penalty, on the held-in frames after the event it is about (reported only).
// Identifiability: at the cause's fit, the Gauss-Newton matrix of the held-in residuals over
// its parameters, the other candidates' that share its graph and the mass damping
// (parameter_correlation below); two of them with a correlation near +-1 trade one for the
// other: the data cannot tell them apart ("air drag or mass damping").
// A score test ranks the candidates that have parameters with an "off" value: the held-in
// cost's gradient at the base fit with the extension at off (friction, air drag, a stiffness
// gradient: one backward pass for all), as the cost decrease it predicts for a typical amount
// of the effect.
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

#include "models/sim/problem.h"

namespace ssc {

inline const std::vector<std::string>& diagnosis_candidate_names() {
  static const std::vector<std::string> names = {"friction", "heterogeneous_stiffness", "second_plane",
                                                 "nonlinear_material", "air_drag"};
  return names;
}

struct DiagnosisOptions {
  std::vector<std::string> fit = {"youngs_modulus"};  // the base model's fitted parameters
  std::vector<std::string> candidates = diagnosis_candidate_names();
  int starts = 8, iterations = 30;
  std::uint64_t seed = 1;
  std::string optimizer = "rprop";
  std::string device = "cpu";
  double holdout = 0.3;     // the last fraction of the frames, held out
  double min_gain = 0.2;    // of the base model's held-out cost
  double margin = 0.05;     // over the placebo's gain
  int bootstrap = 2000;
};

// One fitted model (the base, a candidate or a placebo).
struct FittedModel {
  std::string name;
  Problem problem;                       // the model's scene (with the extension on), all frames
  std::vector<std::string> names;        // fitted parameters
  Eigen::VectorXd values;                // their fitted values
  std::vector<std::string> extra;        // the extension's own parameters (a subset of names)
  std::vector<double> frame_costs;       // every frame's J_SSC term at the fit
  double heldin_cost = 0, heldout_cost = 0;
  bool failed = false;
  std::string failure, note;
  double seconds = 0;
};

struct CandidateVerdict {
  std::string name;
  double gain = 0, gain_low = 0, gain_high = 0;  // fraction of the base's held-out cost removed
  double placebo_gain = 0;
  double score = std::numeric_limits<double>::quiet_NaN();  // predicted relative held-in decrease
  bool passes = false;
  // The frames after the event the extension is about (the first contact with any plane; with
  // the added plane for second_plane; frame 0 for air drag), held-in part: the fraction of the
  // base's cost removed there, and the Akaike difference n ln(RSS / RSS_base) + 2 k over its n
  // observed points (negative favours the extension; k its extra parameters). -1: no event.
  int event_frame = -1;
  double event_gain = std::numeric_limits<double>::quiet_NaN();
  double event_aic = std::numeric_limits<double>::quiet_NaN();
  std::vector<std::string> warnings;
};

// How well the data determine parameters at a point: the Gauss-Newton matrix J^T J of the
// cost's residuals (each observed point's robust residual r, its cost term r^2 / 2), J from
// forward differences (step steps[j]) of n + 1 simulations run as one batch; its inverse (the
// parameters' covariance up to a factor) scaled to a unit diagonal is their correlation. A
// correlation near +-1: the data fix a combination of the two, not each. Parameters the
// residuals do not depend on there are left out (`flat`); `failure` says why there is no
// correlation (fewer than two parameters left).
struct ParameterCorrelation {
  std::vector<std::string> names, flat;  // names: the parameters of gauss_newton and correlation
  Eigen::MatrixXd gauss_newton, correlation;
  std::string failure;
};
ParameterCorrelation parameter_correlation(const Problem& problem, const PhysicalParameters& at,
                                           const std::vector<std::string>& names, const std::vector<double>& steps,
                                           const std::string& device);

struct Diagnosis {
  int heldin_frames = 0, heldout_frames = 0;
  double heldout_from = 0;  // time of the first held-out frame, s
  FittedModel base;
  std::vector<FittedModel> candidates, placebos;  // a placebo per count of extra parameters (1..3) a candidate has
  std::vector<CandidateVerdict> verdicts;         // one per candidate, in the order fitted
  std::string cause = "none";
  std::vector<std::pair<std::string, std::string>> confounded;
  ParameterCorrelation identifiability;  // at the cause's fit (empty names: not assessed)
  // Pairs of parameters whose correlation there is at least 0.95 in size, with it.
  std::vector<std::tuple<std::string, std::string, double>> indistinguishable;
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

}  // namespace ssc
