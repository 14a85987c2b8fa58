// Step 12 of `ssc diagnose` (docs/diagnosis.md): a physical cause refitted from its fit on each
// discretization control's discretization (half the cell size, half the time step), with the
// base's cost threshold, as the control. The controls refit the base model only; a cause's
// values can depend on the discretization where the base's do not: on 25 mm cells a soft cube
// sliding with friction tips over where on 12.5 mm cells it rocks back, and the modulus fitted
// with friction is a third higher. Not run for a measurement cause, or for a control that did
// not run. Where step 3's fits run side by side (on the GPU) the likely cause's refits join
// their queue, placed by weight, and are kept if it is named.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "models/diagnosis/fitted_model.h"
#include "models/diagnosis/model_fit.h"

namespace ssc {

struct ControlRefit {
  std::string control;  // finer_grid or finer_step
  ModelSpec spec;       // the cause's model with the control's overrides
};

// The refits of m's model on the controls named (those whose discretization applies).
std::vector<ControlRefit> control_refits(const FittedModel& m, const Scene& scene,
                                         const std::vector<std::string>& controls);
// One refit from m's values, on `device`, with the cost threshold phi_max.
DiscretizationCheck refit_on_control(const ControlRefit& r, const FittedModel& m, const DiagnosisContext& c,
                                     double phi_max, const std::string& device);
// The cause m's refits on the controls named, side by side.
std::vector<DiscretizationCheck> refit_on_controls(const FittedModel& m, const std::vector<std::string>& controls,
                                                   const DiagnosisContext& c, const Scene& scene, double phi_max);
// Of the shared batch's fits, the one with the largest held-out gain over the base where it
// clears the gain bar ("" where none does): the likely cause.
std::string likely_cause(const FittedModel& base, int heldin_frames,
                         const std::map<std::string, FittedModel>& shared_fits, const DiagnosisOptions& o);
// Of the checks run ahead, those of the controls named, in their order.
std::vector<DiscretizationCheck> checks_of(const std::vector<std::string>& controls,
                                           const std::vector<DiscretizationCheck>& early);
// The printed line of one check.
std::string control_check_line(const DiscretizationCheck& g, const std::string& cause);

}  // namespace ssc
