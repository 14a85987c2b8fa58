// Fitting a measurement candidate of `ssc diagnose`: the cameras' focal lengths, the depth
// unit or the frames' clock corrected (models/observation/measurement_correction.h), the
// physics as the base model has it.
//
// The correction is one number, found with the motion held: the base fit is simulated once,
// every step's state kept, and the value that best lays the held-in frames onto that motion
// is searched over the plausible range (a scan of 41 values, then golden-section search;
// a time offset interpolates between steps). Where the correction removes at least 2 % of the
// held-in cost, the base parameters are fitted again on the corrected frames (the base's
// starts, one batch), and the correction is searched again at that fit; at most two refits.
// A correction that removes less is kept with the base's parameters: a measurement that fits
// as recorded is not worth a batch. The time offset is rounded to the scene's steps for the refit.
#pragma once
#include <map>
#include <string>
#include <vector>

#include "models/diagnosis/model_fit.h"
#include "models/observation/measurement_correction.h"

namespace ssc {

// The correction a measurement parameter ("camera.focal_scale") at `value` stands for.
MeasurementCorrection measurement_correction(const std::string& parameter, double value);

// The problem with its observations corrected: the set, the frames (re-derived), and the
// scene's steps raised to the last frame. The time offset is rounded to the scene's steps.
void apply_measurement(Problem& p, const MeasurementCorrection& m, const std::string& observation_dir);

FittedModel fit_measurement(const ExtensionRow& row, const FittedModel& base, const DiagnosisContext& c,
                            std::vector<std::map<std::string, double>>& base_starts);

// The correction fitted with another model's physics (a discretization control's: its scene
// keys, problem and fitted values) as fit_measurement fits it with the base's: searched on that
// model's motion, and where it gains, that model refitted on the corrected frames from its own
// fit (one start) and the correction searched again. What of the residual that model leaves the
// measurement explains. `c` carries the cost threshold that model was fitted with.
FittedModel measurement_on(const ExtensionRow& row, const FittedModel& model, const DiagnosisContext& c);

}  // namespace ssc
