// What `ssc diagnose` is asked for and what one of its fits gives: the options, and a fitted
// model (the base, a candidate or a placebo) with its per-frame costs (see diagnosis.h).
#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "models/sim/extensions.h"
#include "models/sim/problem.h"

namespace ssc {

struct ModelSpec;  // models/diagnosis/model_fit.h

struct DiagnosisOptions {
  std::vector<std::string> fit = {"youngs_modulus"};  // the base model's fitted parameters
  std::vector<std::string> candidates = extension_names();
  int starts = 8, iterations = 30;
  std::uint64_t seed = 1;
  std::string optimizer = "lm";  // Levenberg-Marquardt: its fits stop on convergence (docs/diagnosis.md)
  std::string device = "cpu";
  double holdout = 0.3;     // the last fraction of the frames, held out
  double min_gain = 0.2;    // of the base model's held-out cost
  double margin = 0.05;     // over the placebo's gain
  int bootstrap = 2000;
  // The discretization controls: the base refitted on half the cell size and on half the time
  // step; a candidate must also beat their gains (candidates.h, discretization_controls).
  bool discretization_controls = true;
};

// How one start of a fit ended: its stop reason, accepted iterations, and the held-in cost after
// each (the first entry at the start point).
struct FitStart {
  std::string stop_reason;
  int iterations = 0;
  std::vector<double> costs;
  int restarts = 0;  // how often it went on from a stall (models/optim/reconstruction.cpp)
  int rounds = 0;    // the batches it took part in (StartRecord::rounds)
};

// A proposal fitted beside the one kept (the best of several planes, fitted as one batch).
struct OtherProposal {
  std::string proposal;
  bool failed = false;
  double heldin_cost = 0;
  std::vector<FitStart> per_start;
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
  std::string stop_reason;         // of the best start
  int starts = 0, converged_starts = 0;
  std::vector<FitStart> per_start;
  std::string proposal;            // what the data proposed (a plane, an interface), if anything
  std::vector<OtherProposal> other_proposals;  // fitted in the same batch, not kept
  std::shared_ptr<const ModelSpec> spec;  // what was fitted: the scene keys and parameters of its model
  double seconds = 0;
  int batches = 0;  // of simulations, of the fit this model was part of (ReconstructionResult::batches)
};

// A model refitted on a discretization control's discretization (half the cell size, half the
// time step), from its fit.
struct DiscretizationCheck {
  std::string control;  // finer_grid or finer_step
  FittedModel fit;      // failed with the reason where its fit failed
  std::vector<std::tuple<std::string, double, double>> moved;  // by 10 % or more: (name, as fitted, there)
};

}  // namespace ssc
