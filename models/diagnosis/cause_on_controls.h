// Step 12 of `ssc diagnose` (docs/diagnosis.md): a physical cause refitted from its fit on each
// discretization control's discretization (half the cell size, half the time step), with the
// base's cost threshold, as the control. The controls refit the base model only; a cause's
// values can depend on the discretization where the base's do not: on 25 mm cells a soft cube
// sliding with friction tips over where on 12.5 mm cells it rocks back, and the modulus fitted
// with friction is a third higher. Not run for a measurement cause, or for a control that did
// not run. Where step 3's fits run side by side (on the GPU) the likely cause's refits are
// queued behind them and kept if it is named.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "models/diagnosis/diagnosis.h"
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
Diagnosis::DiscretizationCheck refit_on_control(const ControlRefit& r, const FittedModel& m, const DiagnosisContext& c,
                                                double phi_max, const std::string& device);
// The controls that ran, in the order of discretization_controls().
std::vector<std::string> controls_that_ran(const Diagnosis& d);
// The cause m's refits on the controls that ran, side by side, into d.cause_on_controls.
void refit_cause_on_controls(Diagnosis& d, const DiagnosisContext& c, const Scene& scene, const FittedModel& m);
// The shared batch's candidate with the largest held-out gain over the base where it clears
// the gain bar ("" where none does): the likely cause.
std::string likely_cause(const Diagnosis& d, const std::map<std::string, FittedModel>& shared_fits,
                         const DiagnosisOptions& o);
// The refits run ahead, for the controls that ran, into d.cause_on_controls.
void keep_early_refits(Diagnosis& d, const std::vector<Diagnosis::DiscretizationCheck>& early);
// The printed line of one check.
std::string control_check_line(const Diagnosis::DiscretizationCheck& g, const std::string& cause);

}  // namespace ssc
