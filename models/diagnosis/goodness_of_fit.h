// How well a fit fits: the RMS of the matched observed points' residuals (their signed
// distances to the simulated surface, metres) against the depth noise those residuals should
// show, per frame and overall, and where structure above the noise remains.
//
// A depth error e of a pixel moves its point along the pixel's viewing ray, and the residual
// by e (r . n): n the surface normal at the match, r the ray scaled to unit z depth (noise of
// the stored depth) or to unit length (noise along the ray). So a point's residual noise has
// the variance var = sigma(z)^2 (r . n)^2 + q^2/12 (r_z . n)^2, where sigma(z) is the sensor's
// noise at the point's depth z and q the PNG depth quantum (depth_scale). The noise level of a
// set of points is sqrt(mean var); the ratio chi = RMS / noise is 1 for a fit at the noise.
//
// sigma(z) comes from cameras.json's depth_noise model where every camera gives one;
// otherwise it is estimated from the residuals: differences of horizontally and vertically
// neighbouring pixels cancel the part of the residual that is smooth across the image (a
// model error) and keep the pixel noise, so sigma = 1.4826 MAD of the pair differences
// (r_i - r_j) / sqrt(c_i^2 + c_j^2), c = |r_z . n|, floored at the quantisation q / sqrt(12).
// This assumes independent noise per pixel: depth that the sensor's software smoothed gives
// an estimate too low (and a ratio too high); give the model for such sensors.
#pragma once
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/diagnosis/residuals.h"
#include "models/sim/parameters.h"
#include "models/sim/problem.h"

namespace ssc {

// A fit is "above the noise" when its ratio exceeds this (docs/reconstruction.md says why)
// and it has at least kFitMinMatchedPoints matched points; a frame, phase, region or
// direction is named where structure remains when its ratio exceeds this and this times the
// overall ratio, with as many points.
inline constexpr double kAboveNoiseRatio = 1.5;
inline constexpr int kFitMinMatchedPoints = 50;

struct FitGroup {
  std::string kind;  // "all", "frame", "phase", "region", "direction"
  std::string name;  // "all", "frame 12", "contact with plane 0", "+x-y+z", "normal", "tangential"
  int points = 0, matched = 0;
  double rms_m = 0;    // of the matched points' residuals
  double noise_m = 0;  // their expected noise, sqrt(mean var)
  double ratio = 0;    // rms_m / noise_m
};

struct GoodnessOfFit {
  std::string noise_source;  // "cameras.json", "estimate" or "unknown" (the verdict says why)
  double estimated_sigma_m = std::numeric_limits<double>::quiet_NaN();  // "estimate": sigma of the z depth
  int estimate_pairs = 0;                                               // neighbouring pixel pairs the estimate used
  double quantisation_m = 0;                                            // depth_scale / sqrt(12)
  FitGroup overall;
  std::vector<FitGroup> frames;  // one per observed frame (time: frame_times_s)
  std::vector<double> frame_times_s;
  std::vector<FitGroup> groups;  // by phase, region and direction, as residual_summary groups them
  std::vector<FitGroup> above;   // the frames and groups where structure above the noise remains
  // Above the noise overall (ratio above kAboveNoiseRatio) or in some frames or groups (`above`).
  bool above_noise = false;
  // "at the noise", "below the noise (0.55 times)", "above the noise (2.3 times)", "above the
  // noise in frame 12 (2.6 times)", "too few matched points", "noise unknown (why)"
  std::string verdict;
  std::string warning;  // the message when above_noise, naming where and the likely causes
};

// Simulates the problem with `params` (on the GPU for device "cuda") and judges the fit.
GoodnessOfFit goodness_of_fit(const Problem& problem, const PhysicalParameters& params,
                              const std::string& device = "cpu");
// The same from residuals already computed for the problem.
GoodnessOfFit goodness_of_fit(const Problem& problem, const Residuals& residuals);

nlohmann::json goodness_json(const GoodnessOfFit& g);
// One line for a command's summary, e.g. "goodness of fit: RMS 1.49 mm over 6422 of 6422
// points (100.0 %) against noise 0.65 mm (cameras.json): 2.29 times, above the noise".
std::string goodness_line(const GoodnessOfFit& g);
// Raises the warning "fit_above_noise" (stderr and the run's warnings) when above the noise.
void warn_if_above_noise(const GoodnessOfFit& g);

}  // namespace ssc
