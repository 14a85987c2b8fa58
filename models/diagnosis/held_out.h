// The diagnosis's statistics over frames: the fraction of the base model's cost a model
// removes over a range of frames, with a moving-block bootstrap interval; residual sums for
// the Akaike comparison; the frame from which an extension acts.
#pragma once
#include <cstdint>
#include <utility>
#include <vector>

#include "models/diagnosis/fitted_model.h"

namespace ssc {

struct Gain {
  double value = 0, low = 0, high = 0;  // the fraction removed and its (5 %, 95 %) interval
};

// Over frames [from, to) of the per-frame costs (to = -1: to the end); resamples 1 gives the
// value alone.
Gain cost_gain(const std::vector<double>& base, const std::vector<double>& model, int from, int to, int resamples,
               std::uint64_t seed);

// Twice the summed point costs of frames [from, to): the residual sum of squares for small
// residuals (surface_constraint.h), and the number of observed points there.
std::pair<double, double> residual_sum(const std::vector<double>& frame_costs, const Problem& p, int from, int to);

// The first frame from which an extension acts in its fit (see CandidateVerdict), -1 if never.
int event_frame(const FittedModel& m, const std::string& device);

}  // namespace ssc
