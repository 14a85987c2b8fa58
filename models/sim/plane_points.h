// Observed points that lie on a contact plane of the scene are the support (a table patch
// that segmentation left around the body), not the body: the cost matches many of them to
// the body's contact side and the fit bends the body towards the table: a confident wrong
// modulus, with most points matched and every start agreeing.
//
// A point is on a plane when its signed distance to it is within the band
// kPlaneBandSigmas x the depth noise (the largest of the cameras' depth_noise models at their
// median measured depth, else kDefaultDepthNoise) plus one depth unit (quantisation). The body's own surface near the plane (the strip of its
// sides just above it) is told apart by what lies above it: a point on the plane whose
// position along the plane is within max(kFootprintMargin, 2 x band) of an observed point
// above the band is under or beside the body and is not counted.
//  - more than kTablePointsWarning of a frame's points on a plane: warning `table_points`;
//  - more than kTablePointsError: InputError naming the plane and the fix.
#pragma once
#include <string>
#include <vector>

#include "models/observation/observation_set.h"
#include "models/sim/gradient.h"
#include "models/sim/scene.h"

namespace ssc {

constexpr double kPlaneBandSigmas = 3;
constexpr double kDefaultDepthNoise = 2e-3;  // m
constexpr double kFootprintMargin = 0.01;    // m
constexpr double kTablePointsWarning = 0.02, kTablePointsError = 0.1;

// The depth noise (m) the band is made of, and where it comes from.
double plane_depth_noise(const ObservationSet& set, std::string* source = nullptr);
// The band (m) within which a point counts as lying on a plane.
double plane_band(const ObservationSet& set);

// Per frame, the number of its points that lie on planes[k] and not under the body.
std::vector<long> table_points(const std::vector<ObservedFrame>& frames, const PlaneSpec& plane, double band);

// Warns or throws (see above); dir names the observation folder.
void check_table_points(const std::vector<ObservedFrame>& frames, const std::vector<PlaneSpec>& planes,
                        const ObservationSet& set, const std::string& dir);

}  // namespace ssc
