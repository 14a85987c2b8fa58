// Whether the observed points fall on the simulated body: a fit on points that match
// nothing returns its start, and one on unsegmented depth (floor, background) is biased.
//  - fewer than kMinMatchedFraction of all observed points matched to the body at the
//    evaluated parameters: InputError listing the usual causes;
//  - more than kUnsegmentedFraction unmatched in every frame: a warning (recorded) that the
//    depth is probably not segmented.
// Unmatched: the point lies in no cell of the body's grid and its band (ssc cost).
#pragma once
#include <string>
#include <vector>

#include "models/cost/surface_constraint.h"

namespace ssc {

constexpr double kMinMatchedFraction = 0.2;
constexpr double kUnsegmentedFraction = 0.3;

// where: the observation folder; at: the parameters evaluated ("the best fit", ...).
void check_matches(const std::vector<FrameCost>& frames, const std::string& where, const std::string& at);

}  // namespace ssc
